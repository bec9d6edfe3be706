"""BVH frame values as text in one compiled pass (``motionrep._ccore``, C: ``motionrep/_c/shortest.c``): each value
as the shortest decimal that reads back to the very same double.

1. The fewest decimals ``d`` (at most 17) with an integer ``m < 2**53`` such that ``m / 10**d`` is the value's
   magnitude (one correctly rounded division of two exact doubles: what every correct reader, ``float`` and
   ``strtod`` included, returns for that decimal); written in fixed point, ``-`` for a negative value (``-0`` too).
2. Otherwise ``repr``'s digits (17 significant digits at most), computed exactly where that is easy to be sure of:
   a normal value with ``1e-3 <= |x| < 2**52`` whose significand is not a power of two (its rounding interval is
   symmetric).  With ``x = f 2**-s``, ``x 10**k`` is a 128-bit product shifted by ``s``; for ``n`` = 16, 15, ...
   significant digits the nearest decimal ``D 10**-k`` is taken and it reads back as ``x`` iff ``|D 2**(s + 1) - 2 f
   10**k| < 10**k`` (inside the half-ulp interval): the shortest ``n`` that does is repr's length, and the nearest of
   that length is the one repr writes (David Gay's shortest mode).  Written positionally, as repr does for ``1e-4
   <= |x| < 1e16``.
3. Anything else (ties, a boundary hit exactly, a power-of-two significand, other magnitudes) is left to Python's
   ``repr``: its place in the output is recorded and spliced in here.

``tests/test_io_bvh_writer.py`` checks the bytes against ``repr`` and ``float`` on hostile values and real clips.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .._ccore import format_shortest as _format

__all__ = ["format_shortest"]

#: Values left to repr whose place the first pass records; more take a second pass.
_FALLBACK_CAPACITY = 4096
_WIDTH = 26  # the most bytes a value takes (repr of a double: 24) and its separator


def format_shortest(values: NDArray[np.float64]) -> bytes:
    """``values`` ``(F, C)`` (float64, ``C >= 1``) as lines of single-space separated numbers, each the shortest
    decimal (fixed point, at most 17 decimals and 16 significant digits) that reads back to the same double, ``-0``
    for negative zero; a value that needs more digits is written as ``repr`` writes it (17 significant digits,
    exponent form where Python uses it).  Never ``inf`` for a finite value."""
    flat = np.ascontiguousarray(values, dtype=np.float64).ravel()
    C = values.shape[1]
    out = np.empty(flat.shape[0] * _WIDTH, np.uint8)
    fallback = np.empty((min(flat.shape[0], _FALLBACK_CAPACITY), 2), np.int64)
    length, left = _format(flat, C, out, fallback)
    if left > fallback.shape[0]:  # many values left to repr: again, with room for all of them
        fallback = np.empty((left, 2), np.int64)
        length, left = _format(flat, C, out, fallback)
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
