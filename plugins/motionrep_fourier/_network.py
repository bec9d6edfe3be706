"""The Fourier-feature network of Tojo et al. (2022), eq. 1 and 2, evaluated without torch.

``x(t) = [t, sin 2 pi w_1 t, cos 2 pi w_1 t, ..., sin 2 pi w_K t, cos 2 pi w_K t]`` with ``t`` in [0, 1] and
``w_k`` in cycles over the clip; ``F(x) = W2 ELU(W1 ELU(W0 x + b0) + b1) + b2``.

Decoding is one compiled loop (``motionrep.jit``) per block of :data:`ROWS` times, in **float32**, the precision
the network was trained in and its weights are stored in: the inputs ``x`` in float64 (as in training), then
rounded; every layer a sum over its inputs in a fixed order (bias first), vectorised over the times of the block
and not over the sum, so a time decodes to the same bits alone or in any batch and on any x86-64 CPU (IEEE
arithmetic, no fused multiply-add, no BLAS); ELU from a polynomial (below).  The core measures the bound on
exactly these values (``Codec.decode`` returns them as float64).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep.jit import affine_block, affine_one, jit, jit_inline, sincos

__all__ = ["fourier_features", "elu", "Network", "network_forward", "ARRAY_NAMES", "ROWS"]

#: Payload arrays, in storage order.
ARRAY_NAMES = ("omega", "W0", "b0", "W1", "b1", "W2", "b2")
#: Times evaluated together: the block's activations stay in the CPU cache and in vector registers.
ROWS = 64


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


@jit_inline
def _elu(v):
    """ELU (alpha 1) of a float32 ``v``: ``v`` for ``v >= 0``; for ``v < 0``, ``expm1(v)`` as
    ``expm1(2 y) = expm1(y) (expm1(y) + 2)`` applied six times to ``y = max(v, -30) / 64`` (exact scaling), whose
    ``expm1`` is its Taylor polynomial of degree 8 (``|y| <= 0.47``: truncation below 1e-8 relative); within a
    few float32 ulps of ``expm1``, branch-free so the loops around it vectorise."""
    y = np.float32(max(v, np.float32(-30.0)) * np.float32(0.015625))
    e = y * (np.float32(1.0) + y * (np.float32(0.5) + y * (np.float32(1.0 / 6.0) + y * (np.float32(1.0 / 24.0) + y * (
        np.float32(1.0 / 120.0) + y * (np.float32(1.0 / 720.0) + y * (np.float32(1.0 / 5040.0) + y * np.float32(
            1.0 / 40320.0))))))))
    for _ in range(6):
        e = e * (e + np.float32(2.0))
    return v if v >= np.float32(0.0) else e


def elu(x: ArrayLike) -> NDArray[np.float32]:
    """The decoder's ELU of ``x`` (float32, see :func:`_elu`), for tests and benchmarks."""
    a = np.ascontiguousarray(x, dtype=np.float32)
    out = np.empty_like(a)
    _elu_array(a.reshape(-1), out.reshape(-1))
    return out


@jit
def _elu_array(a, out):
    for i in range(a.size):
        out[i] = _elu(a[i])


@jit
def _forward(times, omega, W0, b0, W1, b1, W2, b2, W0T, W1T, W2T, out):
    """``out (T, D)`` = the network at ``times (T,)`` (float64); weights float32 ``W0 (h, I)``, ``W1 (h, h)``,
    ``W2 (D, h)`` and their transposes (for one time); biases float32; ``omega (K,)`` float64."""
    T, K = times.shape[0], omega.shape[0]
    if T == 1:
        _forward_one(times[0], omega, b0, b1, b2, W0T, W1T, W2T, out[0])
        return
    h, I, D = W0.shape[0], W0.shape[1], W2.shape[0]
    X = np.empty((I, ROWS), np.float32)  # activations are (units, times): the sums vectorise over times
    H0 = np.empty((h, ROWS), np.float32)
    H1 = np.empty((h, ROWS), np.float32)
    Y = np.empty((D, ROWS), np.float32)
    two_pi = 2.0 * np.pi
    for a in range(0, T, ROWS):
        m = min(ROWS, T - a)
        for i in range(m):
            X[0, i] = times[a + i]
        for k in range(K):
            for i in range(m):
                s, c = sincos(two_pi * times[a + i] * omega[k])
                X[1 + 2 * k, i] = s
                X[2 + 2 * k, i] = c
        affine_block(W0, b0, X, H0, m)
        _elu_block(H0, m)
        affine_block(W1, b1, H0, H1, m)
        _elu_block(H1, m)
        affine_block(W2, b2, H1, Y, m)
        for i in range(m):
            for d in range(D):
                out[a + i, d] = Y[d, i]


@jit_inline
def _elu_block(Z, m):
    for u in range(Z.shape[0]):
        for i in range(m):
            Z[u, i] = _elu(Z[u, i])


@jit
def _forward_one(t, omega, b0, b1, b2, W0T, W1T, W2T, out):
    """The network at one time: the same sums as the block path (``affine_one``: bias first, inputs in order),
    vectorised over the units instead of the times."""
    K, h = omega.shape[0], b0.shape[0]
    x = np.empty(2 * K + 1, np.float32)
    x[0] = t
    for k in range(K):
        s, c = sincos(2.0 * np.pi * t * omega[k])
        x[1 + 2 * k] = s
        x[2 + 2 * k] = c
    z0 = np.empty(h, np.float32)
    z1 = np.empty(h, np.float32)
    affine_one(W0T, b0, x, z0)
    for u in range(h):
        z0[u] = _elu(z0[u])
    affine_one(W1T, b1, z0, z1)
    for u in range(h):
        z1[u] = _elu(z1[u])
    affine_one(W2T, b2, z1, out)


class Network:
    """One network's arrays, checked and converted once, ready to decode any number of times.

    Args:
        arrays: ``omega (K,)``, ``W0 (h, 2K + 1)``, ``b0 (h,)``, ``W1 (h, h)``, ``b1 (h,)``, ``W2 (D, h)``,
            ``b2 (D,)``, any float dtype.

    Raises:
        ValueError: if the arrays' shapes do not fit together.
    """

    def __init__(self, arrays: Mapping[str, ArrayLike]):
        a = {name: np.asarray(arrays[name]) for name in ARRAY_NAMES}
        K = a["omega"].reshape(-1).size
        h = a["b0"].shape[0] if a["b0"].ndim == 1 else -1
        D = a["b2"].shape[0] if a["b2"].ndim == 1 else -1
        expected = {"W0": (h, 2 * K + 1), "b0": (h,), "W1": (h, h), "b1": (h,), "W2": (D, h), "b2": (D,)}
        for name, shape in expected.items():
            if a[name].shape != shape:
                raise ValueError(f"array {name} has shape {a[name].shape}, expected {shape} for K={K}, hidden {h}, "
                                 f"width {D}")
        self.width = D
        self._omega = np.ascontiguousarray(a["omega"].reshape(-1), dtype=np.float64)
        self._weights = [np.ascontiguousarray(a[n], dtype=np.float32) for n in ARRAY_NAMES[1:]]
        self._weights += [np.ascontiguousarray(self._weights[i].T) for i in (0, 2, 4)]  # W0T, W1T, W2T

    def __call__(self, times: ArrayLike, out: NDArray[np.float32] | None = None) -> NDArray[np.float32]:
        """``(T, D)`` float32 outputs at ``times`` ``(T,)`` (into ``out`` when given)."""
        t = np.ascontiguousarray(times, dtype=np.float64).reshape(-1)
        if out is None:
            out = np.empty((t.size, self.width), np.float32)
        _forward(t, self._omega, *self._weights, out)
        return out


def network_forward(arrays: Mapping[str, ArrayLike], times: ArrayLike) -> NDArray[np.float64]:
    """``(T, D)`` network outputs at ``times`` (computed in float32, see the module docstring), as float64.

    Raises:
        ValueError: if the arrays' shapes do not fit together.
    """
    return Network(arrays)(times).astype(np.float64)

