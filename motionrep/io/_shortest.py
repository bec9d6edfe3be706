"""BVH frame values as text in one compiled pass: the bytes of ``motionrep.io._bvh._format_shortest``, exactly.

The numpy writer formats whole arrays, but half the values of a clip whose angles were computed (from
quaternions: AMASS, a decoder's output) need 17 significant digits, and those go through Python's ``repr``
one at a time, then through byte rows: about 1 s for 2 million such values.  This kernel writes every value
straight into one byte buffer:

1. ``d`` and ``m`` of :func:`motionrep.io._bvh._shortest_decimals` by the very same IEEE operations (the fewest
   decimals, at most 17 with ``m < 2**53``, that read back as the value), then ``m``'s digits: fixed point,
   ``-`` for a negative value (``-0`` too);
2. otherwise ``repr``'s digits, computed exactly where that is easy to be sure of: a normal value with
   ``1e-3 <= |x| < 2**52`` whose significand is not a power of two (its rounding interval is symmetric).  With
   ``x = f 2**e`` (``e < 0``), ``x 10**k`` is ``f 10**k / 2**-e``, a 128-bit integer division by a power of two
   (two uint64 halves); for ``n`` = 1, 2, ... significant digits the nearest decimal ``D 10**-k`` is taken and it
   reads back as ``x`` iff ``|D 2**(1-e) - 2 f 10**k| < 10**k`` (inside the half-ulp interval): the first
   ``n`` that does is repr's shortest, and the nearest of that length is the one repr writes (David Gay's
   shortest mode).  Written positionally, as repr does for ``1e-4 <= |x| < 1e16``;
3. anything else (ties, a boundary hit exactly, a power-of-two significand, other magnitudes, a first candidate
   already exact) is left to Python's ``repr``: its place in the output is recorded and the caller splices it in.

``tests/test_io_bvh_writer.py`` compares the kernel with the numpy writer on hostile values and real clips.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..jit import jit, jit_inline

__all__ = ["format_shortest_compiled"]

_U = np.uint64
_POW10F = 10.0 ** np.arange(18)
_POW10U = np.array([10 ** k for k in range(20)], np.uint64)
_MAX_SAFE = 2.0 ** 53
_M32, _S32 = _U(0xFFFFFFFF), _U(32)
_ONE, _ZERO = _U(1), _U(0)
_FRACTION, _HIDDEN = _U((1 << 52) - 1), _U(1 << 52)
#: Values left to repr whose place the first pass records; more take a second pass.
_FALLBACK_CAPACITY = 4096
_WIDTH = 26  # the most bytes a value takes (repr of a double: 24) and its separator


@jit_inline
def _mul(a, b):
    """The 128-bit product of uint64 ``a`` and ``b`` as ``(hi, lo)``."""
    a0, a1, b0, b1 = a & _M32, a >> _S32, b & _M32, b >> _S32
    p00, p01, p10, p11 = a0 * b0, a0 * b1, a1 * b0, a1 * b1
    mid = (p00 >> _S32) + (p01 & _M32) + (p10 & _M32)
    return p11 + (p01 >> _S32) + (p10 >> _S32) + (mid >> _S32), (p00 & _M32) | (mid << _S32)


@jit_inline
def _shl(hi, lo, s):
    """``(hi, lo) << s`` for ``1 <= s <= 63``."""
    return (hi << _U(s)) | (lo >> _U(64 - s)), lo << _U(s)


@jit_inline
def _digits(out, pos, x, count):
    """Write the ``count`` lowest decimal digits of uint64 ``x`` at ``out[pos:pos + count]``."""
    for i in range(count - 1, -1, -1):
        q = x // _U(10)
        out[pos + i] = (x - q * _U(10)) + _U(48)
        x = q


@jit_inline
def _nearest(f, s, E, n, mask, half):
    """``(status, D)``: the nearest decimal of ``n`` significant digits to ``a = f 2**-s`` (exponent ``E``) is
    ``D 10**(E + 1 - n)``; status 1 if it reads back as ``a``, 0 if not, 2 if this cannot be sure (a tie, the
    interval's boundary, ``E`` off by one)."""
    k = n - 1 - E
    p = _POW10U[k]
    hi, lo = _mul(f, p)
    q = (lo >> _U(s)) | (hi << _U(64 - s))
    r = lo & mask
    if r == half:
        return 2, _ZERO
    D = q + _ONE if r > half else q
    if D < _POW10U[n - 1] or D >= _POW10U[n]:
        return 2, _ZERO  # E is off by one (near a power of ten), or the nearest is 10**n
    # |D 2**(s + 1) - 2 f 10**k| against 10**k
    ah, al = _shl(_ZERO, D, s + 1)
    bh, bl = _shl(hi, lo, 1)
    if ah > bh or (ah == bh and al >= bl):
        dh, dl = ah - bh - (_ONE if al < bl else _ZERO), al - bl
    else:
        dh, dl = bh - ah - (_ONE if bl < al else _ZERO), bl - al
    if dh == _ZERO and dl == p:
        return 2, _ZERO
    return (1 if dh == _ZERO and dl < p else 0), D


@jit_inline
def _repr_digits(a):
    """``(D, n, E)``: repr's shortest digits ``D`` (``n`` of them) of ``a > 0`` and its decimal exponent ``E``
    (``a`` is about ``D 10**(E + 1 - n)``); ``n = 0`` where this cannot be sure (module docstring, step 2).

    Whether ``n`` digits suffice is monotone in ``n`` (a shorter decimal padded with zeros is a longer one), so
    the search starts at 16 (most values that get here need 16 or 17) and walks down while ``n`` digits do."""
    if not (1e-3 <= a < 4503599627370496.0):
        return _ZERO, 0, 0
    bits = _bits(a)
    f = (bits & _FRACTION) | _HIDDEN
    s = 1075 - np.int64(bits >> _U(52))  # a = f 2**-s, 1 <= s <= 61 in this range
    if (bits & _FRACTION) == _ZERO:
        return _ZERO, 0, 0
    E = np.int64(np.floor(np.log10(a)))
    if E < -3 or E > 14:
        return _ZERO, 0, 0
    low = 1 if E + 2 < 1 else E + 2  # fewer digits would make a whole number (those have d >= 0)
    mask = (_ONE << _U(s)) - _ONE
    half = _ONE << _U(s - 1)
    status, D = _nearest(f, s, E, 16, mask, half)
    if status == 2:
        return _ZERO, 0, 0
    if status == 0:
        status, D = _nearest(f, s, E, 17, mask, half)
        return (D, 17, E) if status == 1 else (_ZERO, 0, 0)
    n = 16
    while n > low:
        status, shorter = _nearest(f, s, E, n - 1, mask, half)
        if status == 2:
            return _ZERO, 0, 0
        if status == 0:
            break
        D = shorter
        n -= 1
    else:
        return _ZERO, 0, 0  # n digits suffice down to the search's start: a shorter one might exist below it
    while D % _U(10) == _ZERO:  # not expected at the shortest length; repr writes none
        D //= _U(10)
        n -= 1
    if n <= E + 1:  # a whole number: repr writes '.0' (not expected: it has d >= 0)
        return _ZERO, 0, 0
    return D, n, E


@jit_inline
def _bits(a):
    return np.array([a]).view(np.uint64)[0]


@jit
def _format_kernel(flat, C, out, fallback):
    """Write ``flat``'s values (``C`` per line) into ``out``; return ``(length, fallbacks)``, the first rows of
    ``fallback`` (as many as fit) holding ``(offset in out, value index)`` of each value left to repr."""
    pos = 0
    left = 0
    for i in range(flat.shape[0]):
        v = flat[i]
        a = abs(v)
        negative = np.signbit(v)
        small = min(a, _MAX_SAFE)
        d = -1
        m = 0.0
        for k in range(18):  # _shortest_decimals, operation for operation
            cand = np.rint(small * _POW10F[k])
            if cand < _MAX_SAFE and cand / _POW10F[k] == a:
                d = k
                m = cand
                break
        if d >= 0:
            if negative:
                out[pos] = 45
                pos += 1
            mi = _U(m)
            whole = mi // _POW10U[d]
            count = 1
            while count < 17 and whole >= _POW10U[count]:
                count += 1
            _digits(out, pos, whole, count)
            pos += count
            if d > 0:
                out[pos] = 46
                _digits(out, pos + 1, mi - whole * _POW10U[d], d)
                pos += d + 1
        else:
            D, n, E = _repr_digits(a)
            if n == 0:
                if left < fallback.shape[0]:
                    fallback[left, 0] = pos
                    fallback[left, 1] = i
                left += 1
            else:
                if negative:
                    out[pos] = 45
                    pos += 1
                if E >= 0:
                    frac = n - (E + 1)
                    _digits(out, pos, D // _POW10U[frac], E + 1)
                    out[pos + E + 1] = 46
                    _digits(out, pos + E + 2, D % _POW10U[frac], frac)
                    pos += n + 1
                else:
                    out[pos] = 48
                    out[pos + 1] = 46
                    for z in range(-E - 1):
                        out[pos + 2 + z] = 48
                    pos += 1 - E
                    _digits(out, pos, D, n)
                    pos += n
        out[pos] = 10 if i % C == C - 1 else 32
        pos += 1
    return pos, left


def format_shortest_compiled(values: NDArray[np.float64]) -> bytes:
    """The bytes of ``motionrep.io._bvh._format_shortest(values)`` (``(F, C)`` float64, ``C >= 1``)."""
    flat = np.ascontiguousarray(values, dtype=np.float64).ravel()
    C = values.shape[1]
    out = np.empty(flat.shape[0] * _WIDTH, np.uint8)
    fallback = np.empty((min(flat.shape[0], _FALLBACK_CAPACITY), 2), np.int64)
    length, left = _format_kernel(flat, C, out, fallback)
    if left > fallback.shape[0]:  # many values left to repr: again, with room for all of them
        fallback = np.empty((left, 2), np.int64)
        length, left = _format_kernel(flat, C, out, fallback)
    data = out[:length].tobytes()
    if not left:
        return data
    pieces, prev = [], 0
    for at, i in fallback[:left].tolist():
        pieces.append(data[prev:at])
        pieces.append(repr(float(flat[i])).encode("ascii"))
        prev = at
    pieces.append(data[prev:])
    return b"".join(pieces)
