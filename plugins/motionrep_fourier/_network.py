"""The Fourier-feature network of Tojo et al. (2022), eq. 1 and 2, evaluated with numpy (no torch).

``x(t) = [t, sin 2 pi w_1 t, cos 2 pi w_1 t, ..., sin 2 pi w_K t, cos 2 pi w_K t]`` with ``t`` in [0, 1] and
``w_k`` in cycles over the clip; ``F(x) = W2 ELU(W1 ELU(W0 x + b0) + b1) + b2``.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["fourier_features", "elu", "network_forward", "ARRAY_NAMES", "ROWS"]

#: Payload arrays, in storage order.
ARRAY_NAMES = ("omega", "W0", "b0", "W1", "b1", "W2", "b2")
#: Times evaluated together by :func:`network_forward`: the temporaries of a block stay in the CPU cache and are
#: reused (fresh pages for large temporaries cost more than the arithmetic at these sizes).
ROWS = 1024


def fourier_features(times: ArrayLike, omega: ArrayLike) -> NDArray[np.float64]:
    """``(T, 2K + 1)`` inputs ``[t, sin 2 pi w_1 t, cos 2 pi w_1 t, ...]`` for times ``(T,)`` and ``(K,)`` cycles."""
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    w = np.asarray(omega, dtype=np.float64).reshape(-1)
    x = np.empty((t.size, 2 * w.size + 1))
    x[:, 0] = t
    angle = 2.0 * np.pi * t[:, None] * w[None, :]
    x[:, 1::2] = np.sin(angle)
    x[:, 2::2] = np.cos(angle)
    return x


def elu(x: NDArray[np.float64], out: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Exponential linear unit (alpha 1): ``x`` for ``x >= 0``, ``exp(x) - 1`` (``expm1``) for ``x < 0``;
    into ``out`` (which may be ``x``) when given."""
    x = np.asarray(x, dtype=np.float64)
    negative = np.minimum(x, 0.0)
    np.expm1(negative, out=negative)  # expm1(0) = 0, so x >= 0 gets x + 0 = x
    out = np.maximum(x, 0.0, out=out)
    out += negative
    return out


def network_forward(arrays: Mapping[str, ArrayLike], times: ArrayLike) -> NDArray[np.float64]:
    """``(T, D)`` network outputs at ``times``, computed in float64 from the stored arrays.

    Raises:
        ValueError: if the arrays' shapes do not fit together.
    """
    a = {name: np.asarray(arrays[name], dtype=np.float64) for name in ARRAY_NAMES}
    K = a["omega"].reshape(-1).size
    h = a["b0"].shape[0] if a["b0"].ndim == 1 else -1
    D = a["b2"].shape[0] if a["b2"].ndim == 1 else -1
    expected = {"W0": (h, 2 * K + 1), "b0": (h,), "W1": (h, h), "b1": (h,), "W2": (D, h), "b2": (D,)}
    for name, shape in expected.items():
        if a[name].shape != shape:
            raise ValueError(f"array {name} has shape {a[name].shape}, expected {shape} for K={K}, hidden {h}, "
                             f"width {D}")
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    out = np.empty((t.size, D))
    z0, z1 = np.empty((min(ROWS, t.size), h)), np.empty((min(ROWS, t.size), h))
    for start in range(0, t.size, ROWS):  # each row depends only on its own time
        rows = slice(start, min(start + ROWS, t.size))
        n = rows.stop - rows.start
        hidden = np.matmul(fourier_features(t[rows], a["omega"]), a["W0"].T, out=z0[:n])
        hidden += a["b0"]
        elu(hidden, out=hidden)
        hidden = np.matmul(hidden, a["W1"].T, out=z1[:n])
        hidden += a["b1"]
        elu(hidden, out=hidden)
        block = np.matmul(hidden, a["W2"].T, out=out[rows])
        block += a["b2"]
    return out
