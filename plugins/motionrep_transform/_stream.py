"""The bytes of a ``transform`` payload (format 1): quantised wavelet coefficients, range-coded with context
models (``motionrep.plugin.coding``). Layout in ``specs/codecs.md``.  :func:`pack` writes them (numpy and the
range coder); :func:`unpack` reads them with the C decoder (``_c/mrtransform.c``, every count and range checked).

Coefficients are coded coarse to fine. The approximation is coded as differences between neighbouring samples.
Each detail level is coded in two passes, its even then its odd coefficients; a coefficient's context is the
size of what the decoder already has around it: its parent (the coefficient at the same time one level
coarser) and the parent's neighbours, and, in the odd pass, its two even neighbours at its own level. The
context picks one of 32 models (8 sizes x 2 passes x coarse/fine levels), each fitted to its coefficients and
stored in two bytes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from motionrep.plugin.coding import IntegerEncoder, Model, fit_model

from ._wavelet import level_sizes, num_levels

__all__ = ["Quantised", "pack", "unpack", "declared", "MAX_EXPONENT", "MAX_ZERO", "COEFFICIENT_WORK"]

_SIZES = 8  # context classes per (pass, level group): bit length of the context sum, capped
_FINE = 3  # detail levels 1..3 (the finest) form one group, coarser levels the other
_CONTEXTS = 2 * 2 * _SIZES
#: Largest magnitude of a stored step exponent (steps are 2 ** (exponent / 8)).
MAX_EXPONENT = (1 << 15) - 1
#: Largest zero index of a stored model (P(0) <= 0.999): a byte then holds at most ~5700 values, so a header
#: cannot make the decoder work or allocate out of proportion to the data (``motionrep.plugin.coding.max_values``).
MAX_ZERO = 208


def _fit(values: NDArray[np.int64]) -> Model:
    return fit_model(values, max_zero=MAX_ZERO)


@dataclass(frozen=True, eq=False)
class Quantised:
    """What the payload holds.

    Attributes:
        num_frames: ``F``.
        num_features: ``D``.
        region_frames: frames per region of the step envelope.
        feature_exponents: ``(D,)`` step exponent of each feature.
        region_exponents: ``(R,)`` step exponent of each region, ``R = ceil(F / region_frames)``.
        coefficients: int64 arrays ``(n, D)`` in the order of :func:`~._wavelet.level_sizes`.
    """

    num_frames: int
    num_features: int
    region_frames: int
    feature_exponents: NDArray[np.int64]
    region_exponents: NDArray[np.int64]
    coefficients: list[NDArray[np.int64]]


def _parent_rows(magnitudes: list[NDArray[np.int64]], index: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """``2 p + p_left + p_right`` for each coefficient of array ``index`` (1..L) from the coarser level, of its
    even rows and of its odd rows (read-only: they may be views of one array): for the coarsest detail level, the
    approximation's differences at the same position; otherwise the detail level above at ``i // 2`` (both past
    the coarser array's end: its last row)."""
    n = magnitudes[index].shape[0]
    a = magnitudes[0] if index == 1 else magnitudes[index - 1]  # [0]: |A[i + 1] - A[i]|, last repeated (the caller)
    m, even, odd = a.shape[0], (n + 1) // 2, n // 2
    if not m:
        return np.zeros((even,) + a.shape[1:], np.int64), np.zeros((odd,) + a.shape[1:], np.int64)
    # the sum at each row of the coarser array (whole numbers: exact in any order), then the rows that take it
    s = a * 2  # int64 (or int16 magnitudes capped at _CAP: the sums stay below 2 ** 10)
    s[1:] += a[:-1]
    s[:-1] += a[1:]
    if index == 1:
        if n <= m:
            return s[0:n:2], s[1:n:2]
        at = np.minimum(np.arange(n), m - 1)
        return s[at[0::2]], s[at[1::2]]
    if even <= m:
        return s[:even], s[:odd]
    at = np.minimum(np.arange(even), m - 1)
    return s[at], s[at[:odd]]


def _context_ids(mags: list[NDArray[np.int64]], levels: int, out: NDArray[np.int64]) -> None:
    """The context of every detail coefficient, written into ``out`` (the detail arrays' elements in storage
    order, one after the other): for each pass, the bit length (capped) of the parents' sum
    (:func:`_parent_rows`), plus, in the odd pass, ``2 (|q[i - 1]| + |q[i + 1]|)`` from the level's even rows
    (already known to the decoder); both passes of a level at once. ``mags``: the magnitudes, ``mags[0]`` the
    approximation's steps (:func:`_approx_steps`)."""
    start = 0
    for index, odd, group in _passes(levels):
        if odd:  # both passes of the level are done with its even one
            continue
        level = mags[index]
        n = level.shape[0]
        even_parents, odd_parents = _parent_rows(mags, index)
        k = n // 2  # odd rows: their even neighbours at this level (the last one's right: 0 past the end)
        t = level[0:2 * k:2].copy()
        right = level[2::2]
        t[:right.shape[0]] += right
        t *= 2
        t += odd_parents
        # the bit length of the sum, capped at _SIZES - 1 (reached at 64), of the pass's model group: a table
        # (even rows: 0 .. _CAP, odd rows: _CAP + 1 .. 2 _CAP + 1)
        s = np.empty(level.shape, np.int64)
        np.minimum(even_parents, _CAP, out=s[0::2])
        np.minimum(t, _CAP, out=t)
        np.add(t, _CAP + 1, out=s[1::2])
        np.take(_SIZE_TABLES[group], s, out=out[start:start + level.size].reshape(level.shape), mode="clip")
        start += level.size


#: the context size of a capped parent sum (even pass: 0 .. _CAP, odd pass: _CAP + 1 .. 2 _CAP + 1) per group
_CAP = 1 << (_SIZES - 2)
_SIZE_TABLES = [np.array([(group * 2 + odd) * _SIZES + min(s.bit_length(), _SIZES - 1)
                          for odd in (0, 1) for s in range(_CAP + 1)], np.int64) for group in (0, 1)]


def _grouped(ctx: NDArray[np.int64]) -> tuple[NDArray[np.int64], list[tuple[int, int, int]]]:
    """The coefficients of one pass grouped by context: ``order`` (positions sorted by context, row-major
    within each) and ``(context, start, stop)`` of each context present, in increasing order."""
    order = np.argsort(ctx, kind="stable")
    counts = np.bincount(ctx, minlength=_CONTEXTS)
    stops = np.cumsum(counts)
    return order, [(c, int(stops[c] - counts[c]), int(stops[c])) for c in np.flatnonzero(counts).tolist()]


def _approx_steps(a: NDArray[np.int64]) -> NDArray[np.int64]:
    """``|A[i + 1] - A[i]|`` per row, the last row repeated (the coarsest detail level's parents)."""
    d = np.abs(np.diff(a, axis=0))
    return np.concatenate([d, d[-1:]], axis=0)


def _encode_signed(enc: IntegerEncoder, v: NDArray[np.int64]) -> None:
    """A vector of small signed integers: the first zigzag-coded in 16 raw bits, then the differences under a
    stored fitted model."""
    first = int(v[0])
    enc.encode_raw([2 * first if first >= 0 else -2 * first - 1], 16)
    d = np.diff(v)
    model = _fit(d)
    enc.encode_models([model])
    enc.encode(d, model)


def _passes(levels: int):
    """``(array index, level j, odd, group)`` in coding order."""
    for index in range(1, levels + 1):
        j = levels - index + 1
        for odd in (False, True):
            yield index, odd, int(j <= _FINE)


def pack(q: Quantised) -> bytes:
    """The payload bytes of ``q``."""
    F, D = q.num_frames, q.num_features
    levels = num_levels(F)
    coeffs = [np.asarray(c, dtype=np.int64) for c in q.coefficients]
    enc = IntegerEncoder()
    enc.encode_raw([F - 1], 32)
    enc.encode_raw([D - 1], 20)
    enc.encode_raw([q.region_frames - 1], 16)
    _encode_signed(enc, np.asarray(q.feature_exponents, np.int64))
    _encode_signed(enc, np.asarray(q.region_exponents, np.int64))
    # contexts of every detail coefficient, from the magnitudes (the decoder rebuilds them as it goes)
    mags = [np.abs(c) for c in coeffs]
    mags[0] = _approx_steps(coeffs[0])
    ids = np.empty(sum(coeffs[index].size for index in range(1, levels + 1)), np.int64)
    _context_ids(mags, levels, ids)
    segments = []  # (context ids, values) per pass, in coding order
    start = 0
    for index, odd, _ in _passes(levels):
        level = ids[start:start + coeffs[index].size].reshape(coeffs[index].shape)
        segments.append((level[int(odd)::2].reshape(-1), coeffs[index][int(odd)::2].reshape(-1)))
        start += coeffs[index].size if odd else 0
    all_ctx = np.concatenate([c for c, _ in segments]) if segments else np.zeros(0, np.int64)
    all_val = np.concatenate([v for _, v in segments]) if segments else np.zeros(0, np.int64)
    used = np.unique(all_ctx)
    models = {int(c): _fit(all_val[all_ctx == c]) for c in used}
    enc.encode_raw([int(np.bitwise_or.reduce(np.left_shift(1, used))) if used.size else 0], _CONTEXTS)
    enc.encode_models([models[int(c)] for c in used])
    # the approximation: its first row, then the differences of the next rows
    first, steps = coeffs[0][0], np.diff(coeffs[0], axis=0)
    m_first, m_steps = _fit(first), _fit(steps)
    enc.encode_models([m_first, m_steps])
    enc.encode(first, m_first)
    enc.encode(steps, m_steps)
    for ctx, values in segments:
        order, groups = _grouped(ctx)
        ordered = values[order]
        for c, start, stop in groups:
            enc.encode(ordered[start:stop], models[c])
    return enc.to_bytes()


#: Decode work of one coefficient, in the units of ``motionrep.limits.check_decode_work`` (a network's multiply-add):
#: range decoding its value and context, and its share of the inverse wavelet, about 256 times a multiply-add.
COEFFICIENT_WORK = 256


def declared(data: bytes) -> tuple[int, int, int]:
    """``(frames F, features D, region frames)`` the head of payload bytes declares (3 raw fields; nothing else
    is decoded), for ``Codec.check_payload``.

    Raises:
        PayloadError: for data that is not a whole number of 32-bit words.
    """
    from ._cdecode import declared as c_declared

    return c_declared(data, 1)


def unpack(data: bytes, version: int = 1) -> Quantised:
    """The :class:`Quantised` content of payload bytes (the C decoder, ``_c/mrtransform.c``).

    Raises:
        PayloadError: for damaged or inconsistent data (one line saying what).
    """
    from ._cdecode import unpack as c_unpack

    F, D, region, feature_exp, region_exp, coefficients = c_unpack(data, version)
    values = np.frombuffer(coefficients, np.int64).reshape(F, D)
    arrays, start = [], 0
    for n in level_sizes(F, num_levels(F)):
        arrays.append(values[start:start + n])
        start += n
    return Quantised(F, D, region, np.frombuffer(feature_exp, np.int64), np.frombuffer(region_exp, np.int64), arrays)
