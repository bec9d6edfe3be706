"""The Fourier-feature network of Tojo et al. (2022), eq. 1 and 2, evaluated without torch.

``x(t) = [t, sin 2 pi w_1 t, cos 2 pi w_1 t, ..., sin 2 pi w_K t, cos 2 pi w_K t]`` with ``t`` in [0, 1] and
``w_k`` in cycles over the clip; ``F(x) = W2 ELU(W1 ELU(W0 x + b0) + b1) + b2``.

Decoding is one compiled loop (``motionrep.jit``) per block of :data:`ROWS` times: the inputs ``x`` in float64
(as in training), then every layer a sum over its inputs in a fixed order (bias first), vectorised over the
times of the block and not over the sum, so a time decodes to the same bits alone or in any batch and on any
x86-64 CPU (IEEE arithmetic, no fused multiply-add, no BLAS).  The precision is the payload version's
(:func:`network_dtype`): **float32** (the precision the network was trained in and its weights are stored in;
ELU from a polynomial, below) from payload version 3, **float64** for payload versions 1 and 2, which were
measured in float64 when they were written (ELU from ``expm1``), so that every older file decodes to what was
measured.  The core measures the bound on exactly these values (``Codec.decode``
returns them as float64).

One kernel serves a single network and a clip in windows (``_windows``; a quantised payload is dequantised to
the same arrays first): each time is decoded by the network of the window it falls in, at its local time, the
call's times grouped by window first (:data:`GROUP` at a time) so that each network runs on whole blocks.  It writes the features **feature-major**
(``out[d, i]``, the layout of the runtime decoder's blocks, ``motionrep.model.poseplan``).
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep.plugin.codec import CompiledDecoder
from motionrep.jit import affine_block, affine_one, jit, jit_inline, sincos

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
    """The decoder's float32 ELU of ``x`` (see :func:`_elu`), for tests and benchmarks."""
    a = np.ascontiguousarray(x, dtype=np.float32)
    out = np.empty_like(a)
    _elu_array(a.reshape(-1), out.reshape(-1))
    return out


@jit
def _elu_array(a, out):
    for i in range(a.size):
        out[i] = _elu(a[i])


@jit_inline
def _elu_block(Z, rows, m, double):
    """ELU of ``Z[:rows, :m]`` in place: ``expm1`` in float64 (``double``), the polynomial :func:`_elu` in
    float32."""
    if double:
        for u in range(rows):
            for i in range(m):
                z = Z[u, i]
                Z[u, i] = z if z >= 0.0 else np.expm1(z)
    else:
        for u in range(rows):
            for i in range(m):
                Z[u, i] = _elu(Z[u, i])


@jit_inline
def _elu_vector(z, rows, double):
    if double:
        for u in range(rows):
            v = z[u]
            z[u] = v if v >= 0.0 else np.expm1(v)
    else:
        for u in range(rows):
            z[u] = _elu(z[u])


@jit
def _networks_kernel(times, out, frames, windowed, double, edges, ks, hs, omega, offsets, weights, b2):
    """``out[:, :T]`` (``(D, >= T)`` float64, feature-major) = the networks at ``times (T,)``, each time by the
    window it falls in (``windowed``: window ``s`` covers frame positions ``edges[s] .. edges[s + 1]``, a shared
    boundary frame taken by the later window, at the local time ``(t (F - 1) - edges[s]) / (edges[s + 1] -
    edges[s])``; otherwise one network at ``t`` itself).  Window ``s`` has ``ks[s]`` frequencies starting at
    ``omega[sum ks[:s]]``, ``hs[s]`` hidden units and its weights at ``weights[offsets[s, :]]`` (W0, b0, W1, b1,
    W2, then W0T, W1T, W2T), arithmetic in ``weights.dtype``; its output bias is ``b2[s]``.

    The times are taken :data:`GROUP` at a time and grouped by window (a stable counting sort), and each
    window's times of the group run through its network :data:`ROWS` at a time: times in random order spread
    over the windows still fill whole blocks.  Every time's sums are the same whatever block it is in (see the
    module docstring), so the grouping changes no bit."""
    T, S, D = times.shape[0], ks.shape[0], b2.shape[1]
    dt = weights.dtype
    cast = dt.type
    kmax, H = 0, 0
    for s in range(S):
        kmax = max(kmax, ks[s])
        H = max(H, hs[s])
    I = 2 * kmax + 1
    first_omega = np.zeros(S + 1, np.int64)
    for s in range(S):
        first_omega[s + 1] = first_omega[s] + ks[s]
    X = np.empty((I, ROWS), dt)  # activations are (units, times): the sums vectorise over times
    H0 = np.empty((H, ROWS), dt)
    H1 = np.empty((H, ROWS), dt)
    Y = np.empty((D, ROWS), dt)
    x1, z0, z1, y1 = np.empty(I, dt), np.empty(H, dt), np.empty(H, dt), np.empty(D, dt)
    G = max(1, min(GROUP, T))
    window = np.empty(G, np.int64)
    tau = np.empty(G)
    order = np.empty(G, np.int64)  # the group's times grouped by window
    local = np.empty(ROWS)
    start = np.empty(S + 1, np.int64)
    two_pi = 2.0 * np.pi
    for a in range(0, T, G):
        m = min(G, T - a)
        for s in range(S + 1):
            start[s] = 0
        for i in range(m):
            t = times[a + i]
            s = 0
            if windowed:
                x = t * (frames - 1)
                lo, hi = 0, S - 1  # the last s with edges[s] <= x (searchsorted on the inner edges, right)
                while lo < hi:
                    mid = (lo + hi + 1) // 2
                    if edges[mid] <= x:
                        lo = mid
                    else:
                        hi = mid - 1
                s = lo
                tau[i] = (x - edges[s]) / (edges[s + 1] - edges[s])
            else:
                tau[i] = t
            window[i] = s
            start[s + 1] += 1
        for s in range(S):
            start[s + 1] += start[s]
        for i in range(m):  # counting sort: order[start[s]:start[s + 1]] are window s's rows
            s = window[i]
            order[start[s]] = i
            start[s] += 1
        begin = 0
        for s in range(S):
            end = start[s]
            if end == begin:
                continue
            identity = end - begin == m  # the whole group in one window: the (stable) order is the identity
            K, h = ks[s], hs[s]
            inputs = 2 * K + 1
            o = offsets[s]
            W0 = weights[o[0]:o[0] + h * inputs].reshape((h, inputs))
            bias0 = weights[o[1]:o[1] + h]
            W1 = weights[o[2]:o[2] + h * h].reshape((h, h))
            bias1 = weights[o[3]:o[3] + h]
            W2 = weights[o[4]:o[4] + D * h].reshape((D, h))
            w_omega = omega[first_omega[s]:first_omega[s] + K]
            for c in range(begin, end, ROWS):
                n = min(ROWS, end - c)
                if n == 1:  # one time: the same sums, vectorised over the units (affine_one)
                    t = tau[order[c]]
                    x1[0] = cast(t)
                    for k in range(K):
                        sn, cs = sincos(two_pi * t * w_omega[k])
                        x1[1 + 2 * k] = cast(sn)
                        x1[2 + 2 * k] = cast(cs)
                    # whole scratch arrays, not slices: the layers touch only their rows, and contiguous arrays
                    # keep the loops vectorised (slices are typed as strided)
                    affine_one(weights[o[5]:o[5] + inputs * h].reshape((inputs, h)), bias0, x1, z0)
                    _elu_vector(z0, h, double)
                    affine_one(weights[o[6]:o[6] + h * h].reshape((h, h)), bias1, z0, z1)
                    _elu_vector(z1, h, double)
                    affine_one(weights[o[7]:o[7] + h * D].reshape((h, D)), b2[s], z1, y1)
                    i = a + order[c]
                    for d in range(D):
                        out[d, i] = y1[d]
                    continue
                for r in range(n):  # the block's times, contiguous: the sines below vectorise
                    local[r] = tau[order[c + r]]
                    X[0, r] = cast(local[r])
                for k in range(K):
                    for r in range(n):
                        sn, cs = sincos(two_pi * local[r] * w_omega[k])
                        X[1 + 2 * k, r] = cast(sn)
                        X[2 + 2 * k, r] = cast(cs)
                affine_block(W0, bias0, X, H0, n)  # whole scratch arrays, as above
                _elu_block(H0, h, n, double)
                affine_block(W1, bias1, H0, H1, n)
                _elu_block(H1, h, n, double)
                affine_block(W2, b2[s], H1, Y, n)
                if identity:
                    for d in range(D):
                        for r in range(n):
                            out[d, a + c + r] = Y[d, r]
                else:
                    for d in range(D):
                        for r in range(n):
                            out[d, a + order[c + r]] = Y[d, r]
            begin = end


class Networks(CompiledDecoder):
    """One network, or a clip's windows of networks, checked and converted once to the arithmetic's dtype,
    ready to decode any number of times.

    Attributes:
        width: features per time ``D``.
        dtype: the arithmetic (float32, or float64 for payload versions 1 and 2).
        kernel, kernel_args: the compiled decoder and its prepared arguments: ``kernel(times, out,
            *kernel_args)`` writes the features at ``times (T,)`` into ``out (D, >= T)`` float64, feature-major
            (what ``motionrep.open`` calls for each block of poses; a plain call runs it too,
            ``motionrep.plugin.codec.CompiledDecoder``).

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
        self.width, self.dtype = int(D), dt
        self.kernel = _networks_kernel
        self.kernel_args = (int(e[-1]) + 1, windowed, dt == np.float64, e, np.array(ks, np.int64),
                            np.array(hs, np.int64), np.concatenate(omegas) if omegas else np.zeros(0), offsets, weights,
                            np.ascontiguousarray(np.stack(biases), dtype=dt))


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
