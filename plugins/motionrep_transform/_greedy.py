"""Spending the bound's slack move by move, each move measured exactly (``context.feature_edits``).

After the region search (:mod:`._codec`) each region's worst frame sits at the bound and its other frames below
it. A non-zero detail coefficient may move one step towards zero (``q -> q - sign(q)``): that changes its feature
by ``-sign(q) step phi`` over the frames its synthesis function ``phi`` reaches, and so moves only the joints and
end sites below that feature's joint, in those frames. The context's feature edits
(:class:`motionrep.pipeline.edits.FeatureEdits`) compute exactly that, in C, so every move is tried on the state the
moves before it left and kept when every point it moves stays within the bound in every frame: a greedy search
that knows that a move of the left arm costs nothing in a frame whose worst point is the right foot.

Each pass tries every non-zero detail coefficient once, the moves that save the most bits first (the bits under
the context models of payload version 1, :func:`._slack.reduction_savings`: an estimate that orders the moves);
the next pass starts from the integers the last left, with their savings computed afresh, so a coefficient may move
one step per pass. Moves estimated to save less than ``min_saving`` bits are not tried: every try costs about the
same measurement, and on the clips of large magnitudes (tight bounds) most tries are of such moves.

The synthesis functions are computed once per clip length and level count (:func:`synthesis`): the inverse
wavelet's response to one unit coefficient, one row per array shifted along where its reach stays clear of the
clip's ends (the same values as the inverse wavelet of each row, tested), the other rows computed directly.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Callable

import numpy as np
from numpy.typing import NDArray

from ._wavelet import inverse, level_sizes

__all__ = ["synthesis", "spend_slack_exact", "MIN_SAVING"]

#: The codec's ``min_saving``: moves estimated to save at most this many bits are not tried. Chosen on nine clips
#: that are not CMU ones: 5 passes with it wrote as few bytes as 3 passes without, in 0.6-0.8x the time
#: (``benchmarks/results/rate4.md``).
MIN_SAVING = 0.2

_DIRECT = 32  # arrays of at most this many rows have every row's response computed directly


@lru_cache(maxsize=8)
def synthesis(num_frames: int, levels: int) -> tuple[list[NDArray[np.int64]], list[NDArray[np.int64]],
                                                      list[NDArray[np.int64]], NDArray[np.float64]]:
    """The synthesis function of every coefficient of a clip of ``num_frames`` frames and ``levels`` levels.

    Returns:
        ``(firsts, counts, starts, pool)``: per coefficient array (storage order) and row, the first frame its
        synthesis function reaches, the number of frames, and where its values start in ``pool``: the inverse
        wavelet of a unit coefficient at that row is ``pool[start : start + count]`` on the frames ``first ..``
        and zero elsewhere (rows that are shifts of one another share their values).
    """
    F = num_frames
    sizes = level_sizes(F, levels)
    firsts, counts, starts, pool = [], [], [], []
    used = 0

    def responses(a: int, rows: NDArray[np.int64]) -> NDArray[np.float64]:
        arrays = [np.zeros((s, rows.size)) for s in sizes]
        arrays[a][rows, np.arange(rows.size)] = 1.0
        return inverse(arrays) if levels else arrays[0]

    for a, n in enumerate(sizes):
        span = 1 << (levels if a == 0 else levels - a + 1)  # frames between the centres of two rows
        first = np.zeros(n, np.int64)
        count = np.zeros(n, np.int64)
        start = np.zeros(n, np.int64)
        direct = np.arange(n)
        if n > _DIRECT:
            middle = n // 2
            r = responses(a, np.array([middle]))[:, 0]
            nz = np.flatnonzero(r)
            lo, hi = int(nz[0]), int(nz[-1])
            shift = (np.arange(n) - middle) * span
            # a row whose response stays a row's span away from either end is the middle one's, shifted
            inside = (lo + shift >= span) & (hi + shift <= F - 1 - span)
            first[inside], count[inside], start[inside] = lo + shift[inside], hi - lo + 1, used
            pool.append(r[lo:hi + 1])
            used += hi - lo + 1
            direct = np.flatnonzero(~inside)
        if direct.size:
            R = responses(a, direct)
            for k, row in enumerate(direct):
                nz = np.flatnonzero(R[:, k])
                lo, hi = (int(nz[0]), int(nz[-1])) if nz.size else (0, -1)
                first[row], count[row], start[row] = lo, hi - lo + 1, used
                pool.append(R[lo:hi + 1, k])
                used += hi - lo + 1
        firsts.append(first)
        counts.append(count)
        starts.append(start)
    return firsts, counts, starts, np.concatenate(pool) if pool else np.zeros(0)


def _peaks(rows: int, counts: NDArray[np.int64], starts: NDArray[np.int64], pool: NDArray[np.float64]
           ) -> NDArray[np.int64]:
    """``(rows,)`` the offset of the largest ``|value|`` (the first of equals) of each row's synthesis function
    ``pool[start : start + count]`` (0 for a row of no values)."""
    out = np.zeros(rows, np.int64)
    has = np.flatnonzero(counts > 0)
    if not has.size:
        return out
    segments, where = np.unique(np.stack([starts[has], counts[has]], axis=1), axis=0, return_inverse=True)
    first, count = segments[:, 0], segments[:, 1]
    index = np.repeat(first - np.cumsum(np.concatenate([[0], count[:-1]])), count) + np.arange(count.sum())
    values = np.abs(pool[index])
    ends = np.cumsum(count) - count
    largest = np.maximum.reduceat(values, ends)
    offsets = np.arange(count.sum()) - np.repeat(ends, count)
    # the first offset of each segment whose value is its largest
    at = np.where(values == np.repeat(largest, count), offsets, np.iinfo(np.int64).max)
    out[has] = np.minimum.reduceat(at, ends)[where.reshape(-1)]
    return out


def spend_slack_exact(q: list[NDArray[np.int64]], steps: list[NDArray[np.float64]], levels: int, edits,
                      bound: float,
                      savings_of: Callable[[list[NDArray[np.int64]], NDArray[np.int64]], NDArray[np.float64]],
                      passes: int, min_saving: float = 0.0) -> tuple[list[NDArray[np.int64]], dict]:
    """Move non-zero detail coefficients one step towards zero, each where every point it moves stays within
    ``bound`` (measured by ``edits``, the context's feature edits of the features ``q`` decodes to).

    Args:
        q: the coefficient arrays (storage order) of a state within the bound.
        steps: their steps (same shapes).
        levels: wavelet levels.
        edits: :class:`motionrep.pipeline.edits.FeatureEdits` of the features of ``q``; left holding the features
            of the result.
        bound: the bound.
        savings_of: (integer arrays, their detail arrays concatenated in storage order) -> the bits a move of each
            detail coefficient would save, in that order (positive where it may move; :func:`._slack.detail_savings`).
        passes: rounds over every coefficient, each with the savings of the integers the last left.
        min_saving: moves whose savings are at most this are not tried.

    Returns:
        The new arrays and figures ``{"moved": steps moved, "tried": moves tried}``.
    """
    F = edits.features.shape[0]
    firsts, counts, starts, pool = synthesis(F, levels)
    current = [c.copy() for c in q]
    figures = {"moved": 0, "tried": 0}
    if len(current) < 2 or not current[1].size:
        return current, figures
    D = current[1].shape[1]
    # the detail arrays as views of one flat array (storage order: level, row, column), beside each coefficient's
    # step and synthesis function (first frame, count, start in the pool), so that a pass gathers its moves at once
    flat = np.concatenate([c.reshape(-1) for c in current[1:]])
    ends = np.cumsum([c.size for c in current[1:]])[:-1]
    current[1:] = [part.reshape(c.shape) for part, c in zip(np.split(flat, ends), current[1:])]
    step_of = np.concatenate([s.reshape(-1) for s in steps[1:]])
    # per detail row (the arrays' rows one after the other: coefficient i is in row i // D, every array D wide)
    first_of, count_of, start_of = (np.concatenate(xs[1:]) for xs in (firsts, counts, starts))
    # per coefficient, the frame (from its synthesis function's first) the kernel checks first: where its move last
    # failed (where it most likely fails again), else its synthesis function's largest value (the kernel's own
    # choice, found here once per row instead of at every try; the frame checked first changes no decision)
    peak_of = _peaks(first_of.size, count_of, start_of, pool)
    failed_at = np.repeat(peak_of, D)
    floor = max(min_saving, 0.0)
    for _ in range(passes):
        value = savings_of(current, flat)
        at = np.flatnonzero((flat != 0) & (value > floor))
        if not at.size:
            break
        at = at[np.lexsort((at, -value[at]))]  # the most bits first; ties in storage order
        sign = np.sign(flat[at])
        leads = failed_at[at]
        # each move's deltas: its synthesis function's values times -sign(q) step, formed by the kernel
        row = at // D
        accepted = edits.apply(at % D, first_of[row], count_of[row], pool, bound, leads=leads, starts=start_of[row],
                               scales=-sign * step_of[at])
        figures["tried"] += int(at.size)
        figures["moved"] += int(accepted.sum())
        if not accepted.any():
            break
        failed_at[at] = np.where(accepted, peak_of[row], leads)
        flat[at[accepted]] -= sign[accepted]
    return current, figures
