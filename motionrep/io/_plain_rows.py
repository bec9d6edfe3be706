"""Plain decimal frame lines read exactly with whole-array integer arithmetic: the numpy path's fast way through a
BVH MOTION block (:func:`parse_plain_rows`), for a process that has not paid numba's start-up
(:func:`motionrep.io._numbers.use_compiled`).  It answers only when it is sure; otherwise the caller runs the exact
token-by-token path (:mod:`motionrep.io._numbers`), which gives the same values or names the fault and its line.
"""

from __future__ import annotations

import sys

import numpy as np
from numpy.typing import NDArray

__all__ = ["parse_plain_rows"]

# what a frame block read by :func:`parse_plain_rows` may hold: ASCII digits, '.', signs, exponent letters and the
# whitespace every path takes as a separator (space, tab, LF, VT, FF; CR is left to the exact paths)
_PLAIN_BYTES = b"0123456789.+-eE \t\n\x0b\x0c"
#: bytes of whole lines converted at a time: the temporaries stay in cache (measured: 2**16-2**17 fastest)
_PLAIN_CHUNK = 1 << 17
_PLAIN_POW10 = 10.0 ** np.arange(17)  # exact doubles
_ONES = np.uint64(0x0101010101010101)
_THREES = np.uint64(0x3030303030303030)
_NIBBLES = np.uint64(0xF0F0F0F0F0F0F0F0)
_SIXES = np.uint64(0x0606060606060606)
_DOTS = np.uint64(0x2E2E2E2E2E2E2E2E)
#: for k = 0..8: the word keeping its bytes k..7 (little-endian: the lowest k bytes cleared)
_KEEP = np.array([(0xFFFFFFFFFFFFFFFF << (8 * k)) & 0xFFFFFFFFFFFFFFFF for k in range(9)], np.uint64)


def _eight_digits(w: NDArray[np.uint64]) -> NDArray[np.uint64]:
    """The integer of eight ASCII digits held in each word, the first (most significant) digit in the lowest byte
    (a little-endian load of the text): three multiply-and-shift steps (the SWAR method simdjson uses)."""
    w = ((w & np.uint64(0x0F0F0F0F0F0F0F0F)) * np.uint64(2561)) >> np.uint64(8)
    w = ((w & np.uint64(0x00FF00FF00FF00FF)) * np.uint64(6553601)) >> np.uint64(16)
    return ((w & np.uint64(0x0000FFFF0000FFFF)) * np.uint64(42949672960001)) >> np.uint64(32)


def _zero_bytes(w: NDArray[np.uint64]) -> NDArray[np.uint64]:
    """0x01 in each byte of ``w`` that is zero, 0x00 in the others (exact: each byte is tested on its own seven low
    bits and its high bit, so no carry crosses bytes)."""
    low = np.uint64(0x7F7F7F7F7F7F7F7F)
    nonzero = ((w & low) + low) | w  # high bit of each byte: set where the byte is not zero
    return ((~nonzero) >> np.uint64(7)) & _ONES


def _all_digits(w: NDArray[np.uint64]) -> NDArray[np.bool_]:
    """Whether every byte of ``w`` is an ASCII digit 0x30-0x39: high nibble 3, and still 3 after adding 6 (no
    carry can cross bytes once every high nibble is 3)."""
    return ((w & _NIBBLES) == _THREES) & (((w + _SIXES) & _NIBBLES) == _THREES)


def parse_plain_rows(data: bytes, rows: int, width: int) -> NDArray[np.float64] | None:
    """The ``rows * width`` values of ``data`` when it is exactly ``rows`` lines of ``width`` numbers (lines
    without tokens anywhere, as :func:`scan_block` allows them), each bit-identical to ``float(token)``; None on
    any doubt, for the caller to run the exact path (which then gives the values, or names the fault and line).

    Exact by construction, in whole-array operations (no numba, no Python object per number):

    1. every byte is a digit, ``.``, ``+``, ``-``, ``e``, ``E`` or whitespace other than CR (``bytes.translate``
       deletes those; anything left -- ``nan``, ``inf``, ``_``, hex, CR, non-ASCII -- means None);
    2. tokens (runs of bytes > 32) and lines (LF) are found with numpy: every line holds no token or ``width``,
       ``rows * width`` tokens in all, or None;
    3. each token of at most 16 bytes that is an optional sign, digits and at most one ``.`` (at least one
       digit) is copied right-aligned into a 16-byte row, the bytes before its first digit or ``.`` set to '0'
       and the ``.`` taken out; its 16 digits are read eight at a time with integer multiplications, giving the
       integer mantissa ``m`` and the number of decimals ``d``.  With ``m < 2**53`` both ``m`` and ``10**d`` are
       exact doubles and one correctly rounded division gives the correctly rounded value of the decimal
       (Clinger's fast path, the compiled loop's rule), i.e. ``float(token)``;
    4. the other tokens (exponents, long mantissas, malformed ones) are converted by ``float`` itself; one it
       rejects, or a value that is not finite, means None.
    """
    if (rows <= 0 or width <= 0 or sys.byteorder != "little" or len(data) < 16
            or data.translate(None, _PLAIN_BYTES)):
        return None
    total = rows * width
    if total > (len(data) + 1) // 2:  # more values than the bytes can hold (a short file declaring many frames)
        return None
    values = np.empty(total)
    filled = 0
    pos = 0
    n = len(data)
    # word i: data[i:i + 8] as a little-endian integer; head: the same for the first 16 bytes after 16 spaces
    view = np.ndarray(buffer=data, dtype=np.uint64, shape=(n - 7,), strides=(1,))
    head = np.ndarray(buffer=b" " * 16 + data[:16], dtype=np.uint64, shape=(25,), strides=(1,))
    while pos < n:
        stop = data.find(b"\n", min(pos + _PLAIN_CHUNK, n) - 1)
        stop = n if stop < 0 else stop + 1
        if stop - pos > 4 * _PLAIN_CHUNK:  # one very long line: the exact path reads it
            return None
        got = _plain_chunk(data, pos, stop, width, view, head, values, filled)
        if got is None:
            return None
        filled = got
        pos = stop
    return values if filled == total else None


def _plain_chunk(data: bytes, pos: int, stop: int, width: int, view: NDArray, head: NDArray,
                 values: NDArray[np.float64], filled: int) -> int | None:
    """:func:`parse_plain_rows` of the whole lines ``data[pos:stop]``: their values into ``values[filled:]``;
    the new count, or None."""
    u = np.frombuffer(data, np.uint8, stop - pos, pos)
    token = u > 32
    bounds = np.flatnonzero(token[1:] != token[:-1]) + 1
    if token[0]:
        bounds = np.concatenate(([0], bounds))
    if token[-1]:
        bounds = np.concatenate((bounds, [u.shape[0]]))
    starts, ends = bounds[0::2], bounds[1::2]
    count = starts.shape[0]
    if count == 0:
        return filled
    if filled + count > values.shape[0]:
        return None
    # tokens per line: how many start before each LF, differenced; a line holds none or `width`
    per_line = np.diff(np.searchsorted(starts, np.flatnonzero(u == 10)), prepend=0, append=count)
    if np.any((per_line != 0) & (per_line != width)):
        return None
    length = ends - starts
    first = u[starts]
    signed = (first == 43) | (first == 45)
    # each token right-aligned in 16 bytes, as two words: w0 bytes 0-7 (its leading part), w1 bytes 8-15
    at = ends + pos
    w0 = view[np.maximum(at - 16, 0)]
    w1 = view[np.maximum(at - 8, 0)]
    near = np.flatnonzero(at < 16)  # the first tokens: their rows start before the data
    w0[near] = head[at[near]]
    w1[near] = head[at[near] + 8]
    k = 16 - length + signed  # bytes before the first digit or '.': made '0' (k < 0: too long, slow)
    keep0, keep1 = _KEEP[np.minimum(np.maximum(k, 0), 8)], _KEEP[np.minimum(np.maximum(k - 8, 0), 8)]
    w0 = (w0 & keep0) | (_THREES & ~keep0)
    w1 = (w1 & keep1) | (_THREES & ~keep1)
    # the '.': bytes equal to 0x2E, as 0x01 bytes (found exactly: no carry crosses bytes); the byte's place q in
    # its word from the lowest set bit, a power of two (exact in a double)
    d0 = _zero_bytes(w0 ^ _DOTS)
    d1 = _zero_bytes(w1 ^ _DOTS)
    dots = (((d0 + d1) * _ONES) >> np.uint64(56)).view(np.int64)
    in0, in1 = d0 != 0, d1 != 0
    q0 = np.maximum(np.frexp(d0.astype(np.float64))[1] - 1, 0) >> 3
    q1 = np.maximum(np.frexp(d1.astype(np.float64))[1] - 1, 0) >> 3
    # the '.' taken out: the bytes before it move one place right (up a byte), a '0' comes in at byte 0
    eight = np.uint64(8)
    w0_in0 = ((w0 & ~_KEEP[q0]) << eight) | (w0 & _KEEP[q0 + 1]) | np.uint64(0x30)
    w1_in1 = ((w1 & ~_KEEP[q1]) << eight) | (w1 & _KEEP[q1 + 1]) | (w0 >> np.uint64(56))
    w0 = np.where(in1, (w0 << eight) | np.uint64(0x30), np.where(in0, w0_in0, w0))
    w1 = np.where(in1, w1_in1, w1)
    mantissa = (_eight_digits(w0) * np.uint64(100000000) + _eight_digits(w1)).view(np.int64)
    decimals = np.where(in1, 7 - q1, np.where(in0, 15 - q0, 0))
    ok = (_all_digits(w0) & _all_digits(w1) & (dots <= 1) & (length - signed - dots >= 1) & (k >= 0)
          & (mantissa < 2 ** 53))
    v = mantissa.astype(np.float64) / _PLAIN_POW10[decimals]
    out = values[filled:filled + count]
    np.copyto(out, np.where(first == 45, -v, v))
    for i in np.flatnonzero(~ok).tolist():  # exponents, long mantissas, malformed tokens: float decides
        try:
            x = float(data[pos + starts[i]:pos + ends[i]])
        except ValueError:
            return None
        if x - x != 0.0:  # inf (no nan: the only letters are e and E)
            return None
        out[i] = x
    return filled + count
