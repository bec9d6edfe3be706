"""The CDF 9/7 wavelet over frames, by lifting, with whole-sample symmetric extension (JPEG 2000's irreversible
transform): ``n`` samples give exactly ``n`` coefficients at every length, the clip's ends are extended as mirror
images (no jump at the ends, unlike a periodic transform), and the subbands are scaled so that every synthesis
function has about unit norm (a quantisation error of ``e`` in any coefficient is an error of about ``e`` in
the signal, in the L2 sense).

PyWavelets has the same filters but only with extension modes that either add coefficients at the ends
(``symmetric``: more bits on short clips) or make the clip periodic (``periodization``: a jump from the last
frame to the first, more bits on long clips); this critically sampled symmetric form has neither cost. Arrays
are ``(frames, features)``; additions and multiplications in a fixed order (the same result on every run): the
forward transform (encoding) and the inverse (the decoder's own) in C (``_c/mrtransform.c``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["forward", "forward_rows", "inverse", "num_levels", "level_sizes", "coefficient_frames"]

# lifting coefficients of CDF 9/7 (alpha, beta, gamma, delta), JPEG 2000 Part 1, Annex F
_STEPS = (-1.586134342059924, -0.052980118572961, 0.882911075530934, 0.443506852043971)
# subband scaling: low-pass by sqrt(2) / K, high-pass by K / sqrt(2) (K = 1.230174104914001), so that the
# synthesis functions of every level have norm 1.00-1.05
_LOW = 1.1496043988602411
_HIGH = 0.8698644516247813
#: A level is added while the low-pass part has at least this many samples (so it keeps at least 2).
_MIN_SPLIT = 4
#: The most levels (2 ** 20 frames per low-pass sample is far beyond any clip).
MAX_LEVELS = 20


def num_levels(num_frames: int) -> int:
    """Levels of the transform of ``num_frames`` samples: halve while at least 4 remain, at most 20."""
    levels, n = 0, int(num_frames)
    while n >= _MIN_SPLIT and levels < MAX_LEVELS:
        n = (n + 1) // 2
        levels += 1
    return levels


def level_sizes(num_frames: int, levels: int) -> list[int]:
    """Sizes of the coefficient arrays in storage order: ``[approximation, detail L, ..., detail 1]``."""
    details = []
    n = int(num_frames)
    for _ in range(levels):
        details.append(n // 2)
        n = (n + 1) // 2
    return [n] + details[::-1]


def coefficient_frames(num_frames: int, levels: int) -> list[NDArray[np.int64]]:
    """The frame each coefficient is centred on, per array of :func:`level_sizes` (approximation ``i`` at
    ``i 2^L``, detail ``i`` of level ``j`` at ``(2 i + 1) 2^(j - 1)``), clipped to the clip."""
    sizes = level_sizes(num_frames, levels)
    out = [np.minimum(np.arange(sizes[0], dtype=np.int64) << levels, num_frames - 1)]
    for index, j in enumerate(range(levels, 0, -1), start=1):
        out.append(np.minimum(((2 * np.arange(sizes[index], dtype=np.int64) + 1) << (j - 1)), num_frames - 1))
    return out


def forward_rows(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(n, D)``: the coefficients of ``(n, D)`` samples at :func:`num_levels` ``(n)`` levels, the arrays of
    :func:`forward` one after the other (storage order), computed by the C analysis beside the decoder's inverse
    (``_c/mrtransform.c``, ``mrt_forward``: JPEG 2000's lifting steps ``d += a (s + s_right)``, ``s += a (d_left +
    d)`` with the mirrored ends, then the subbands scaled, one IEEE operation at a time in that order)."""
    from ._cdecode import forward as c_forward

    values = np.ascontiguousarray(x, dtype=np.float64)
    if values.ndim != 2:
        raise ValueError(f"forward: (n, D) samples, got shape {values.shape}")
    out = np.empty_like(values)
    c_forward(values, out)
    return out


def forward(x: NDArray[np.float64], levels: int) -> list[NDArray[np.float64]]:
    """``[approximation, detail L, ..., detail 1]`` of ``(n, D)`` samples (sizes :func:`level_sizes`; ``levels``
    must be :func:`num_levels` ``(n)``): :func:`forward_rows` split."""
    rows = forward_rows(x)
    if levels != num_levels(rows.shape[0]):
        raise ValueError(f"forward: levels must be num_levels({rows.shape[0]}), got {levels}")
    return np.split(rows, np.cumsum(level_sizes(rows.shape[0], levels))[:-1], axis=0)


def inverse(coefficients: list[NDArray[np.float64]]) -> NDArray[np.float64]:
    """The ``(n, D)`` samples of :func:`forward`'s output (exact up to float rounding): the C decoder's inverse
    (``_c/mrtransform.c``, ``mrt_inverse``), the one the payloads are decoded with."""
    from ._cdecode import inverse as c_inverse

    joined = coefficients[0] if len(coefficients) == 1 else np.concatenate(coefficients, axis=0)
    values = np.ascontiguousarray(joined, dtype=np.float64)  # (read only)
    out = np.empty_like(values)
    c_inverse(values, out)
    return out
