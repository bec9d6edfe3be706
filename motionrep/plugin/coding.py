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
* :class:`MatrixModel`, :func:`fit_matrix_model`, :meth:`IntegerEncoder.encode_matrices` /
  :meth:`IntegerDecoder.decode_matrices`: matrices of integers (a network's layers) each under one model, or one
  model per row or per column (rows of very different magnitudes), whichever codes it in fewer bits, the line
  models' parameters coded compactly in the stream, all of them in a few coder calls.
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
from typing import Callable, NamedTuple, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ParameterError, PayloadError

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
    "MatrixModel",
    "fit_matrix_model",
    "MAX_MAGNITUDE",
    "LINE_LEVELS",
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


@lru_cache(maxsize=65536)
def _probabilities(zero: int, decay: int) -> NDArray[np.float64]:
    """:attr:`Model.probabilities` (read-only, cached)."""
    z = _zero_probability(zero)
    p = np.array([z] + [(1.0 - z) * t for t in _tail_probabilities(decay)])
    p.flags.writeable = False
    return p


@lru_cache(maxsize=4096)
def _categorical(zero: int, decay: int):
    import constriction

    return constriction.stream.model.Categorical(_probabilities(zero, decay).copy(), perfect=False)


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
        return _probabilities(self.zero, self.decay).copy()

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
        self._encode_signs_and_bits(v, extra)

    def _encode_signs_and_bits(self, v: NDArray[np.int64], extra: NDArray[np.int64]) -> None:
        """The signs of the non-zero values of ``v``, then the raw low bits of the large ones (``extra`` bits)."""
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

    def encode_matrices(self, matrices: Sequence[ArrayLike], models: Sequence["MatrixModel"] | None = None) -> None:
        """Append integer matrices ``(rows, cols)`` (a network's layers; a vector is a ``(1, n)`` matrix), each
        under its :class:`MatrixModel` (default: :func:`fit_matrix_model` of each): the layouts, the models'
        parameters, then every value, in a fixed number of coder calls however many matrices there are
        (``specs/coding.md``, *Matrices*).  The shapes are not stored: :meth:`IntegerDecoder.decode_matrices` is
        given them."""
        arrays = []
        for m in matrices:
            a = np.asarray(m)
            if a.ndim != 2:
                raise ParameterError(f"encode_matrices needs 2-d arrays, got shape {a.shape}")
            if a.size and a.dtype.kind not in "iu":
                raise ParameterError(f"can only code integers, got {a.dtype}")
            arrays.append(a.astype(np.int64))
        chosen = [fit_matrix_model(a) for a in arrays] if models is None else list(models)
        if len(chosen) != len(arrays):
            raise ParameterError(f"{len(arrays)} matrices need as many models, got {len(chosen)}")
        lines = [a.T if mm.layout == 2 else a for a, mm in zip(arrays, chosen)]
        for mm, line in zip(chosen, lines):
            if mm.layout and len(mm.models) != line.shape[0]:
                raise ParameterError(f"a layout-{mm.layout} MatrixModel of {len(mm.models)} models cannot code "
                                     f"{line.shape[0]} lines")
        self.encode_raw([mm.layout for mm in chosen], 2)
        fields: list[int] = []
        level_parts, decay_parts = [], []
        for mm in chosen:
            if mm.layout == 0:
                fields += [mm.models[0].zero, mm.models[0].decay]
                continue
            p = _line_parameters(mm.models)
            fields += [p.base_level, p.base_decay, p.level_model.zero, p.level_model.decay, p.decay_model.zero,
                       p.decay_model.decay]
            level_parts.append((p.level_deltas, [p.level_model]))
            decay_parts.append((p.decay_deltas, [p.decay_model]))
        self.encode_raw(fields, 8)
        for parts in (level_parts, decay_parts):
            self._encode_each(*_per_value(parts, lambda v: v.size))
        self._encode_each(*_per_value([(line, mm.models) for mm, line in zip(chosen, lines)],
                                      lambda v: v.shape[1] if v.ndim == 2 else v.size))

    def _encode_each(self, values: NDArray[np.int64], which: NDArray[np.int64], models: Sequence[Model]) -> None:
        """``values``, value ``i`` under ``models[which[i]]``: the tokens (with a table of per-token
        probabilities, in chunks), then the signs and raw bits as :meth:`encode` writes them."""
        if values.size == 0:
            return
        tokens, extra, _ = _tokenize(values)
        table = _model_table(models)
        for start in range(0, values.size, _TABLE_CHUNK):
            at = slice(start, start + _TABLE_CHUNK)
            self._coder.encode(tokens[at].astype(np.int32), _categorical_family(), table[which[at]])
        self._encode_signs_and_bits(values, extra)

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

    def _pull(self, model, count: int, table: NDArray[np.float64] | None = None) -> NDArray[np.int64]:
        """``count`` symbols from the range decoder (with ``table``: one per row, each under its row of
        probabilities); its complaints (data that no model could have written, as an ``AssertionError`` or
        ``ValueError``) become :class:`PayloadError`."""
        try:
            raw = self._decoder.decode(model, count) if table is None else self._decoder.decode(model, table)
            out = np.asarray(raw, dtype=np.int64)
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
        return self._values_of(self._pull(_categorical(model.zero, model.decay), n))

    def _values_of(self, tokens: NDArray[np.int64]) -> NDArray[np.int64]:
        """The values of decoded ``tokens``: their signs and raw low bits read next."""
        n = tokens.size
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

    def decode_matrices(self, shapes: Sequence[tuple[int, int]]) -> list[NDArray[np.int64]]:
        """The next matrices, of these ``(rows, cols)`` shapes, written by :meth:`IntegerEncoder.encode_matrices`.

        Raises:
            PayloadError: for a layout or line model out of range (damaged data).
        """
        shapes = [(self._check_count(r), self._check_count(c)) for r, c in shapes]
        layouts = self.decode_raw(len(shapes), 2)
        if np.any(layouts == 3):
            raise PayloadError("coded integers are damaged (matrix layout 3)")
        fields = self.decode_raw(int(np.sum(np.where(layouts == 0, 2, 6))), 8)
        line_shapes = [(c, r) if layout == 2 else (r, c) for (r, c), layout in zip(shapes, layouts)]
        singles, params, at = {}, {}, 0
        for k, layout in enumerate(layouts.tolist()):
            f = fields[at:at + (2 if layout == 0 else 6)].tolist()
            at += len(f)
            if layout == 0:
                singles[k] = Model(f[0], f[1])
            else:
                if f[0] >= LINE_LEVELS:
                    raise PayloadError("coded integers are damaged (line model level out of range)")
                params[k] = (f[0], f[1], Model(f[2], f[3]), Model(f[4], f[5]))
        lines_of = {k: line_shapes[k][0] for k in params}
        levels = self._decode_each([(lines_of[k], params[k][2]) for k in params])
        line_keys: dict[int, NDArray[np.int64]] = {}  # zero * 256 + decay of each line's model
        coded_counts, start = [], 0
        for k in params:
            lv = levels[start:start + lines_of[k]] + params[k][0]
            start += lines_of[k]
            if np.any(lv < 0) or np.any(lv >= LINE_LEVELS):
                raise PayloadError("coded integers are damaged (line model level out of range)")
            line_keys[k] = lv
            coded_counts.append(int(np.count_nonzero(lv < LINE_LEVELS - 1)))
        decays = self._decode_each([(n, params[k][3]) for n, k in zip(coded_counts, params)])
        start = 0
        for n, k in zip(coded_counts, params):
            lv = line_keys[k]
            d = np.zeros(lv.size, np.int64)
            d[lv < LINE_LEVELS - 1] = decays[start:start + n] + params[k][1]
            start += n
            if np.any(d < 0) or np.any(d > 255):
                raise PayloadError("coded integers are damaged (line model decay out of range)")
            line_keys[k] = np.minimum(16 * lv, 255) * 256 + d
        groups = []
        for k, (n, length) in enumerate(line_shapes):
            keys = np.full(n, singles[k].zero * 256 + singles[k].decay, np.int64) if k in singles else line_keys[k]
            groups.append((n * length, keys, length))
        values = self._decode_each([(n, keys) for n, keys, _ in groups], [length for *_, length in groups])
        out, start = [], 0
        for (n, _, length), layout, (r, c) in zip(groups, layouts.tolist(), shapes):
            block = values[start:start + n].reshape(r if layout != 2 else c, c if layout != 2 else r)
            start += n
            out.append(block.T.copy() if layout == 2 else block)
        return out

    def _decode_each(self, groups: Sequence[tuple[int, Model | NDArray[np.int64]]],
                     lengths: Sequence[int] | None = None) -> NDArray[np.int64]:
        """What :meth:`IntegerEncoder._encode_each` wrote for ``groups`` of ``(count, model)``: a group's values
        under its one model, or (with ``lengths``) ``(count, keys)``, its lines of ``length`` values each under
        the line's model, ``keys = zero * 256 + decay`` per line."""
        keys, firsts, lines_at, line_lengths = [], [], [], []  # per group: its first value, first key, line length
        total = base = 0
        for g, (count, model) in enumerate(groups):
            if lengths is None:
                keys.append(np.array([model.zero * 256 + model.decay], np.int64))
            else:
                keys.append(np.asarray(model, np.int64))
            firsts.append(total)
            lines_at.append(base)
            line_lengths.append(max(lengths[g], 1) if lengths is not None else max(count, 1))
            total += int(count)
            base += keys[-1].size
        if total == 0:
            return np.zeros(0, np.int64)
        distinct, index = np.unique(np.concatenate(keys), return_inverse=True)
        index = index.reshape(-1)
        table = np.stack([_probabilities(int(k) // 256, int(k) % 256) for k in distinct.tolist()])
        firsts_a, lines_a, lengths_a = (np.array(x, np.int64) for x in (firsts, lines_at, line_lengths))
        tokens = np.empty(total, np.int64)
        for start in range(0, total, _TABLE_CHUNK):  # each value's line, chunk by chunk (memory of one chunk)
            at = np.arange(start, min(start + _TABLE_CHUNK, total), dtype=np.int64)
            g = np.searchsorted(firsts_a, at, side="right") - 1
            rows = index[lines_a[g] + (at - firsts_a[g]) // lengths_a[g]]
            tokens[start:start + at.size] = self._pull(_categorical_family(), at.size, table[rows])
        return self._values_of(tokens)

    def finish(self) -> None:
        """Check that the data held nothing beyond what was decoded.

        Raises:
            PayloadError: if whole words of data were left over.
        """
        if not self._decoder.maybe_exhausted():
            raise PayloadError("coded integers are damaged (data left over after the last value)")


# ---------------------------------------------------------------------------------------------------------------
# matrices: one model, or one per row or column
# ---------------------------------------------------------------------------------------------------------------
#: Levels of a line model (0..16): zero index ``min(16 level, 255)``; level 16 (a line of zeros) has decay 0.
LINE_LEVELS = 17


@dataclass(frozen=True)
class MatrixModel:
    """How :meth:`IntegerEncoder.encode_matrices` codes a matrix of integers.

    Attributes:
        layout: 0: one model for the whole matrix; 1: one per row; 2: one per column.
        models: the one model, or one per row (column), each with a zero index ``min(16 l, 255)`` for a level
            ``l`` in 0..16 and, at level 16, decay 0.
    """

    layout: int
    models: tuple[Model, ...]

    def __post_init__(self) -> None:
        if self.layout not in (0, 1, 2):
            raise ParameterError(f"MatrixModel.layout must be 0, 1 or 2, got {self.layout!r}")
        if self.layout == 0 and len(self.models) != 1:
            raise ParameterError("a layout-0 MatrixModel has exactly one model")
        if self.layout:
            for m in self.models:
                if not (m.zero % 16 == 0 or (m.zero == 255 and m.decay == 0)):
                    raise ParameterError(f"line model {m} is not at a level (zero index 16 l, or 255 with decay 0)")

    def cost(self, values: ArrayLike) -> float:
        """Ideal length in bits of ``values`` ``(rows, cols)`` coded under this model, its parameters included
        (what :meth:`IntegerEncoder.encode_matrices` writes for it, within a few bytes)."""
        v = np.asarray(values, dtype=np.int64)
        if self.layout == 0:
            return 2.0 + 16.0 + self.models[0].cost(v)
        lines = v.T if self.layout == 2 else v
        params = _line_parameters(self.models)
        return (2.0 + 48.0 + params.level_model.cost(params.level_deltas)
                + params.decay_model.cost(params.decay_deltas)
                + sum(m.cost(line) for m, line in zip(self.models, lines)))


class _LineParameters(NamedTuple):
    base_level: int
    base_decay: int
    level_model: Model
    decay_model: Model
    level_deltas: NDArray[np.int64]
    decay_deltas: NDArray[np.int64]


def _line_parameters(models: Sequence[Model]) -> _LineParameters:
    """The stored form of line models: levels and the decays of lines below the top level, as differences from
    their medians (rounded down), each group under its own fitted model."""
    zeros = np.array([m.zero for m in models], np.int64)
    decays = np.array([m.decay for m in models], np.int64)
    levels = np.where(zeros == 255, LINE_LEVELS - 1, zeros // 16)
    coded = decays[levels < LINE_LEVELS - 1]
    base_level = int(np.floor(np.median(levels))) if levels.size else 0
    base_decay = int(np.floor(np.median(coded))) if coded.size else 0
    level_deltas, decay_deltas = levels - base_level, coded - base_decay
    return _LineParameters(base_level, base_decay, fit_model(level_deltas),
                           fit_model(decay_deltas), level_deltas, decay_deltas)


#: Tokens coded per call with a table of per-token probabilities (bounds the table's memory: 4.7 MB).
_TABLE_CHUNK = 8192


@lru_cache(maxsize=None)
def _categorical_family():
    import constriction

    return constriction.stream.model.Categorical(perfect=False)


def _model_table(models: Sequence[Model]) -> NDArray[np.float64]:
    """``(len(models), NUM_TOKENS)``: each model's token probabilities (the same doubles as its
    ``Categorical``); a model that occurs several times is looked up once."""
    if not len(models):
        return np.zeros((0, NUM_TOKENS))
    return np.stack([_probabilities(m.zero, m.decay) for m in models])


def _per_value(parts, line_length) -> tuple[NDArray[np.int64], NDArray[np.int64], list[Model]]:
    """Flattened values, the index of each value's model, and the models, from ``(values, models)`` parts: a
    part's values under its one model, or its lines (rows of a 2-d array) each under its own model."""
    values, which, models = [], [], []
    for v, part_models in parts:
        v = np.asarray(v, np.int64)
        base = len(models)
        models.extend(part_models)
        flat = v.reshape(-1)
        if len(part_models) == 1:
            which.append(np.full(flat.size, base, np.int64))
        else:
            length = line_length(v)
            which.append(base + np.arange(flat.size, dtype=np.int64) // max(length, 1))
        values.append(flat)
    if not values:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), models
    return np.concatenate(values), np.concatenate(which), models


def _fit_lines(lines: NDArray[np.int64]) -> tuple[tuple[Model, ...], float]:
    """One model at a level per line of ``lines (n, m)`` and the lines' ideal code length in bits."""
    n, m = lines.shape
    tokens, extra, nonzero = _tokenize(lines.reshape(-1))
    counts = np.bincount((np.arange(n).repeat(m) * NUM_TOKENS + tokens), minlength=n * NUM_TOKENS)
    counts = counts.reshape(n, NUM_TOKENS).astype(np.float64)
    zero_bits, tail_bits = _fit_tables()
    level_zero = np.array([16 * level for level in range(LINE_LEVELS - 1)])
    nz = m - counts[:, 0]
    zc = counts[:, :1] * zero_bits[level_zero, 0][None, :] + nz[:, None] * zero_bits[level_zero, 1][None, :]
    tc = counts[:, 1:] @ tail_bits.T
    level = np.argmin(zc, axis=1)
    decay = np.argmin(tc, axis=1)
    empty = nz == 0
    bits = np.where(empty, m * zero_bits[255, 0], zc[np.arange(n), level] + tc[np.arange(n), decay])
    models = tuple(Model(255, 0) if e else Model(16 * int(lv), int(d)) for e, lv, d in zip(empty, level, decay))
    return models, float(bits.sum() + extra.sum() + nonzero)


def fit_matrix_model(values: ArrayLike) -> MatrixModel:
    """The :class:`MatrixModel` (one model, one per row or one per column) that codes the ``(rows, cols)``
    integer matrix ``values`` in the fewest bits, parameters included (ties: the lower layout)."""
    v = np.asarray(values, dtype=np.int64)
    if v.ndim != 2:
        raise ParameterError(f"fit_matrix_model needs a 2-d array, got shape {v.shape}")
    best = MatrixModel(0, (fit_model(v),))
    if v.size == 0:
        return best
    best_bits = best.cost(v)
    for layout, lines in ((1, v), (2, v.T)):
        models, _ = _fit_lines(lines)
        candidate = MatrixModel(layout, models)
        bits = candidate.cost(v)
        if bits < best_bits:
            best, best_bits = candidate, bits
    return best


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
                         high: ArrayLike, *, test_ends: bool = True) -> NDArray[np.int64]:
    """:func:`largest_passing` for many independent indices at once, in lockstep.

    ``passes(indices)`` tests a whole ``(n,)`` vector of indices in one call (for example one quantisation and
    one evaluation of every segment of a clip) and returns ``(n,)`` booleans.  Bisects each entry within its own
    ``[low, high]`` (``low`` is tested only when some entry fails at ``high``).  With ``test_ends=False`` neither
    end is tested (two calls fewer): ``high`` is taken to fail and ``low`` to pass, so each entry ends in
    ``[low, high - 1]``, and an entry that ends at ``low`` was never seen to pass (the caller tests it).

    Returns:
        ``(n,)`` indices: each the largest one seen to pass, or ``low - 1`` where not even ``low`` passed (the
        caller decides what to do there; with ``test_ends=False``: ``low``).  When the entries are not quite
        independent (a segment's result depends a little on its neighbours'), test the final vector again.
    """
    lo = np.asarray(low, dtype=np.int64).copy()
    hi = np.asarray(high, dtype=np.int64).copy()
    if lo.shape != hi.shape or lo.ndim != 1 or np.any(hi < lo):
        raise ParameterError("low and high must be (n,) integer vectors with low <= high")
    if test_ends:
        ok_high = np.asarray(passes(hi), dtype=bool)
        if ok_high.all():  # every entry passes at its high end: low decides nothing
            return hi
        ok_low = np.asarray(passes(lo), dtype=bool)
    else:
        ok_high, ok_low = np.zeros(lo.shape, bool), np.ones(lo.shape, bool)
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
