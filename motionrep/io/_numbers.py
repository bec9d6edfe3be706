"""Bulk parsing of whitespace-separated numbers with numpy (the BVH MOTION block).

Every value is bit-identical to ``float(token)``; the fast paths never leave numpy.

1. :func:`scan_tokens` finds the tokens (runs of bytes > 32) and counts them per line.
2. Each token of at most 16 bytes is copied, right-aligned, into a 16-byte row (one fancy-indexing gather of a
   16-byte ``void`` view of the block) and handled as two little-endian ``uint64`` words: the sign is read from
   the token's first byte, the bytes left of the token are cleared, the decimal point is removed by moving the
   bytes before it one column right, every byte is checked to be a digit, and the digits are combined eight at
   a time with three multiply-shift steps (SWAR).  When the first token of a chunk has its '.' in some column
   and all others do too (a fixed number of decimals, the usual layout), that column is used for the whole
   chunk; otherwise each token's '.' is located with one multiply.
3. The integer mantissa is below 2**53 and is divided by (or, with an exponent, multiplied by) a power of ten
   of at most 22, both exact doubles, so the one correctly rounded IEEE operation gives the correctly rounded
   value of the decimal string (Clinger's fast path): the same answer as ``float``.
4. Tokens with an exponent are parsed in a second pass: C's ``%g`` layouts (``5.1072e-06``, ``-9.2e-007``) are
   read from their last bytes, others split at the ``e``; mantissa and exponent go through step 2.  Whatever is
   left (more than 15 significant digits, powers of ten beyond 22, ``nan``, ``inf``, junk) is converted one
   token at a time with Python's ``float`` (ASCII only, no ``_``); a token it rejects is reported by index so
   the caller can name its line.

The work is done in chunks of 8192 tokens: their temporaries stay in the CPU cache and their memory is reused
(fresh pages cost more than the arithmetic here).  Parsing two halves of the block in two threads was tried: on
the shared two-core machine it was slower than one thread, so it is not done.
"""

from __future__ import annotations

import sys

import numpy as np
from numpy.typing import NDArray

__all__ = ["TokenTable", "scan_tokens", "parse_number_tokens"]

_W = 16  # bytes per token row on the fast path
_CHUNK = 1 << 13  # tokens per chunk: the temporaries (128 kB) stay in cache and their memory is reused

_U = np.uint64
_SIX = _U(0x0606060606060606)
_HIGH_NIBBLES = _U(0xF0F0F0F0F0F0F0F0)
_SWAR1, _MASK1 = _U(2561), _U(0x00FF00FF00FF00FF)
_SWAR2, _MASK2 = _U(6553601), _U(0x0000FFFF0000FFFF)
_SWAR3 = _U(42949672960001)
_E8 = _U(10 ** 8)
_TWO53 = _U(2 ** 53)
_POW10 = 10.0 ** np.arange(23)
_MAX_POW = 22


def _byte_table(rows: list[list[int]]) -> NDArray:
    """A table of 16-byte rows, as a 1-D ``V16`` array so that fancy indexing copies whole rows fast."""
    return np.array(rows, np.uint8).view("V16").reshape(-1)


# _KEEP[k]: 0xFF in columns >= k (clears the bytes before a token and its sign), k = 0..16
_KEEP = _byte_table([[255 if c >= k else 0 for c in range(_W)] for k in range(_W + 1)])
# _BEFORE_DOT[c]: 0xFF in columns < c, where c = (column of the '.') + 1, or 0 without a '.'
_BEFORE_DOT = _byte_table([[255 if col < c else 0 for col in range(_W)] for c in range(_W + 1)])
# _DECIMALS[c], _DIVISOR[c]: the number of digits after the '.' and 10 to that power, the same c
_DECIMALS = np.array([0] + [_W - c for c in range(1, _W + 1)], np.int64)
_DIVISOR = 10.0 ** _DECIMALS
# One 0x01 byte at column p of a word, times _DOT_CODE, puts p + 1 (p + 9 in the second word) in the top byte
_DOT_CODE = np.array([sum((p + 1 + 8 * w) << (8 * (7 - p)) for p in range(8)) for w in (0, 1)], np.uint64)
# The words hold bytes in memory order: the digit arithmetic needs a little-endian machine
_FAST = sys.byteorder == "little"


class TokenTable:
    """Where the whitespace-separated tokens of a byte block are.

    Attributes:
        starts, ends: ``(T,)`` int64 byte offsets of each token (``ends`` exclusive).
        newlines: byte offsets of the block's newline characters.
        line_counts: ``(L,)`` number of tokens on each line of the block (``L = len(newlines) + 1``).
    """

    __slots__ = ("starts", "ends", "newlines", "line_counts")

    def __init__(self, starts: NDArray, ends: NDArray, newlines: NDArray):
        self.starts, self.ends, self.newlines = starts, ends, newlines
        before = np.searchsorted(starts, newlines)  # tokens starting before each newline
        self.line_counts = np.diff(before, prepend=0, append=starts.shape[0])

    def line_of(self, i: int) -> int:
        """0-based line index (within the block) of token ``i``."""
        return int(np.searchsorted(self.newlines, self.starts[i]))


def scan_tokens(u: NDArray[np.uint8]) -> TokenTable:
    """Locate the tokens of the bytes ``u`` (whitespace = any byte <= 32) and count them per line."""
    n = u.shape[0]
    newlines = np.flatnonzero(u == 10)
    if n == 0:
        empty = np.zeros(0, np.int64)
        return TokenTable(empty, empty, newlines)
    space = u <= 32
    edges = np.empty(n + 1, np.bool_)  # edges[i]: a token starts or ends at offset i
    edges[0] = not space[0]
    edges[n] = not space[-1]
    np.not_equal(space[1:], space[:-1], out=edges[1:n])
    at = np.flatnonzero(edges)  # token i spans at[2i] .. at[2i + 1]
    return TokenTable(at[0::2], at[1::2], newlines)


def _rows(padded: NDArray[np.uint8], ends: NDArray[np.int64]) -> NDArray:
    """``(T,)`` ``V16`` rows: the 16 bytes of the block that end at each offset in ``ends``.

    ``padded`` is the block with 16 zero bytes before it (and one after), so the row of a token ending at
    block offset ``e`` starts at ``padded[e]``; a ``V16`` view with a one-byte stride makes the gather a
    plain fancy index of whole rows.
    """
    view = np.ndarray(buffer=padded, dtype="V16", shape=(padded.shape[0] - _W + 1,), strides=(1,))
    return view[ends]


def _sign_and_clear(padded, starts, ends, rows, T):
    """Read the sign from each token's first byte and clear the row bytes before the digits.

    ``rows`` (``(T,)`` ``V16``) are turned in place into digit values (``'0'`` -> 0, ``'.'`` -> 0xFE).
    Returns ``(words (T, 2) uint64 view of rows, length, negative, signed)``.
    """
    first = padded[_W:][starts]
    negative = first == 45
    signed = negative | (first == 43)
    length = ends - starts
    b = rows.view(np.uint8)
    np.subtract(b, np.uint8(48), out=b)  # '0'..'9' -> 0..9, '.' -> 0xFE
    w = rows.view(np.uint64).reshape(T, 2)
    k = _W - length  # first column of the token: keep columns >= k (+1 past a sign)
    k += signed
    if T and (k.min() < 0):  # tokens longer than 16 bytes: fixed by the caller's length check
        np.maximum(k, 0, out=k)
    w &= _KEEP[k].view(np.uint64).reshape(T, 2)
    return w, length, negative, signed


def _finish(w, bad):
    """Combine the digit bytes of ``w`` (``(T, 2)``) into a ``uint64`` mantissa per token.

    ``bad`` is None or a ``(T,)`` bool of tokens already known to be wrong; returned with the tokens whose bytes
    are not all digits 0..9 added (None while every token is fine: the per-token test runs only if the cheap
    test over the whole chunk fails).
    """
    check = w + _SIX  # a byte > 9 sets a high nibble, itself or after adding 6
    check |= w
    check &= _HIGH_NIBBLES
    if check.any():
        not_digits = (check[:, 0] | check[:, 1]) != 0
        bad = not_digits if bad is None else bad | not_digits
    # eight digits per word to an integer (SWAR), then the two words
    w *= _SWAR1
    w >>= _U(8)
    w &= _MASK1
    w *= _SWAR2
    w >>= _U(16)
    w &= _MASK2
    w *= _SWAR3
    w >>= _U(32)
    mantissa = w[:, 0] * _E8
    mantissa += w[:, 1]
    return mantissa, bad


def _remove_dot(w, before_dot):
    """Move the bytes in the columns selected by ``before_dot`` one column right, over the '.'."""
    shifted = w << _U(8)
    shifted[:, 1] |= w[:, 0] >> _U(56)
    shifted ^= w
    shifted &= before_dot
    w ^= shifted


def _either(bad, more):
    return more if bad is None else bad | more


def _digits(padded, starts, ends):
    """Integer mantissa of decimal tokens (``[-+]digits[.digits]``, at most 16 bytes).

    Returns:
        ``(mantissa uint64, c int, negative bool, bad bool or None)`` per token: the value is
        ``mantissa / _DIVISOR[c]`` negated where ``negative`` (``c`` is the column of the '.' plus one, 0
        without one); ``bad`` marks the tokens that are not such decimals or whose mantissa is 2**53 or more
        (None: no such token).
    """
    T = ends.shape[0]
    rows = _rows(padded, ends)
    w, length, negative, signed = _sign_and_clear(padded, starts, ends, rows, T)
    # the column of the '.' (+1), from a multiply that collects the flag bytes into the top byte
    code = (rows.view(np.uint8) == 254).view(np.uint64).reshape(T, 2) * _DOT_CODE
    code >>= _U(56)
    c = code[:, 0] + code[:, 1]
    np.minimum(c, _U(_W), out=c)  # several '.' give a wrong column; one of them remains and fails the check
    _remove_dot(w, _BEFORE_DOT[c].view(np.uint64).reshape(T, 2))
    digits = length - signed
    digits -= c > 0
    bad = None
    if digits.min() < 1 or length.max() > _W:
        bad = (digits < 1) | (length > _W)
    mantissa, bad = _finish(w, bad)
    if digits.max() >= 16:  # only sixteen digits can reach 2**53
        bad = _either(bad, mantissa >= _TWO53)
    return mantissa, c, negative, bad


def _digits_fixed(padded, starts, ends, dot):
    """:func:`_digits` for tokens that all have their '.' in column ``dot`` (a fixed number of decimals).

    Returns ``(mantissa, negative, bad)``, or None if some token has no '.' in that column.  With a '.',
    a token has at most 15 digits, so its mantissa is below 2**53.
    """
    T = ends.shape[0]
    rows = _rows(padded, ends)
    if not np.all(rows.view(np.uint8).reshape(T, _W)[:, dot] == 46):
        return None
    w, length, negative, signed = _sign_and_clear(padded, starts, ends, rows, T)
    # move the columns 0..dot one column right: whole words where they lie entirely before the '.'
    w0, w1 = w[:, 0], w[:, 1]
    if dot >= 8:
        keep = _U(((1 << 64) - 1) << (8 * (dot - 7)) & ((1 << 64) - 1))  # word-1 bytes after the '.'
        moved = w1 << _U(8)
        moved |= w0 >> _U(56)
        np.left_shift(w0, _U(8), out=w0)
        moved ^= w1
        moved &= ~keep
        w1 ^= moved
    else:
        keep = _U(((1 << 64) - 1) << (8 * (dot + 1)) & ((1 << 64) - 1))
        moved = w0 << _U(8)
        moved ^= w0
        moved &= ~keep
        w0 ^= moved
    inside = length - signed  # the '.' must be inside the token, with a digit besides it
    bad = None
    if inside.min() < max(_W - dot, 2) or length.max() > _W:
        bad = (inside < max(_W - dot, 2)) | (length > _W)
    mantissa, bad = _finish(w, bad)
    return mantissa, negative, bad


_NONE = np.zeros(0, np.int64)  # no token left over


def _parse_chunk(padded, starts, ends, out, failed):
    """Parse tokens ``starts/ends`` into ``out``; append the indices (in the chunk) of tokens left over."""
    fixed = None
    e = int(ends[0])
    dot = padded[e: e + _W].tobytes().rfind(b".")  # the column of the first token's '.', if any
    if dot >= 0:
        fixed = _digits_fixed(padded, starts, ends, dot)
    # value = mantissa / (+-10^decimals): the mantissa (< 2**53) converts exactly, then one correctly rounded
    # division; the sign goes with the divisor (0 / -10^k is -0.0, as float("-0.0"))
    if fixed is not None:
        mantissa, negative, bad = fixed
        divisor = _DIVISOR[dot + 1]
        np.divide(mantissa, np.where(negative, -divisor, divisor), out=out)
    else:
        mantissa, c, negative, bad = _digits(padded, starts, ends)
        divisor = _DIVISOR[c]
        np.divide(mantissa, np.where(negative, -divisor, divisor), out=out)
    if bad is not None:
        rest = np.flatnonzero(bad)
        if rest.size:
            failed.append(_parse_exponents(padded, starts, ends, rest, out))
            return
    failed.append(_NONE)


def _scale_and_store(out, which, mantissa, c, negative, exponent, ok) -> NDArray:
    """``out[which] = +-mantissa * 10**(exponent - decimals)`` where ``ok`` and the power is at most 22 in size
    (one correctly rounded multiplication or division of exact doubles); returns the mask of those stored."""
    power = exponent - _DECIMALS[c]
    ok = ok & (np.abs(power) <= _MAX_POW)
    p = np.minimum(np.abs(power), _MAX_POW)
    v = mantissa.astype(np.float64)  # exact: mantissa < 2**53
    v = np.where(power >= 0, v * _POW10[p], v / _POW10[p])
    np.negative(v, out=v, where=negative)
    out[which[ok]] = v[ok]
    return ok


def _parse_exponents(padded, starts, ends, idx, out):
    """Tokens ``idx`` that failed the decimal path: those of the form ``<decimal>e<integer>`` are parsed here.

    First the layouts C's ``%g`` prints, a two- or three-digit signed exponent at the end (``1.5e-06``,
    ``-9.2e-007``), read straight from the last bytes; then any other exponent, found by searching the token.
    Returns the indices of the tokens still left.
    """
    block = padded[_W:]
    left = [np.zeros(0, np.int64)]  # exponent tokens out of the fast range: for Python's float
    for width in (2, 3):  # e<sign><width digits>
        if idx.size == 0:
            return left[0] if len(left) == 1 else np.sort(np.concatenate(left))
        e = ends[idx]
        at = e - (width + 2)  # where the 'e' would be
        fits = at > starts[idx]
        at = np.where(fits, at, e - 1)
        letter, sign = block[at], block[at + 1]
        match = fits & ((letter == 101) | (letter == 69)) & ((sign == 45) | (sign == 43))
        exponent = np.zeros(idx.shape[0], np.int64)
        for k in range(width):
            digit = block[np.minimum(at + 2 + k, e - 1)].astype(np.int64) - 48
            match &= (digit >= 0) & (digit <= 9)
            exponent = exponent * 10 + digit
        if not match.any():
            continue
        cand = idx[match]
        m, c, neg, bad = _digits(padded, starts[cand], at[match])
        ok = np.ones(cand.shape[0], bool) if bad is None else ~bad
        exponent = np.where(sign[match] == 45, -exponent[match], exponent[match])
        stored = _scale_and_store(out, cand, m, c, neg, exponent, ok)
        left.append(cand[~stored])
        idx = idx[~match]
    if idx.size == 0:
        return np.sort(np.concatenate(left))
    length = ends[idx] - starts[idx]
    rows = _rows(padded, ends[idx]).view(np.uint8).reshape(-1, _W)
    is_e = ((rows == 101) | (rows == 69)) & (np.arange(_W) >= (_W - length)[:, None])
    col = np.argmax(is_e, axis=1)
    has_e = is_e[np.arange(idx.shape[0]), col] & (length <= _W)
    if not has_e.any():
        return np.sort(np.concatenate(left + [idx]))
    cand = idx[has_e]
    e_pos = ends[cand] - _W + col[has_e]
    m, c, neg, bad = _digits(padded, starts[cand], e_pos)
    x, xc, xneg, xbad = _digits(padded, e_pos + 1, ends[cand])
    ok = xc == 0
    for b in (bad, xbad):
        if b is not None:
            ok &= ~b
    exponent = np.where(xneg, -x.astype(np.int64), x.astype(np.int64))
    stored = _scale_and_store(out, cand, m, c, neg, exponent, ok)
    return np.sort(np.concatenate(left + [idx[~has_e], cand[~stored]]))


def _python_float(token: bytes) -> float | None:
    """``float(token)`` for the tokens the fast path leaves; None if it is not a number."""
    if b"_" in token or not token.isascii():  # float() would take 1_000 and non-ASCII digits
        return None
    try:
        return float(token)
    except ValueError:
        return None


def parse_number_tokens(u: NDArray[np.uint8], tokens: TokenTable) -> tuple[NDArray[np.float64], int | None]:
    """Values of all tokens, bit-identical to ``float(token)``.

    Returns:
        ``(values, bad)``: ``(T,)`` float64 values and the index of the first token that is not a number
        (``None`` if all are).  ``nan`` and ``inf`` are numbers here; the caller decides about them.
    """
    starts, ends = tokens.starts, tokens.ends
    T = starts.shape[0]
    values = np.empty(T)
    if T == 0:
        return values, None
    padded = np.zeros(u.shape[0] + _W + 1, np.uint8)
    padded[_W:-1] = u
    bounds = list(range(0, T, _CHUNK)) + [T]
    if _FAST:
        failed: list[NDArray] = []
        for a, b in zip(bounds, bounds[1:]):
            _parse_chunk(padded, starts[a:b], ends[a:b], values[a:b], failed)
        left = np.concatenate([f + a for f, a in zip(failed, bounds)])
    else:  # pragma: no cover - big-endian machines
        left = np.arange(T)
    if left.size:
        raw = u.data  # the tokens the fast paths left, one at a time with Python's float
        for i, a, b in zip(left.tolist(), starts[left].tolist(), ends[left].tolist()):
            v = _python_float(bytes(raw[a:b]))
            if v is None:
                return values, i
            values[i] = v
    return values, None
