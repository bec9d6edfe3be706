"""Parsing whitespace-separated numbers (the BVH MOTION block) in one compiled pass (``motionrep._ccore``, C), or
with numpy and Python's ``float`` while a process has not paid numba's start-up (:func:`use_compiled`).

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
line) and reports where it is wrong; a row beyond the expected count is counted, not parsed.

The numpy path needs no numba, whose import and cached machine code cost a fresh process more than reading a
typical clip without it (:data:`NUMPY_PATH_BUDGET` gives the figures).  A BVH frame block of plain decimal numbers
in the declared layout (what exporters write) is read by
:func:`motionrep.io._plain_rows.parse_plain_rows`: whole-array integer arithmetic,
exact by construction, and None on any doubt.  Everything else goes to :func:`_scan_numpy`, which finds the same
tokens as the compiled loop with ``bytes.split`` and converts them with ``float`` itself: the same values, layout
findings and errors (``tests/test_bvh_paths.py`` runs all of them on the same text).
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


#: Bytes of BVH text a process reads through the numpy path (:func:`use_compiled`) before it switches to the
#: compiled loops for good: about the break-even measured by ``benchmarks/io.py`` (2026-12-02, 46 real files, the
#: shared 2-core AMD EPYC machine, load 3.2): a fresh process pays 1.55 s to import numba and load the cached
#: machine code of the reader's kernels (1.0-2.0 s at loads 3-6) before it reads a byte; the numpy path (plain
#: frame blocks parsed by
#: :func:`motionrep.io._plain_rows.parse_plain_rows`) then reads 21.8 MB/s, the compiled one 57.9 MB/s, i.e. 0.029 s
#: more per MB, so numba's start-up is won back after ~54 MB read in one process (35-68 MB over those start-up
#: times; 18 MB before the plain-row parser, when the budget was 16 MB).  Below that the numpy path is the faster (a
#: process reading one typical clip: 0.05-3 MB); a process that reads more (a batch) pays numba's start-up once and
#: then reads at the compiled speed: at worst about twice the best choice in hindsight (the rent-or-buy rule).
NUMPY_PATH_BUDGET = 48_000_000
_numpy_path_bytes = 0


def use_compiled(size: int) -> bool:
    """Whether to read ``size`` bytes of numbers with the compiled loops (True) or the numpy path (False).

    The compiled loops once numba is imported in this process (its start-up is paid) or once this process has read
    :data:`NUMPY_PATH_BUDGET` bytes the slow way; the numpy path before that.  Both give identical values and
    errors (tested), so the choice only changes the time.
    """
    global _numpy_path_bytes
    from ..jit import numba_loaded

    if numba_loaded() or _numpy_path_bytes + size > NUMPY_PATH_BUDGET:
        return True
    _numpy_path_bytes += size
    return False


def scan_block(u: NDArray[np.uint8], width: int = 0, rows_max: int = 0, by_line: bool = True,
               compiled: bool | None = None) -> BlockScan:
    """Parse the whitespace-separated numbers of the bytes ``u``: rows of ``width`` values, one per non-blank
    line, at most ``rows_max`` of them stored (``by_line``), or every token in order.

    ``compiled``: run the compiled loop (True) or the numpy path (False); None chooses by :func:`use_compiled`.
    """
    if compiled is None:
        compiled = use_compiled(u.shape[0])
    if not compiled:
        return _scan_numpy(u.tobytes(), width, rows_max, by_line)
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


# every byte the compiled loop takes as a separator (<= 32) but the line feed, as a space: then ``bytes.split()``
# finds exactly its tokens (it would not split at bytes 0-8 or 14-31 itself)
_TO_SPACE = bytes.maketrans(bytes(b for b in range(33) if b != 10), b" " * 32)


_BATCH = 1 << 16  # tokens converted at a time: only one batch's token objects are alive, not the whole file's


def _scan_numpy(data: bytes, width: int, rows_max: int, by_line: bool) -> BlockScan:
    """:func:`scan_block` without numba: the same tokens, layout checks, values and errors (tested side by side).

    Tokens come from ``bytes.split`` (line by line when ``by_line``) and are converted by Python's ``float``
    (the compiled loop's values are bit-identical to it), a batch of lines at a time, each batch at once when the
    text is ASCII without ``_``.
    """
    text = data.translate(_TO_SPACE)
    clean = data.isascii() and b"_" not in data
    if not by_line:
        tokens = text.split()
        values, index = _floats(tokens, clean)
        whole = [(0, len(tokens), -1)]  # lines found on demand (only for an error)
        finite = np.isfinite(values[:index])
        return BlockScan(values, 0, -1, 0, -1, -1, -1,
                         None if index is None else _located(index, tokens, whole, text, False),
                         None if finite.all() else _located(int(np.argmin(finite)), tokens, whole, text, False))
    values = np.empty(rows_max * width)
    pending: list[bytes] = []
    chunks: list[tuple[int, int, int]] = []  # (first slot, tokens, line) of each line's stored tokens in `pending`
    found: dict[str, tuple[int, int, str]] = {}  # "bad", "nonfinite": as the compiled loop reports them

    def convert() -> None:
        converted, index = _floats(pending, clean)
        first, last = chunks[0], chunks[-1]
        if last[0] + last[1] - first[0] == len(pending):  # no short line: one run of slots
            values[first[0]:first[0] + len(pending)] = converted
        else:
            k = 0
            for slot, n, _ in chunks:
                values[slot:slot + n] = converted[k:k + n]
                k += n
        finite = np.isfinite(converted[:index])  # the first non-finite value before the first non-number
        if "nonfinite" not in found and not finite.all():
            found["nonfinite"] = _located(int(np.argmin(finite)), pending, chunks, text, True)
        if index is not None:
            found["bad"] = _located(index, pending, chunks, text, True)
        pending.clear()
        chunks.clear()

    rows = wrong_count = 0
    first_wrong = last_data = first_data = extra = -1
    for line_no, line in enumerate(text.split(b"\n")):
        words = line.split()
        if not words:
            continue
        n = len(words)
        if n != width and first_wrong < 0:
            first_wrong, wrong_count = line_no, n
        if first_data < 0:
            first_data = line_no
        last_data = line_no
        if rows == rows_max:
            extra = line_no
        if rows < rows_max and "bad" not in found:  # after a non-number the compiled loop stops converting too
            stored = words if n <= width else words[:width]
            if stored:
                chunks.append((rows * width, len(stored), line_no))
                pending.extend(stored)
                if len(pending) >= _BATCH:
                    convert()
        rows += 1
    if pending:
        convert()
    return BlockScan(values, rows, first_wrong, wrong_count, last_data, first_data, extra, found.get("bad"),
                     found.get("nonfinite"))


def _floats(tokens: list[bytes], clean: bool) -> tuple[NDArray[np.float64], int | None]:
    """``float`` of each token, and the index of the first that is not a number (None if all are); values from
    that index on are NaN.  ``clean``: the tokens are ASCII without ``_`` (``float`` alone decides)."""
    n = len(tokens)
    if clean:
        try:
            return np.fromiter(map(float, tokens), np.float64, n), None
        except ValueError:
            pass
    out = np.full(n, np.nan)
    for k, token in enumerate(tokens):
        v = _python_float(token)
        if v is None:
            return out, k
        out[k] = v
    return out, None


def _located(index: int, tokens: list[bytes], chunks: list[tuple[int, int, int]], text: bytes,
             by_line: bool) -> tuple[int, int, str]:
    """``(slot, line, text)`` of stored token ``index`` (as the compiled loop reports it)."""
    label = tokens[index].decode("utf-8", "replace")[:40]
    if not by_line:
        seen = 0
        for line_no, line in enumerate(text.split(b"\n")):
            seen += len(line.split())
            if seen > index:
                return index, line_no, label
    k = 0
    for slot, n, line_no in chunks:
        if index < k + n:
            return slot + index - k, line_no, label
        k += n
    raise AssertionError("token index out of range")  # pragma: no cover


def parse_numbers(data: bytes | NDArray[np.uint8], compiled: bool | None = None
                  ) -> tuple[NDArray[np.float64], int | None]:
    """Values of all whitespace-separated tokens of ``data``, bit-identical to ``float(token)``, and the index of
    the first token that is not a number (None if all are; ``nan`` and ``inf`` are numbers here).  ``compiled``
    as for :func:`scan_block`."""
    u = np.frombuffer(data, np.uint8) if isinstance(data, (bytes, bytearray, memoryview)) else data
    scan = scan_block(u, by_line=False, compiled=compiled)
    return scan.values, None if scan.bad is None else scan.bad[0]


# every byte but the control bytes a text file may not hold (bytes 0-8 and 14-31)
_NOT_CONTROL = bytes(range(9, 14)) + bytes(range(32, 256))


def first_control_byte(data: bytes) -> int:
    """Offset of the first control byte of ``data`` other than tab, LF, VT, FF, CR (bytes 9..13), or -1.

    ``bytes.translate`` deletes every other byte in one C pass (hundreds of MB/s, no numba): what is left are
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
