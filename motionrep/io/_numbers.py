"""Bulk parsing of whitespace-separated decimal numbers with numpy (the BVH MOTION block).

The fast path works on the raw bytes with whole-array operations: it finds the tokens, right-aligns them in a
``(tokens, width)`` byte matrix, checks that every token is a plain decimal (``-12.345``, ``7``, ``+.5``), and
computes each value as an exact integer mantissa divided by an exact power of ten.  Mantissas below 2**53
and at most 22 decimals make that division correctly rounded (Clinger's fast path), so the result is
bit-identical to ``float(token)``.  Anything else (exponents, ``nan``, junk, very long digit strings) falls
back to ``numpy.loadtxt``, which is exact for every input; the caller then reports errors with line numbers.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["TokenTable", "scan_tokens", "parse_decimal_tokens"]

_MAX_WIDTH = 24  # longer tokens take the slow path
_POW10 = 10.0 ** np.arange(23)


class TokenTable:
    """Where the whitespace-separated tokens of a byte block are.

    Attributes:
        starts, ends: ``(T,)`` byte offsets of each token (``ends`` exclusive).
        newlines: byte offsets of the block's newline characters.
        line_counts: ``(L,)`` number of tokens on each line of the block.
    """

    __slots__ = ("starts", "ends", "newlines", "line_counts")

    def __init__(self, starts: NDArray, ends: NDArray, newlines: NDArray):
        self.starts, self.ends, self.newlines = starts, ends, newlines
        before = np.searchsorted(starts, newlines)  # tokens starting before each newline
        self.line_counts = np.diff(np.concatenate(([0], before, [starts.shape[0]])))

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
    ws = u <= 32
    edges = np.flatnonzero(ws[1:] != ws[:-1]) + 1  # positions where whitespace-ness changes
    if not ws[0]:
        edges = np.concatenate(([0], edges))
    if not ws[-1]:
        edges = np.concatenate((edges, [n]))
    return TokenTable(edges[0::2], edges[1::2], newlines)


def parse_decimal_tokens(u: NDArray[np.uint8], tokens: TokenTable) -> NDArray[np.float64] | None:
    """Values of the tokens if every one is a plain decimal number, else ``None`` (use the slow path).

    Tokens are grouped by length; each group is a ``(n, length)`` byte matrix (rows of a sliding window over
    the block), and within it by the column of the decimal point, so each sub-group is one exact
    matrix-vector product of its digits with powers of ten.
    """
    starts, ends = tokens.starts, tokens.ends
    T = starts.shape[0]
    values = np.empty(T)
    if T == 0:
        return values
    lengths = ends - starts
    if int(lengths.max()) > _MAX_WIDTH:
        return None
    present = np.flatnonzero(np.bincount(lengths))
    for L in present.tolist():
        rows = None if present.shape[0] == 1 else np.flatnonzero(lengths == L)
        st = starts if rows is None else starts[rows]
        m = np.lib.stride_tricks.sliding_window_view(u, L)[st]  # (n, L) token bytes
        d = m - np.uint8(48)  # digits 0..9; '-' 253, '+' 251, '.' 254, anything else is out of place
        negative = m[:, 0] == 45
        signed = negative | (m[:, 0] == 43)
        if signed.any():
            d[signed, 0] = 0
        is_dot = d == 254
        has_dot = is_dot.any(axis=1)
        dot_col = np.where(has_dot, np.argmax(is_dot, axis=1), L)
        d[is_dot] = 0
        if not np.all(d < 10):  # not a plain decimal (junk, exponent, nan, two dots or a sign inside)
            return None
        ndigits = L - signed - has_dot
        if np.any(ndigits == 0) or np.any(ndigits > 15):
            return None
        vals = np.empty(d.shape[0])
        r = np.arange(L - 1, -1, -1)  # distance of each column from the token's end
        for col in np.flatnonzero(np.bincount(dot_col)).tolist():
            sel = dot_col == col
            decimals = L - 1 - col if col < L else 0
            power = np.where(np.arange(L) > col, r, r - 1) if col < L else r
            weights = np.where(power >= 0, 10.0 ** np.maximum(power, 0), 0.0)
            if col < L:
                weights[col] = 0.0
            sub = d if sel.all() else d[sel]
            mantissa = sub.astype(np.float64) @ weights  # exact: integers below 2**53
            if sel.all():
                vals = mantissa / _POW10[decimals]
            else:
                vals[sel] = mantissa / _POW10[decimals]
        vals[negative] *= -1.0
        if rows is None:
            values[:] = vals
        else:
            values[rows] = vals
    return values
