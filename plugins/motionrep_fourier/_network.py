"""The Fourier-feature network of Tojo et al. (2022), eq. 1 and 2, evaluated without torch.

``x(t) = [t, sin 2 pi w_1 t, cos 2 pi w_1 t, ..., sin 2 pi w_K t, cos 2 pi w_K t]`` with ``t`` in [0, 1] and
``w_k`` in cycles over the clip; ``F(x) = W2 ELU(W1 ELU(W0 x + b0) + b1) + b2``.

Decoding is one C loop (``_c/module.c``, the extension ``_cfourier``) per block of :data:`ROWS` times: the inputs
``x`` in float64 (as in training), then every layer a sum over its inputs in a fixed order (bias first),
vectorised over the times of the block and not over the sum, so a time decodes to the same bits alone or in any
batch and on any x86-64 or aarch64 CPU (IEEE arithmetic, no fused multiply-add, no BLAS).  The precision is the
payload version's (:func:`network_dtype`): **float32** (the precision the network was trained in and its weights
are stored in; ELU from a polynomial, :func:`elu`) from payload version 3, **float64** for payload versions 1 and
2, which were measured in float64 when they were written (ELU from the C library's ``expm1``), so that every
older file decodes to what was measured.  The core measures the bound on exactly these values (``Codec.decode``
returns them as float64).

One kernel serves a single network and a clip in windows (``_windows``; a quantised payload is dequantised to
the same arrays first): each time is decoded by the network of the window it falls in, at its local time, the
call's times grouped by window first (:data:`GROUP` at a time) so that each network runs on whole blocks.  It
writes the features **feature-major** (``out[d, i]``, the layout of the runtime decoder's blocks,
``motionrep.model.poseplan``).
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep.plugin.codec import CompiledDecoder

__all__ = ["fourier_features", "elu", "Network", "Networks", "network_forward", "network_dtype", "ARRAY_NAMES",
           "ROWS", "GROUP"]

#: Payload arrays, in storage order.
ARRAY_NAMES = ("omega", "W0", "b0", "W1", "b1", "W2", "b2")
#: Times evaluated together: the block's activations stay in the CPU cache and in vector registers.
ROWS = 64
#: Times grouped by window before they are evaluated (one runtime block, ``motionrep.pipeline.runtime.BLOCK``, or more).
GROUP = 1024
#: Payload versions decoded in float64 (their files were measured in float64 when they were written).
FLOAT64_VERSIONS = (1, 2)
# per window, the offsets in the flat weights of W0, b0, W1, b1, W2 and of the transposes W0T, W1T, W2T
_PARTS = 8


def network_dtype(version: int) -> type:
    """The arithmetic of payload ``version``: float64 for versions 1 and 2, float32 from version 3."""
    return np.float64 if version in FLOAT64_VERSIONS else np.float32


def fourier_features(times: ArrayLike, omega: ArrayLike) -> NDArray[np.float64]:
    """``(T, 2K + 1)`` inputs ``[t, sin 2 pi w_1 t, cos 2 pi w_1 t, ...]`` for times ``(T,)`` and ``(K,)`` cycles,
    in float64 (training rounds them to float32; decoding computes the same values in its own loop)."""
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    w = np.asarray(omega, dtype=np.float64).reshape(-1)
    x = np.empty((t.size, 2 * w.size + 1))
    x[:, 0] = t
    angle = 2.0 * np.pi * t[:, None] * w[None, :]
    x[:, 1::2] = np.sin(angle)
    x[:, 2::2] = np.cos(angle)
    return x


def elu(x: ArrayLike) -> NDArray[np.float32]:
    """The decoder's float32 ELU of ``x``, element by element (``_c/module.c``): ``v`` for ``v >= 0``; for
    ``v < 0``, ``expm1(v)`` as ``expm1(2 y) = expm1(y) (expm1(y) + 2)`` applied six times to ``y = max(v, -30) /
    64`` (exact scaling), whose ``expm1`` is its Taylor polynomial of degree 8 (``|y| <= 0.47``: truncation below
    1e-8 relative); within a few float32 ulps of ``expm1``, branch-free so the loops around it vectorise.  For
    tests and benchmarks."""
    from . import _cfourier

    a = np.ascontiguousarray(x, dtype=np.float32)
    out = np.empty_like(a)
    _cfourier.elu(a.reshape(-1), out.reshape(-1))
    return out


class Networks(CompiledDecoder):
    """One network, or a clip's windows of networks, checked and converted once to the arithmetic's dtype,
    ready to decode any number of times.

    Attributes:
        width: features per time ``D``.
        dtype: the arithmetic (float32, or float64 for payload versions 1 and 2).
        kernel, kernel_args: the C decoder (``_c/module.c``) and its prepared arguments: ``kernel(times, out,
            *kernel_args)`` writes the features at ``times (T,)`` into ``out (D, >= T)`` float64, feature-major (a
            plain call runs it, ``motionrep.plugin.codec.CompiledDecoder``).
        sampler: the same for C callers (``motionrep.open`` calls it for each block of poses,
            ``motionrep/_c/include/motionrep/sampler.h``).

    Raises:
        ValueError: if the arrays' shapes do not fit together.
    """

    def __init__(self, windows: Sequence[Mapping[str, ArrayLike]], edges: ArrayLike | None = None, *,
                 dtype: type = np.float32):
        dt = np.dtype(dtype)
        ks, hs, omegas, parts, biases = [], [], [], [], []
        D = None
        for arrays in windows:
            a = {name: np.asarray(arrays[name]) for name in ARRAY_NAMES}
            K = a["omega"].reshape(-1).size
            h = a["b0"].shape[0] if a["b0"].ndim == 1 else -1
            width = a["b2"].shape[0] if a["b2"].ndim == 1 else -1
            expected = {"W0": (h, 2 * K + 1), "b0": (h,), "W1": (h, h), "b1": (h,), "W2": (width, h),
                        "b2": (width,)}
            for name, shape in expected.items():
                if a[name].shape != shape:
                    raise ValueError(f"array {name} has shape {a[name].shape}, expected {shape} for K={K}, hidden "
                                     f"{h}, width {width}")
            if D is not None and width != D:
                raise ValueError(f"the windows' networks give {D} and {width} features")
            D = width
            ks.append(K)
            hs.append(h)
            omegas.append(a["omega"].reshape(-1).astype(np.float64))
            parts += [a["W0"], a["b0"], a["W1"], a["b1"], a["W2"], a["W0"].T, a["W1"].T, a["W2"].T]
            biases.append(a["b2"])
        if D is None:
            raise ValueError("no network")
        sizes = np.array([p.size for p in parts], np.int64)
        offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]]).reshape(-1, _PARTS)
        weights = np.concatenate([np.ascontiguousarray(p, dtype=dt).ravel() for p in parts])
        windowed = edges is not None
        e = np.asarray([0, 1] if edges is None else edges, np.int64).reshape(-1)
        if e.size != len(ks) + 1 or e[0] != 0 or np.any(np.diff(e) < 1):
            raise ValueError(f"{len(ks)} networks need {len(ks) + 1} increasing window edges from 0, got "
                             f"{e.tolist()[:8]}")
        from . import _cfourier

        self.width, self.dtype = int(D), dt
        self._decoder = _cfourier.Decoder(int(e[-1]) + 1, windowed, dt == np.float64, np.ascontiguousarray(e),
                                          np.array(ks, np.int64), np.array(hs, np.int64),
                                          np.concatenate(omegas) if omegas else np.zeros(0),
                                          np.ascontiguousarray(offsets, dtype=np.int64), weights,
                                          np.ascontiguousarray(np.stack(biases), dtype=dt))
        self.kernel = _cfourier.sample
        self.kernel_args = (self._decoder,)

    @property
    def sampler(self):
        """The C sampler (a capsule) that ``motionrep.open`` calls for each block of poses."""
        return self._decoder.sampler


class Network(Networks):
    """One network's arrays (payload version 1, or an unwindowed later version), prepared once.

    Args:
        arrays: ``omega (K,)``, ``W0 (h, 2K + 1)``, ``b0 (h,)``, ``W1 (h, h)``, ``b1 (h,)``, ``W2 (D, h)``,
            ``b2 (D,)``, any float dtype.
        dtype: the arithmetic (:func:`network_dtype` of the payload version).
    """

    def __init__(self, arrays: Mapping[str, ArrayLike], *, dtype: type = np.float32):
        super().__init__([arrays], dtype=dtype)


def network_forward(arrays: Mapping[str, ArrayLike], times: ArrayLike, dtype: type = np.float32
                    ) -> NDArray[np.float64]:
    """``(T, D)`` network outputs at ``times`` (computed in ``dtype``, see the module docstring), as float64.

    Raises:
        ValueError: if the arrays' shapes do not fit together.
    """
    return Network(arrays, dtype=dtype)(times).astype(np.float64)
