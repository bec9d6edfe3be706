"""Integer coding for codecs: quantisation, a parametric entropy model, a range coder, step bisection.

A codec that stores numbers as integers (quantised transform coefficients, quantised network weights) uses this
module to turn them into as few bytes as possible and back, the same way on every machine:

* :func:`quantize` / :func:`dequantize`: a uniform quantiser with an optional dead zone; :func:`step_scale`:
  exact powers ``2 ** (index / 8)`` for step sizes chosen by an integer index.
* :class:`Model`: the probability of each integer, from two stored 8-bit parameters (how likely a zero is, and
  how fast the magnitudes decay: a zero-inflated two-sided geometric distribution, the discrete Laplace of
  transform coding). :func:`fit_model` picks the parameters that code given values in the fewest bits;
  :meth:`Model.cost` tells how many bits values would take.
* :class:`IntegerEncoder` / :class:`IntegerDecoder`: a range coder (``constriction``'s ``RangeEncoder`` /
  ``RangeDecoder``) over segments of integers, each segment under a model the decoder knows (because it was
  stored earlier in the stream, or is derived from what was decoded before); raw unsigned fields for headers.
* :func:`encode_integers` / :func:`decode_integers`: the simple case, groups of integers each coded under its
  own fitted model, the models stored in the stream.
* :func:`largest_passing`, :func:`largest_passing_each`: bisection of an integer step index to a bound, one
  index or many in lockstep.

Determinism: the model's probabilities are computed from its two indices with IEEE double additions,
multiplications and divisions only (no ``exp``/``log``/``pow``, whose last bit may differ between C libraries
and CPUs), then handed to the coder, whose fixed-point quantisation of them is integer arithmetic; the same
values and models therefore give the same bytes, and the same bytes decode to the same values, everywhere.
The exact definitions are in ``specs/coding.md``.

Size: one concern, integer coding; the quantiser, the model and the coder share one definition of the
probabilities that must agree bit for bit between encoder and decoder, so they are kept in one module.

Example::

    enc = IntegerEncoder()
    model = fit_model(q)
    enc.encode_models([model])
    enc.encode(q, model)
    data = enc.to_bytes()

    dec = IntegerDecoder(data)
    (model,) = dec.decode_models(1)
    q2 = dec.decode(q.size, model)
    dec.finish()
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import ParameterError, PayloadError

__all__ = [
    "quantize",
    "dequantize",
    "step_scale",
    "Model",
    "fit_model",
    "max_values",
    "IntegerEncoder",
    "IntegerDecoder",
    "encode_integers",
    "decode_integers",
    "largest_passing",
    "largest_passing_each",
    "MAX_MAGNITUDE",
]

#: Magnitudes below this are coded as their own token; larger ones as a bit-length bucket plus raw bits.
DIRECT = 16
#: Largest magnitude a coded integer may have (``2 ** 62 - 1``).
MAX_MAGNITUDE = (1 << 62) - 1
_FIRST_BUCKET = 4  # DIRECT == 2 ** _FIRST_BUCKET
_LAST_BUCKET = 61
#: Tokens: magnitudes 0..15, then one per bit length 5..62 (magnitudes in [2 ** e, 2 ** (e + 1)), e = 4..61).
NUM_TOKENS = DIRECT + _LAST_BUCKET - _FIRST_BUCKET + 1
_CHUNK = 16  # raw bits are coded in chunks of at most this many bits

# 2 ** (i / 8), i = 0..7, written out so that every machine uses the same bits (pow may differ in the last one)
_EIGHTH_ROOTS = (1.0, 1.0905077326652577, 1.189207115002721, 1.2968395546510096, 1.4142135623730951,
                 1.5422108254079407, 1.681792830507429, 1.8340080864093424)


# ---------------------------------------------------------------------------------------------------------------
# quantisation
# ---------------------------------------------------------------------------------------------------------------
def step_scale(index: ArrayLike) -> NDArray[np.float64] | float:
    """``2 ** (index / 8)`` for integer ``index`` (scalar or array), exactly the same bits on every machine."""
    i = np.asarray(index, dtype=np.int64)
    roots = np.asarray(_EIGHTH_ROOTS)
    out = np.ldexp(roots[i % 8], (i // 8).astype(np.int32))
    return float(out) if out.ndim == 0 else out


def quantize(values: ArrayLike, step: ArrayLike, *, rounding: float = 0.5) -> NDArray[np.int64]:
    """Integers ``q = sign(x) * floor(|x| / step + rounding)`` (``step`` broadcasts against ``values``).

    ``rounding = 0.5`` rounds to the nearest multiple of the step; smaller values widen the dead zone around
    zero (``|x| < (1 - rounding) * step`` gives 0), which trades a little error for many more zeros.

    Raises:
        ParameterError: for a step that is not finite and > 0, ``rounding`` outside [0, 1), non-finite values,
            or a quotient beyond :data:`MAX_MAGNITUDE`.
    """
    x = np.asarray(values, dtype=np.float64)
    s = np.asarray(step, dtype=np.float64)
    if not (0.0 <= rounding < 1.0):
        raise ParameterError(f"rounding must be in [0, 1), got {rounding!r}")
    if not np.all(np.isfinite(s) & (s > 0)):
        raise ParameterError("quantisation steps must be finite and > 0")
    if not np.all(np.isfinite(x)):
        raise ParameterError("cannot quantise NaN or infinity")
    with np.errstate(over="ignore"):
        a = np.floor(np.abs(x) / s + rounding)
    if a.size and not float(a.max()) <= MAX_MAGNITUDE:
        raise ParameterError(f"a quantised value exceeds {MAX_MAGNITUDE} steps; the step is too small")
    return (np.sign(x) * a).astype(np.int64)


def dequantize(q: ArrayLike, step: ArrayLike) -> NDArray[np.float64]:
    """``q * step`` as float64 (``step`` broadcasts against ``q``)."""
    return np.asarray(q, dtype=np.float64) * np.asarray(step, dtype=np.float64)


# ---------------------------------------------------------------------------------------------------------------
# the model
# ---------------------------------------------------------------------------------------------------------------
def _zero_probability(index: int) -> float:
    """``z = o / (1 + o)``, ``o = (8 + index % 8) / 8 * 2 ** (index // 8 - 16)``: from 1.5e-5 to 0.99997."""
    o = math.ldexp(8 + index % 8, index // 8 - 19)
    return o / (1.0 + o)


def _decay(index: int) -> float:
    """``theta = o / (1 + o)``, ``o = (4 + index % 4) / 4 * 2 ** (index // 4 - 16)``: mean magnitudes of non-zero
    values ``1 + o`` from 1 to about 2 ** 48, a quarter octave apart."""
    o = math.ldexp(4 + index % 4, index // 4 - 18)
    return o / (1.0 + o)


@lru_cache(maxsize=None)
def _tail_probabilities(decay: int) -> tuple[float, ...]:
    """``NUM_TOKENS - 1`` probabilities of the tokens of magnitudes >= 1 given a non-zero value, in IEEE double
    basic arithmetic only: ``(1 - theta) theta ** (a - 1)`` for ``a`` = 1..15, then per bit length ``e`` = 4..61
    the mass of ``[2 ** e, 2 ** (e + 1))``, ``theta ** (2 ** e - 1) - theta ** (2 ** (e + 1) - 1)``."""
    theta = _decay(decay)
    p = []
    c = 1.0 - theta
    t = 1.0  # theta ** (a - 1)
    for _ in range(1, DIRECT):
        p.append(c * t)
        t = t * theta
    power = theta  # theta ** (2 ** k), by squaring
    for _ in range(_FIRST_BUCKET):
        power = power * power
    low = power / theta  # theta ** (2 ** 4 - 1)
    for _ in range(_FIRST_BUCKET, _LAST_BUCKET + 1):
        power = power * power
        high = power / theta
        p.append(low - high)
        low = high
    return tuple(p)


@lru_cache(maxsize=4096)
def _categorical(zero: int, decay: int):
    import constriction

    z = _zero_probability(zero)
    probs = np.array([z] + [(1.0 - z) * p for p in _tail_probabilities(decay)], dtype=np.float64)
    return constriction.stream.model.Categorical(probs, perfect=False)


@lru_cache(maxsize=None)
def _fit_tables() -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Code lengths in bits (for fitting only, never to decode): ``(256, 2)`` of a zero / a non-zero value per
    zero index, ``(256, NUM_TOKENS - 1)`` of each non-zero token per decay index."""
    z = np.array([_zero_probability(i) for i in range(256)])
    zero = -np.log2(np.stack([z, 1.0 - z], axis=1))
    tail = np.array([_tail_probabilities(i) for i in range(256)])
    return zero, -np.log2(np.maximum(tail, 2.0 ** -24))


@dataclass(frozen=True)
class Model:
    """A probability model of integers: zero-inflated two-sided geometric, from two indices in 0..255.

    ``P(0) = z``; ``P(+-a) = (1 - z) (1 - theta) theta ** (a - 1) / 2`` for ``a >= 1`` (the sign is a fair
    bit).  Magnitudes of 16 and more share one token per bit length (their low bits are coded raw), so any
    integer up to :data:`MAX_MAGNITUDE` in size is coded with a table of ``NUM_TOKENS`` entries.  Stored as two
    bytes; the exact tables are in ``specs/coding.md``.

    Attributes:
        zero: index of ``z``, the probability of 0 (0: 1.5e-5 ... 255: 0.99997, eight steps per octave of the
            odds ``z / (1 - z)``).
        decay: index of ``theta``; the mean magnitude of a non-zero value, ``1 / (1 - theta)``, goes from 1 to
            about ``2 ** 48``, four steps per octave.
    """

    zero: int
    decay: int

    def __post_init__(self) -> None:
        for name in ("zero", "decay"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 0 <= int(v) <= 255:
                raise ParameterError(f"Model.{name} must be an integer in 0..255, got {v!r}")
        object.__setattr__(self, "zero", int(self.zero))
        object.__setattr__(self, "decay", int(self.decay))

    @property
    def probabilities(self) -> NDArray[np.float64]:
        """``(NUM_TOKENS,)`` token probabilities (token ``a`` for magnitude ``a < 16``, then one per bit length)."""
        z = _zero_probability(self.zero)
        return np.array([z] + [(1.0 - z) * p for p in _tail_probabilities(self.decay)])

    def cost(self, values: ArrayLike) -> float:
        """Ideal code length of ``values`` under this model, in bits (the coder comes within a few bytes)."""
        tokens, extra_bits, nonzero = _tokenize(np.asarray(values, dtype=np.int64).reshape(-1))
        zero, tail = _fit_tables()
        counts = np.bincount(tokens, minlength=NUM_TOKENS)
        return float(counts[0] * zero[self.zero, 0] + nonzero * zero[self.zero, 1] + counts[1:] @ tail[self.decay]
                     + extra_bits.sum() + nonzero)


def _tokenize(values: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64], int]:
    """Tokens, the number of raw bits of each value, and the number of non-zero values (sign bits)."""
    a = np.abs(values)
    if a.size and int(a.max()) > MAX_MAGNITUDE:
        raise ParameterError(f"cannot code an integer of magnitude above {MAX_MAGNITUDE}")
    big = a >= DIRECT
    tokens = a.copy()
    extra = np.zeros(a.shape, np.int64)
    if big.any():
        # bit length - 1 of each big magnitude, exactly (frexp is exact on integers below 2 ** 53; above, fix up)
        e = np.frexp(a[big].astype(np.float64))[1].astype(np.int64) - 1
        e -= (np.left_shift(np.int64(1), e) > a[big])
        e += (np.left_shift(np.int64(1), e + 1) <= a[big])
        tokens[big] = DIRECT + e - _FIRST_BUCKET
        extra[big] = e
    return tokens, extra, int(np.count_nonzero(a))


def fit_model(values: ArrayLike, *, max_zero: int = 255) -> Model:
    """The :class:`Model` that codes ``values`` in the fewest bits, with a zero index of at most ``max_zero``
    (an empty array gives ``Model(max_zero, 0)``).

    ``max_zero`` caps the probability of 0, and with it how many values one coded bit can hold: a decoder that
    only accepts models up to ``max_zero`` knows that ``n`` bytes hold at most :func:`max_values` ``(n,
    max_zero)`` values, and can refuse a damaged or hostile header that claims more before allocating anything.
    """
    if isinstance(max_zero, bool) or not isinstance(max_zero, (int, np.integer)) or not 0 <= max_zero <= 255:
        raise ParameterError(f"max_zero must be an integer in 0..255, got {max_zero!r}")
    v = np.asarray(values, dtype=np.int64).reshape(-1)
    if v.size == 0:
        return Model(int(max_zero), 0)
    tokens, _, nonzero = _tokenize(v)
    counts = np.bincount(tokens, minlength=NUM_TOKENS).astype(np.float64)
    zero_bits, tail_bits = _fit_tables()
    zero = int(np.argmin(zero_bits[:max_zero + 1] @ np.array([counts[0], nonzero], dtype=np.float64)))
    decay = int(np.argmin(tail_bits @ counts[1:])) if nonzero else 0
    return Model(zero, decay)


def max_values(num_bytes: int, max_zero: int = 255) -> int:
    """The most values that ``num_bytes`` of coded data can hold when every model's zero index is at most
    ``max_zero`` (each value costs at least ``-log2 z`` bits, ``z`` the probability of 0 at ``max_zero``)."""
    z = _zero_probability(int(max_zero))
    per_bit = 1.0 / -math.log2(z)
    return int(math.ceil((8 * int(num_bytes) + 64) * per_bit))


# ---------------------------------------------------------------------------------------------------------------
# the coder
# ---------------------------------------------------------------------------------------------------------------
@lru_cache(maxsize=None)
def _uniform(bits: int):
    import constriction

    return constriction.stream.model.Uniform(1 << bits)


def _raw_chunks(bits: int) -> list[int]:
    """Chunk widths (<= 16 bits each, low chunk first) of a raw field of ``bits`` bits."""
    out = []
    while bits > 0:
        out.append(min(bits, _CHUNK))
        bits -= out[-1]
    return out


class IntegerEncoder:
    """Range-codes segments of integers into bytes (decode them in the same order with :class:`IntegerDecoder`).

    Each segment is coded under a :class:`Model` (or as raw unsigned fields); the decoder must be given the same
    models and counts in the same order, so store what it cannot derive (:meth:`encode_models`,
    :meth:`encode_raw`) before the segments that need it.
    """

    def __init__(self) -> None:
        import constriction

        self._coder = constriction.stream.queue.RangeEncoder()

    def encode(self, values: ArrayLike, model: Model) -> None:
        """Append ``values`` (integers of magnitude <= :data:`MAX_MAGNITUDE`, any shape, C order) under ``model``."""
        v = np.asarray(values)
        if v.size and v.dtype.kind not in "iu":
            raise ParameterError(f"can only code integers, got {v.dtype}")
        v = v.astype(np.int64).reshape(-1)
        if v.size == 0:
            return
        tokens, extra, _ = _tokenize(v)
        self._coder.encode(tokens.astype(np.int32), _categorical(model.zero, model.decay))
        nonzero = v != 0
        if nonzero.any():
            self._coder.encode((v[nonzero] < 0).astype(np.int32), _uniform(1))
        big = extra > 0
        if big.any():
            a, e = np.abs(v[big]), extra[big]
            for bits in np.unique(e).tolist():  # ascending bit counts, each value's low bits in 16-bit chunks
                low = a[e == bits] - (np.int64(1) << bits)
                shift = 0
                for width in _raw_chunks(bits):
                    self._coder.encode(((low >> shift) & ((1 << width) - 1)).astype(np.int32), _uniform(width))
                    shift += width

    def encode_raw(self, values: ArrayLike, bits: int) -> None:
        """Append unsigned integers ``0 <= v < 2 ** bits`` (``bits`` in 1..62), each in exactly ``bits`` bits."""
        if not isinstance(bits, (int, np.integer)) or not 1 <= bits <= 62:
            raise ParameterError(f"raw fields have 1..62 bits, got {bits!r}")
        v = np.asarray(values, dtype=np.int64).reshape(-1)
        if v.size and (int(v.min()) < 0 or int(v.max()) >= (1 << int(bits))):
            raise ParameterError(f"a raw field of {bits} bits holds 0..{(1 << int(bits)) - 1}")
        shift = 0
        for width in _raw_chunks(int(bits)):
            if v.size:
                self._coder.encode(((v >> shift) & ((1 << width) - 1)).astype(np.int32), _uniform(width))
            shift += width

    def encode_models(self, models: Sequence[Model]) -> None:
        """Append models as two raw bytes each."""
        self.encode_raw(np.array([(m.zero, m.decay) for m in models], dtype=np.int64).reshape(-1), 8)

    def to_bytes(self) -> bytes:
        """The coded bytes (a multiple of 4; empty when nothing was coded)."""
        return self._coder.get_compressed().astype("<u4").tobytes()


class IntegerDecoder:
    """Decodes what :class:`IntegerEncoder` wrote, segment by segment, in the same order.

    The decoder cannot tell bytes that were never encoded from data: damaged input decodes to other numbers,
    which the caller's own checks (sizes, ranges) and :meth:`finish` catch where they can; the container's
    checksum catches accidental damage before this point.

    Raises:
        PayloadError: for data that is not a whole number of 32-bit words, or a count or field out of range.
    """

    def __init__(self, data: bytes | ArrayLike) -> None:
        import constriction

        raw = bytes(np.asarray(data, dtype=np.uint8).tobytes()) if not isinstance(data, (bytes, bytearray)) \
            else bytes(data)
        if len(raw) % 4:
            raise PayloadError(f"coded integers must be whole 32-bit words, got {len(raw)} bytes")
        words = np.frombuffer(raw, dtype="<u4").astype(np.uint32)
        self._decoder = constriction.stream.queue.RangeDecoder(words)
        self._words = words.size

    def _pull(self, model, count: int) -> NDArray[np.int64]:
        """``count`` symbols from the range decoder; its complaints (data that no model could have written, as
        an ``AssertionError`` or ``ValueError``) become :class:`PayloadError`."""
        try:
            out = np.asarray(self._decoder.decode(model, count), dtype=np.int64)
        except (AssertionError, ValueError, RuntimeError, OverflowError) as exc:
            raise PayloadError(f"coded integers are damaged ({str(exc).strip() or type(exc).__name__})") from None
        if out.shape != (count,):
            raise PayloadError("coded integers are damaged (short read)")
        return out

    def _check_count(self, count: int) -> int:
        if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 0:
            raise PayloadError(f"invalid count of coded integers: {count!r}")
        return int(count)

    def decode(self, count: int, model: Model) -> NDArray[np.int64]:
        """The next ``count`` integers, coded under ``model``, as int64."""
        n = self._check_count(count)
        if n == 0:
            return np.zeros(0, np.int64)
        tokens = self._pull(_categorical(model.zero, model.decay), n)
        if int(tokens.max()) >= NUM_TOKENS or int(tokens.min()) < 0:
            raise PayloadError("coded integers are damaged (token out of range)")
        nonzero = tokens != 0
        negative = np.zeros(n, bool)
        count_nonzero = int(nonzero.sum())
        if count_nonzero:
            negative[nonzero] = self._pull(_uniform(1), count_nonzero) != 0
        values = tokens.copy()
        big = tokens >= DIRECT
        if big.any():
            e = tokens[big] - DIRECT + _FIRST_BUCKET
            low = np.zeros(e.size, np.int64)
            for bits in np.unique(e).tolist():  # ascending, as encoded
                rows = e == bits
                low[rows] = self.decode_raw(int(rows.sum()), bits)
            values[big] = (np.int64(1) << e) + low
        return np.where(negative, -values, values)

    def decode_raw(self, count: int, bits: int) -> NDArray[np.int64]:
        """The next ``count`` unsigned fields of ``bits`` bits each."""
        n = self._check_count(count)
        if not isinstance(bits, (int, np.integer)) or not 1 <= bits <= 62:
            raise PayloadError(f"raw fields have 1..62 bits, got {bits!r}")
        out = np.zeros(n, np.int64)
        if n == 0:
            return out
        shift = 0
        for width in _raw_chunks(int(bits)):
            out |= self._pull(_uniform(width), n) << shift
            shift += width
        return out

    def decode_models(self, count: int) -> list[Model]:
        """The next ``count`` models (two raw bytes each)."""
        pairs = self.decode_raw(2 * self._check_count(count), 8).reshape(-1, 2)
        return [Model(int(z), int(d)) for z, d in pairs]

    def finish(self) -> None:
        """Check that the data held nothing beyond what was decoded.

        Raises:
            PayloadError: if whole words of data were left over.
        """
        if not self._decoder.maybe_exhausted():
            raise PayloadError("coded integers are damaged (data left over after the last value)")


# ---------------------------------------------------------------------------------------------------------------
# groups of integers
# ---------------------------------------------------------------------------------------------------------------
def encode_integers(groups: Sequence[ArrayLike]) -> bytes:
    """Bytes holding integer arrays, each coded under its own fitted :class:`Model` (stored, 2 bytes each).

    The sizes of the groups are not stored: :func:`decode_integers` is given them.
    """
    arrays = [np.asarray(g) for g in groups]
    models = [fit_model(a) for a in arrays]
    enc = IntegerEncoder()
    enc.encode_models(models)
    for a, m in zip(arrays, models):
        enc.encode(a, m)
    return enc.to_bytes()


def decode_integers(data: bytes | ArrayLike, counts: Sequence[int]) -> list[NDArray[np.int64]]:
    """The integer arrays (flat, int64) that :func:`encode_integers` wrote, given their sizes.

    Raises:
        PayloadError: if the data are damaged or do not hold exactly these groups.
    """
    dec = IntegerDecoder(data)
    models = dec.decode_models(len(counts))
    out = [dec.decode(n, m) for n, m in zip(counts, models)]
    dec.finish()
    return out


# ---------------------------------------------------------------------------------------------------------------
# bisection of step indices
# ---------------------------------------------------------------------------------------------------------------
def largest_passing(passes: Callable[[int], bool], low: int, high: int) -> int | None:
    """The largest integer ``i`` in ``[low, high]`` with ``passes(i)``, by bisection.

    Assumes ``passes`` holds up to some index and fails above it (a larger step index, a coarser quantiser,
    a larger error); where that is only roughly true, the index returned still passes (it was tested), but a
    larger passing one may exist.  Calls ``passes`` about ``log2(high - low)`` times.

    Returns:
        The index, or None if not even ``low`` passes.
    """
    if high < low:
        raise ParameterError(f"empty search range [{low}, {high}]")
    if passes(high):
        return high
    if not passes(low):
        return None
    lo, hi = low, high  # lo passes, hi fails
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if passes(mid):
            lo = mid
        else:
            hi = mid
    return lo


def largest_passing_each(passes: Callable[[NDArray[np.int64]], NDArray[np.bool_]], low: ArrayLike,
                         high: ArrayLike) -> NDArray[np.int64]:
    """:func:`largest_passing` for many independent indices at once, in lockstep.

    ``passes(indices)`` tests a whole ``(n,)`` vector of indices in one call (for example one quantisation and
    one evaluation of every segment of a clip) and returns ``(n,)`` booleans.  Bisects each entry within its own
    ``[low, high]``.

    Returns:
        ``(n,)`` indices: each the largest one seen to pass, or ``low - 1`` where not even ``low`` passed (the
        caller decides what to do there).  When the entries are not quite independent (a segment's result
        depends a little on its neighbours'), test the final vector again.
    """
    lo = np.asarray(low, dtype=np.int64).copy()
    hi = np.asarray(high, dtype=np.int64).copy()
    if lo.shape != hi.shape or lo.ndim != 1 or np.any(hi < lo):
        raise ParameterError("low and high must be (n,) integer vectors with low <= high")
    ok_high = np.asarray(passes(hi), dtype=bool)
    ok_low = np.asarray(passes(lo), dtype=bool)
    best = np.where(ok_high, hi, np.where(ok_low, lo, lo - 1))
    active = ~ok_high & ok_low
    lo_a, hi_a = lo.copy(), hi.copy()  # for active entries: lo passes, hi fails
    while True:
        todo = active & (hi_a - lo_a > 1)
        if not todo.any():
            break
        mid = np.where(todo, (lo_a + hi_a) // 2, np.where(active, lo_a, best))  # the others at their answer
        ok = np.asarray(passes(mid), dtype=bool)
        lo_a = np.where(todo & ok, mid, lo_a)
        hi_a = np.where(todo & ~ok, mid, hi_a)
    return np.where(active, lo_a, best)
