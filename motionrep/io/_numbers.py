"""Parsing whitespace-separated numbers (the BVH MOTION block) in one compiled pass (``motionrep._ccore``, C).

Every value is bit-identical to ``float(token)``:

1. One loop over the bytes finds the tokens (runs of bytes > 32), counts them per line and parses each where it
   stands: an optional sign, digits with at most one '.', an optional exponent (``e``/``E``, optional sign,
   digits).  The digits form an integer mantissa; while it is below 2**53 and the power of ten it must be
   scaled by is at most 22 in size, both are exact doubles and one correctly rounded multiplication or
   division gives the correctly rounded value of the decimal string (Clinger's fast path): the same answer as
   ``float``.
2. Whatever is left (more than 15 or 16 significant digits, powers of ten beyond 22, ``nan``, ``inf``, junk) is
   converted one token at a time with Python's ``float`` (ASCII only, no ``_``); a token it rejects is reported
   with its line so the caller can name it.

For the BVH block the loop also checks the layout as it goes (rows of ``channels`` values, one per non-blank
line) and reports where it is wrong; a row beyond the expected count is counted, not parsed.  The loop is C
(``motionrep/_c/numbers.c``), compiled at install time: nothing to load or compile when a process starts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .._ccore import scan as _scan

__all__ = ["BlockScan", "scan_block", "parse_numbers", "first_control_byte"]

#: Left-over tokens whose place is recorded in the first pass; more take a second pass.
_FALLBACK_CAPACITY = 4096
# info fields written by the kernel (motionrep/_c/numbers.c)
_ROWS, _FIRST_WRONG, _WRONG_COUNT, _LAST_DATA, _EXTRA, _FIRST_DATA, _FALLBACKS, _TOKENS = range(8)


@dataclass(frozen=True)
class BlockScan:
    """What :func:`scan_block` found.

    Attributes:
        values: ``(rows_max * width,)`` float64 (by line) or ``(tokens,)`` values, bit-identical to ``float``.
        rows: number of lines with tokens.
        first_wrong_line, wrong_count: the first line (0-based) whose token count is not ``width``, and its
            count (-1, 0 if none).
        last_data_line, first_data_line: 0-based lines of the last and first lines with tokens (-1 if none).
        extra_line: 0-based line of row ``rows_max`` (the first one too many; -1 if none).
        bad: ``(slot, line, text)`` of the first token that is not a number, or None.
        nonfinite: ``(slot, line, text)`` of the first ``nan``/``inf`` value, or None.
    """

    values: NDArray[np.float64]
    rows: int
    first_wrong_line: int
    wrong_count: int
    last_data_line: int
    first_data_line: int
    extra_line: int
    bad: tuple[int, int, str] | None
    nonfinite: tuple[int, int, str] | None


def scan_block(u: NDArray[np.uint8], width: int = 0, rows_max: int = 0, by_line: bool = True) -> BlockScan:
    """Parse the whitespace-separated numbers of the bytes ``u``: rows of ``width`` values, one per non-blank
    line, at most ``rows_max`` of them stored (``by_line``), or every token in order.
    """
    size = rows_max * width if by_line else u.shape[0] // 2 + 1  # tokens are at least one byte and a separator
    values = np.empty(size)
    info = np.zeros(8, np.int64)
    fallback = np.empty((_FALLBACK_CAPACITY, 4), np.int64)
    _scan(u, width, rows_max, by_line, values, fallback, info)
    if info[_FALLBACKS] > _FALLBACK_CAPACITY:  # many left-over tokens: again, with room for all of them
        fallback = np.empty((int(info[_FALLBACKS]), 4), np.int64)
        _scan(u, width, rows_max, by_line, values, fallback, info)
    if not by_line:
        values = values[:int(info[_TOKENS])]
    bad = nonfinite = None
    raw = u.data
    for slot, a, b, line in fallback[:int(info[_FALLBACKS])].tolist():
        text = bytes(raw[a:b])
        v = _python_float(text)
        if v is None:
            bad = (slot, line, text.decode("utf-8", "replace")[:40])
            break
        values[slot] = v
        if nonfinite is None and not np.isfinite(v):
            nonfinite = (slot, line, text.decode("utf-8", "replace")[:40])
    return BlockScan(values, int(info[_ROWS]), int(info[_FIRST_WRONG]), int(info[_WRONG_COUNT]),
                     int(info[_LAST_DATA]), int(info[_FIRST_DATA]), int(info[_EXTRA]), bad, nonfinite)


def parse_numbers(data: bytes | NDArray[np.uint8]) -> tuple[NDArray[np.float64], int | None]:
    """Values of all whitespace-separated tokens of ``data``, bit-identical to ``float(token)``, and the index of
    the first token that is not a number (None if all are; ``nan`` and ``inf`` are numbers here)."""
    u = np.frombuffer(data, np.uint8) if isinstance(data, (bytes, bytearray, memoryview)) else data
    scan = scan_block(u, by_line=False)
    return scan.values, None if scan.bad is None else scan.bad[0]


# every byte but the control bytes a text file may not hold (bytes 0-8 and 14-31)
_NOT_CONTROL = bytes(range(9, 14)) + bytes(range(32, 256))


def first_control_byte(data: bytes) -> int:
    """Offset of the first control byte of ``data`` other than tab, LF, VT, FF, CR (bytes 9..13), or -1.

    ``bytes.translate`` deletes every other byte in one C pass (hundreds of MB/s): what is left are
    the control bytes in file order, and the first of them is found with ``bytes.find``."""
    rest = data.translate(None, _NOT_CONTROL)
    return data.find(rest[:1]) if rest else -1


def _python_float(token: bytes) -> float | None:
    """``float(token)`` for the tokens the fast path leaves; None if it is not a number."""
    if b"_" in token or not token.isascii():  # float() would take 1_000 and non-ASCII digits
        return None
    try:
        return float(token)
    except ValueError:
        return None
