"""The decoder of ``transform`` payloads (format 1) as motionrep shipped it in Python and numpy until the C decoder
(``_c/mrtransform.c``) replaced it: kept here, unchanged, as the oracle the C decoder is tested against (the same
values and the same error messages on valid and on damaged payloads), and the numpy forward wavelet the C one
is tested against.  Not used by the plugin."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from motionrep.errors import PayloadError
from motionrep.plugin.coding import IntegerDecoder, Model, max_values, step_scale
from motionrep_transform._codec import coefficient_exponents
from motionrep_transform._stream import (_CONTEXTS, _SIZES, MAX_EXPONENT, MAX_ZERO, Quantised, _approx_steps,
                                         _grouped, _passes)
from motionrep_transform._wavelet import _STEPS, _HIGH, _LOW, coefficient_frames, level_sizes, num_levels

_REACH = 3


def _parents(magnitudes: list[NDArray[np.int64]], index: int) -> NDArray[np.int64]:
    """``2 p + p_left + p_right`` for each coefficient of array ``index`` (1..L) from the coarser level, as
    ``motionrep_transform._stream`` formed it until 0a46dc9 (gathered from a zero-padded copy): the oracle its
    faster formulation is tested against (``test_slack``)."""
    n = magnitudes[index].shape[0]
    if index == 1:
        a = magnitudes[0]  # here: |A[i + 1] - A[i]|, last repeated (set by the caller)
        at = np.arange(n)
    else:
        a = magnitudes[index - 1]
        at = np.arange(n) // 2
    at = np.minimum(at, a.shape[0] - 1)
    pad = np.zeros((a.shape[0] + 2,) + a.shape[1:], np.int64)
    pad[1:-1] = a
    return 2 * pad[at + 1] + pad[at] + pad[at + 2]


# the wavelet's mirrored neighbours, as the plugin's numpy code had them
def _right(s: NDArray, count: int) -> NDArray:
    """``s[i + 1]`` for ``i < count``; past the end, ``s[-1]`` (the mirror image: for an even-length signal the
    last odd sample's right neighbour ``x[n]`` is ``x[n - 2]``)."""
    if s.shape[0] > count:
        return s[1:count + 1]
    return np.concatenate([s[1:], s[-1:]], axis=0)


def _left(d: NDArray, count: int) -> NDArray:
    """``d[i - 1]`` for ``i < count``, with ``d[-1] = d[0]`` (mirror at the start)."""
    return np.concatenate([d[:1], d[:count - 1]], axis=0)


def _here(d: NDArray, count: int) -> NDArray:
    """``d[i]`` for ``i < count``, with ``d[len] = d[len - 1]`` (mirror at the end of an odd-length signal)."""
    if d.shape[0] >= count:
        return d[:count]
    return np.concatenate([d, d[-1:]], axis=0)


def forward(x: NDArray[np.float64], levels: int) -> list[NDArray[np.float64]]:
    """The numpy forward wavelet the plugin shipped until the C one (``mrt_forward``) replaced it (the oracle)."""
    out, s = [], np.asarray(x, dtype=np.float64)
    for _ in range(levels):
        s, d = s[0::2].copy(), s[1::2].copy()
        ns, nd = s.shape[0], d.shape[0]
        for k, a in enumerate(_STEPS):
            if k % 2 == 0:
                d += a * (s[:nd] + _right(s, nd))
            else:
                s += a * (_left(d, ns) + _here(d, ns))
        s *= _LOW
        d *= _HIGH
        out.append(d)
    out.append(s)
    return out[::-1]


# the v1 format's contexts pass by pass, as its decoder meets them (the library computes them for both passes of a
# level at once, motionrep_transform._stream._context_ids; test_slack checks the two agree)
def _bit_length(s: NDArray[np.int64]) -> NDArray[np.int64]:
    """Bits of each non-negative integer (0 for 0), capped at 41."""
    s = np.minimum(s, np.int64(1) << 40)
    return np.where(s > 0, np.frexp(s.astype(np.float64))[1], 0).astype(np.int64)


def _contexts(parents: NDArray[np.int64], level: NDArray[np.int64], odd: bool, group: int) -> NDArray[np.int64]:
    """Context ids of one pass over the rows ``i`` of a level with ``i % 2 == odd``: the bit length (capped) of
    the parents' sum, plus, in the odd pass, ``2 (|q[i - 1]| + |q[i + 1]|)`` from ``level`` (the level's
    magnitudes; only its even rows, already known to the decoder, are read)."""
    s = parents[int(odd)::2]
    if odd:
        n = level.shape[0]
        pad = np.zeros((n + 1,) + level.shape[1:], np.int64)
        pad[:n] = level
        rows = np.arange(1, n, 2)
        s = s + 2 * (pad[rows - 1] + pad[rows + 1])
    size = np.minimum(_bit_length(s), _SIZES - 1)
    return (group * 2 + int(odd)) * _SIZES + size


def _models(dec: IntegerDecoder, count: int) -> list[Model]:
    models = dec.decode_models(count)
    if any(m.zero > MAX_ZERO for m in models):
        raise PayloadError("transform payload: a stored model is out of range (damaged data)")
    return models


def _decode_signed(dec: IntegerDecoder, n: int) -> NDArray[np.int64]:
    z = int(dec.decode_raw(1, 16)[0])
    first = z // 2 if z % 2 == 0 else -(z + 1) // 2
    (model,) = _models(dec, 1)
    v = np.cumsum(np.concatenate([[first], dec.decode(n - 1, model)]))
    if np.any(np.abs(v) > MAX_EXPONENT):
        raise PayloadError("transform payload: a step exponent is out of range")
    return v


def unpack(data: bytes) -> Quantised:
    dec = IntegerDecoder(data)
    F = int(dec.decode_raw(1, 32)[0]) + 1
    D = int(dec.decode_raw(1, 20)[0]) + 1
    region = int(dec.decode_raw(1, 16)[0]) + 1
    regions = -(-F // region)
    if F * D + D + regions > max_values(len(data), MAX_ZERO):
        raise PayloadError(f"transform payload: {F} frames x {D} features cannot be held in {len(data)} bytes "
                           "(damaged data)")
    feature_exp = _decode_signed(dec, D)
    region_exp = _decode_signed(dec, regions)
    levels = num_levels(F)
    sizes = level_sizes(F, levels)
    bitmap = int(dec.decode_raw(1, _CONTEXTS)[0])
    used = [c for c in range(_CONTEXTS) if bitmap >> c & 1]
    models: dict[int, Model] = dict(zip(used, _models(dec, len(used))))
    m_first, m_steps = _models(dec, 2)
    first = dec.decode(D, m_first)
    steps = dec.decode((sizes[0] - 1) * D, m_steps).reshape(sizes[0] - 1, D)
    approx = np.cumsum(np.concatenate([first[None], steps], axis=0), axis=0)
    coeffs = [approx] + [np.zeros((n, D), np.int64) for n in sizes[1:]]
    mags = [_approx_steps(approx)] + [np.zeros((n, D), np.int64) for n in sizes[1:]]
    for index, odd, group in _passes(levels):
        ctx = _contexts(_parents(mags, index), mags[index], odd, group).reshape(-1)
        order, groups = _grouped(ctx)
        values = np.empty(ctx.size, np.int64)
        for c, start, stop in groups:
            if c not in models:
                raise PayloadError("transform payload: a coefficient's context has no stored model (damaged data)")
            values[order[start:stop]] = dec.decode(stop - start, models[c])
        coeffs[index][int(odd)::2] = values.reshape(-1, D)
        mags[index][int(odd)::2] = np.abs(values).reshape(-1, D)
    dec.finish()
    return Quantised(F, D, region, feature_exp, region_exp, coeffs)


def _merge(s: NDArray[np.float64], d: NDArray[np.float64]) -> NDArray[np.float64]:
    s, d = s / _LOW, d / _HIGH
    ns, nd = s.shape[0], d.shape[0]
    for k in range(len(_STEPS) - 1, -1, -1):
        a = _STEPS[k]
        if k % 2 == 0:
            d -= a * (s[:nd] + _right(s, nd))
        else:
            s -= a * (_left(d, ns) + _here(d, ns))
    x = np.empty((ns + nd,) + s.shape[1:])
    x[0::2] = s
    x[1::2] = d
    return x


def inverse(coefficients: list[NDArray[np.float64]]) -> NDArray[np.float64]:
    s = coefficients[0]
    for d in coefficients[1:]:
        s = _merge(s, d)
    return s


def steps_of(exponents):
    low = min(int(e.min()) for e in exponents if e.size)
    high = max(int(e.max()) for e in exponents if e.size)
    table = step_scale(np.arange(low, high + 1))
    return [np.asarray(table)[e - low] for e in exponents]


def reconstruct(q: Quantised) -> NDArray[np.float64]:
    levels = num_levels(q.num_frames)
    region_of = [np.minimum(f // q.region_frames, q.region_exponents.size - 1)
                 for f in coefficient_frames(q.num_frames, levels)]
    spans = [levels] + list(range(levels, 0, -1))
    reach = [int(math.ceil(_REACH * 2 ** j / q.region_frames)) for j in spans]
    exps = coefficient_exponents(q.region_exponents, region_of, reach, q.feature_exponents)
    if any(c.shape != e.shape for c, e in zip(q.coefficients, exps)) or len(exps) != len(q.coefficients):
        raise PayloadError("transform payload: coefficient arrays do not fit the clip")
    if any(e.size and int(np.abs(e).max()) > MAX_EXPONENT for e in exps):
        raise PayloadError("transform payload: a step is out of range")
    with np.errstate(all="ignore"):
        values = [c * step for c, step in zip(q.coefficients, steps_of(exps))]
        out = inverse(values) if levels else values[0]
    if not np.all(np.isfinite(out)):
        raise PayloadError("transform payload: the coefficients decode to values that are not finite")
    return out


def decode_frames(data: bytes) -> NDArray[np.float64]:
    """``(F, D)`` features of every frame of payload bytes, as the Python decoder gave them."""
    return reconstruct(unpack(data))
