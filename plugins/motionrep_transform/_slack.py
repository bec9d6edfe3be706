"""Spending the bound's slack by thresholds: smaller integers where the frames have room under the bound, for a
context without feature edits (with them, :mod:`._greedy` measures every move exactly and saves more). The savings
estimate (:func:`reduction_savings`) orders the moves of both.

The region search (:mod:`._codec`) gives every region the coarsest step whose frames all stay within the bound,
so the worst frame of each region sits at the bound, but the other frames do not: on the CMU clips the median
frame is at about half of it. This module spends that room. It only chooses other integers for the same steps
(each non-zero detail coefficient may move one step towards zero per round, two rounds), so the payload format
does not change and any decoder reads the result.

Which coefficients move is decided by thresholds, searched like the region exponents:

1. every non-zero detail coefficient gets a priority: the bits its move would save (the ideal code length under
   the fitted context models of payload version 1, :mod:`._stream`, :func:`reduction_savings`: an estimate that
   only orders the moves; version 2's adaptive coder writes them in fewer bits still) per unit of error the move
   can add (its step times the largest sensitivity of its feature over the frames it reaches);
2. the clip is cut into short stretches (``stretch`` frames); the features are cut into ``blocks`` contiguous
   groups;
3. for one feature group at a time, every stretch bisects, in lockstep, a threshold index into a fixed ladder of
   thresholds: a coefficient moves when its priority is at least the threshold of its stretch (the most cautious
   threshold over the stretches it reaches); each step of the bisection reconstructs the group's columns and
   measures every frame once (``frame_errors``); a stretch passes when its frames are within the bound;
4. stretches pushed over the bound by a neighbour are then settled (lowered until all pass; if that does not
   converge, the group's integers stay as they were), so every group ends on a measured state within the bound;
5. a second round does it again with priorities computed from the state the first round left, in half as many
   groups.

Searching the features in groups, one after the other, measures more and gains more than one search of every
feature at once; groups cut at the limbs (where the sensitivity jumps up) gained less than equal contiguous
groups, and a second round with fresh priorities more than more groups (``benchmarks/results/rate3.md``).

Determinism: numpy only, no BLAS; comparisons of float priorities computed in a fixed order, so the same input
gives the same integers on the same machine (and, but for a tie within an ulp, on any).
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from numpy.typing import NDArray

from motionrep.plugin.coding import NUM_TOKENS, Model, _fit_tables, _probabilities, _tokenize

from ._stream import _CAP, MAX_ZERO, _approx_steps, _context_ids, _passes

__all__ = ["reduction_savings", "detail_savings", "frame_sensitivity", "sliding_max", "spend_slack", "LADDER"]

#: Thresholds of the ladder: index ``i`` >= 1 is ``top * 2 ** (-(i - 1) / 2)`` (index 0: nothing moves).
LADDER = 15
_TOKENS_DIRECT = 16  # magnitudes below this are their own token (motionrep.plugin.coding, specs/coding.md)
_SETTLE = 8  # rounds of lowering stretches over the bound before a group's moves are given up


def _code_lengths(model: Model, magnitudes: NDArray[np.int64]) -> NDArray[np.float64]:
    """Ideal code length in bits of integers of these magnitudes under ``model`` (token, sign and raw bits), as
    :meth:`Model.cost` counts them (a token's probability given a non-zero value floored at ``2 ** -24``)."""
    a = np.asarray(magnitudes, dtype=np.int64)
    return _code_length_of(model.probabilities[None], np.zeros(a.size, np.int64), a.reshape(-1)).reshape(a.shape)


def _fit_each(ctx: NDArray[np.int64], values: NDArray[np.int64], wanted: NDArray[np.int64] | None = None
              ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The model :func:`._stream._fit` gives the values of each context, ``(zero, decay)`` indices per context
    number ``0 .. ctx.max()`` (contexts without values: ``(MAX_ZERO, 0)``), all contexts at once: the same
    costs as :func:`motionrep.plugin.coding.fit_model`, each a sum of products formed and added elementwise
    (no BLAS, whose kernels differ between CPUs), the first index of the smallest kept.  ``wanted``: only these
    context numbers are fitted (each as it would be among all: a context's sums are its own), the others get
    ``(MAX_ZERO, 0)``."""
    n = int(ctx.max()) + 1
    tokens, _, _ = _tokenize(values)
    counts = np.bincount(ctx * NUM_TOKENS + tokens, minlength=n * NUM_TOKENS).reshape(n, NUM_TOKENS)
    return _fit_counts(counts, wanted)


def _fit_counts(counts: NDArray[np.int64], wanted: NDArray[np.int64] | None = None
                ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """:func:`_fit_each` from the ``(n, NUM_TOKENS)`` token counts of each context."""
    n = counts.shape[0]
    rows = np.arange(n) if wanted is None else np.asarray(wanted, np.int64)
    counts = counts[rows].astype(np.float64)
    nonzero = counts.sum(axis=1) - counts[:, 0]  # token 0 is the value 0 (whole numbers: exact)
    zero_bits, tail_bits = _fit_tables()
    zb = zero_bits[:MAX_ZERO + 1]
    zero = np.full(n, MAX_ZERO, np.int64)
    decay = np.zeros(n, np.int64)
    z = np.argmin(zb[None, :, 0] * counts[:, 0, None] + zb[None, :, 1] * nonzero[:, None], axis=1)
    d = np.argmin(_tail_costs(counts[:, 1:], tail_bits), axis=1) if rows.size else np.zeros(0, np.int64)
    d[nonzero == 0] = 0
    z[counts.sum(axis=1) == 0] = MAX_ZERO  # fit_model of no values
    zero[rows], decay[rows] = z, d
    return zero, decay


def _tail_costs(counts: NDArray[np.float64], tail_bits: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(n, 256)``: for each row of ``(n, NUM_TOKENS - 1)`` non-zero token counts, the bits of its tokens under
    each decay index, ``(tail_bits[None] * counts[:, None]).sum(axis=2)``, the same float64 bits: only the tokens
    up to the last counted one, rounded up to eight, are multiplied and added (numpy adds a contiguous axis in
    eight interleaved partial sums, then the rest in order: the products left out, of zero counts, only ever
    added an exact zero)."""
    used = np.flatnonzero(counts.any(axis=0))
    full = counts.shape[1]
    width = full if not used.size else min(full, max(8, -(-(int(used[-1]) + 1) // 8) * 8))
    tail, counts = tail_bits[None, :, :width], counts[:, None, :width]
    # eight rows at a time: their (8, 256, width) products stay in the cache (all at once they do not)
    return np.concatenate([(tail * counts[k:k + 8]).sum(axis=2) for k in range(0, counts.shape[0], 8)]
                          + [np.zeros((0, tail_bits.shape[0]))])


def _code_length_of(table: NDArray[np.float64], rows: NDArray[np.int64], magnitudes: NDArray[np.int64]
                    ) -> NDArray[np.float64]:
    """:func:`_code_lengths` elementwise, magnitude ``i`` under the model whose probabilities are
    ``table[rows[i]]`` (``table`` ``(n, NUM_TOKENS)``): the same operations on the same numbers."""
    z = table[rows, 0]
    a = np.asarray(magnitudes, dtype=np.int64)
    big = a >= _TOKENS_DIRECT
    e = np.zeros(a.shape, np.int64)
    if big.any():
        e[big] = np.frexp(a[big].astype(np.float64))[1] - 1
    token = np.where(big, _TOKENS_DIRECT + e - 4, a)
    tail = table[rows, np.maximum(token, 1)] / (1.0 - z)
    nonzero = -np.log2(1.0 - z) - np.log2(np.maximum(tail, 2.0 ** -24)) + 1 + e
    return np.where(a > 0, nonzero, -np.log2(z))


def reduction_savings(coefficients: list[NDArray[np.int64]], levels: int) -> list[NDArray[np.float64]]:
    """Per coefficient array ``(n, D)``: the bits saved by moving each non-zero detail coefficient one step
    towards zero, under the context models the stream would fit to ``coefficients`` (0 for zeros and for the
    approximation, which is not moved). The contexts of the neighbours are taken as they are (a zero more
    usually makes them cheaper too, so the real saving is somewhat larger). Every context's model is fitted at
    once (:func:`_fit_each`); the token counts of the zeros (most coefficients) are counted without their
    tokens (the same counts). The detail arrays' savings are views of :func:`detail_savings`."""
    details = coefficients[1:levels + 1] if levels else []
    sizes = [c.size for c in details]
    flat = detail_savings(coefficients, levels)
    out = [np.zeros(coefficients[0].shape)] + [part.reshape(c.shape)
                                                for part, c in zip(np.split(flat, np.cumsum(sizes)[:-1]), details)]
    return out + [np.zeros(c.shape) for c in coefficients[levels + 1:]]


def detail_savings(coefficients: list[NDArray[np.int64]], levels: int,
                   values: NDArray[np.int64] | None = None) -> NDArray[np.float64]:
    """:func:`reduction_savings` of the detail arrays ``coefficients[1:levels + 1]``, one after the other in
    storage order (level, row, column), as one ``(total,)`` array. ``values``: those arrays so concatenated, if
    the caller holds them (not copied again)."""
    details = coefficients[1:levels + 1] if levels else []
    total = sum(c.size for c in details)
    flat = np.zeros(total)
    if not total:
        return flat
    val = np.concatenate([c.reshape(-1) for c in details]) if values is None else values
    moved = np.flatnonzero(val)
    if not moved.size:
        return flat
    # the contexts only see the parents' sums capped at _CAP (sums of magnitudes, each >= 0): the magnitudes capped
    # at _CAP give the same capped sums, in int16 (a quarter of the memory to go through)
    mags = [np.minimum(_approx_steps(coefficients[0]), _CAP).astype(np.int16)]
    mags += [np.abs(np.clip(c, -_CAP, _CAP).astype(np.int16)) for c in details]
    ctx = np.empty(total, np.int64)
    _context_ids(mags, levels, ctx)
    n = int(ctx.max()) + 1
    rows = ctx[moved]
    v = val[moved]
    tokens, _, _ = _tokenize(v)
    counts = np.bincount(rows * NUM_TOKENS + tokens, minlength=n * NUM_TOKENS).reshape(n, NUM_TOKENS)
    moving = counts.sum(axis=1)  # per context, its non-zero coefficients (tokens >= 1)
    counts[:, 0] = np.bincount(ctx, minlength=n) - moving  # token 0: the zeros, and only they
    used = np.flatnonzero(moving)  # the contexts of coefficients that may move, increasing (np.unique(rows))
    zero, decay = _fit_counts(counts, used)  # only the contexts of coefficients that may move
    table = np.zeros((zero.size, NUM_TOKENS))
    table[used] = np.stack([_probabilities(int(zero[k]), int(decay[k])) for k in used])
    mag = np.abs(v)
    flat[moved] = _code_length_of(table, rows, mag) - _code_length_of(table, rows, mag - 1)
    return flat


def frame_sensitivity(samples: NDArray[np.float64], num_frames: int) -> NDArray[np.float64]:
    """``(F, D)`` sensitivity of every frame from ``(m, D)`` measured at ``m`` frames spread evenly over the
    clip (``context.feature_sensitivity``), linearly interpolated between them."""
    s = np.asarray(samples, dtype=np.float64)
    m = s.shape[0]
    if m == 1 or num_frames == 1:
        return np.repeat(s.max(axis=0, keepdims=True), num_frames, axis=0)
    pos = np.arange(num_frames) * ((m - 1) / (num_frames - 1))
    i = np.minimum(np.floor(pos).astype(np.int64), m - 2)
    a = (pos - i)[:, None]
    return s[i] * (1.0 - a) + s[i + 1] * a


def sliding_max(values: NDArray[np.float64], span: int) -> NDArray[np.float64]:
    """``out[i] = max(values[max(0, i - span) : i + span + 1])`` along the first axis (ends extended)."""
    from ._codec import window_minimum

    return -window_minimum(-np.asarray(values), span)


class _Block:
    """The movable coefficients of one feature group: per detail array, their rows, columns (within the
    group), priorities and signs."""

    def __init__(self, columns: NDArray[np.int64], q: list[NDArray[np.int64]],
                 priority: list[NDArray[np.float64]]):
        self.columns = columns
        self.q = [c[:, columns].copy() for c in q]
        self.moves = []
        for a in range(1, len(q)):
            p = priority[a][:, columns]
            rows, cols = np.nonzero(np.isfinite(p))
            self.moves.append((a, rows, cols, p[rows, cols], np.sign(self.q[a][rows, cols])))

    def integers(self, index_of: Callable[[int, NDArray[np.int64]], NDArray[np.int64]],
                 thresholds: NDArray[np.float64]) -> list[NDArray[np.int64]]:
        """The group's coefficient arrays with every coefficient moved whose priority reaches its threshold."""
        out = [c.copy() for c in self.q]
        for a, rows, cols, p, sign in self.moves:
            if rows.size:
                move = p >= thresholds[index_of(a, rows)]
                out[a][rows[move], cols[move]] -= sign[move]
        return out


def spend_slack(q: list[NDArray[np.int64]], steps: list[NDArray[np.float64]], levels: int,
                sensitivity: NDArray[np.float64], frame_errors: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                bound: float, synthesise: Callable[[list[NDArray[np.float64]]], NDArray[np.float64]],
                coefficient_frames: list[NDArray[np.int64]], *, blocks: int = 4, stretch: int = 8
                ) -> tuple[list[NDArray[np.int64]], dict]:
    """Move coefficients towards zero where the frames have room under ``bound``.

    Args:
        q: the coefficient arrays (storage order) of a state whose every frame is within the bound.
        steps: their steps (same shapes).
        levels: wavelet levels.
        sensitivity: ``(F, D)`` position units per feature unit at every frame (:func:`frame_sensitivity`).
        frame_errors: ``(F, D)`` features -> ``(F,)`` error of each frame (``context.frame_errors``).
        bound: the bound, in position units.
        synthesise: dequantised coefficient arrays (any number of columns) -> features (the inverse wavelet the
            decoder runs, column by column, so a group's columns come out with the same bits as in the whole).
        coefficient_frames: the centre frame of each coefficient row, per array.
        blocks: feature groups of the first round (a second round, with the priorities of the state the first
            left, searches ``blocks // 2`` groups).
        stretch: frames per stretch of the thresholds.

    Returns:
        The new arrays (the last state measured, within the bound) and figures ``{"evaluations", "moved"}``.
    """
    from ._codec import window_minimum

    F, D = sensitivity.shape
    spans = [levels] + list(range(levels, 0, -1))
    reach = [3 << j for j in spans]
    # the largest sensitivity of each coefficient's feature over the frames it reaches
    worst = [np.zeros(0)] + [sliding_max(sensitivity, reach[a])[coefficient_frames[a]] for a in range(1, len(q))]
    R = -(-F // stretch)
    stretch_of = [np.minimum(f // stretch, R - 1) for f in coefficient_frames]
    # a coefficient takes the most cautious threshold of the stretches within half its level's reach
    span_of = [int(math.ceil(r / 2 / stretch)) for r in reach]
    figures = {"evaluations": 0, "moved": 0}
    current = [c.copy() for c in q]
    features = synthesise([c * s for c, s in zip(current, steps)])

    def search(columns: NDArray[np.int64], priority: list[NDArray[np.float64]],
               thresholds: NDArray[np.float64]) -> None:
        """One feature group: bisect its stretch indices, settle, keep the state if it settled."""
        nonlocal features
        block = _Block(columns, current, priority)
        if not any(m[1].size for m in block.moves):
            return
        block_steps = [s[:, columns] for s in steps]

        def stretch_errors(index: NDArray[np.int64]) -> tuple[NDArray[np.float64], list, NDArray[np.float64]]:
            minima = [window_minimum(index, span)[rows] for span, rows in zip(span_of, stretch_of)]
            ints = block.integers(lambda a, rows: minima[a][rows], thresholds)
            trial = features.copy()
            trial[:, columns] = synthesise([c * s for c, s in zip(ints, block_steps)])
            figures["evaluations"] += 1
            e = np.asarray(frame_errors(trial), dtype=np.float64)
            padded = np.zeros(R * stretch)
            padded[:F] = e
            return padded.reshape(R, stretch).max(axis=1), ints, trial

        index = _bisect_each(lambda i: stretch_errors(i)[0] <= bound, R, LADDER)
        fails = np.zeros(R, np.int64)
        for _ in range(_SETTLE):
            e, ints, trial = stretch_errors(index)
            bad = e > bound
            if not bad.any():
                for a in range(len(current)):
                    current[a][:, columns] = ints[a]
                features = trial
                return
            fails += bad
            # over the bound: two rungs lower; a second time: nothing moves there, and the neighbours go two
            # rungs lower (a stretch is mostly pushed over by coarse moves its neighbours allowed)
            index[bad] = np.where(fails[bad] > 1, 0, np.maximum(index[bad] - 2, 0))
            stuck = bad & (fails > 1)
            index[1:][stuck[:-1]] = np.maximum(index[1:][stuck[:-1]] - 2, 0)
            index[:-1][stuck[1:]] = np.maximum(index[:-1][stuck[1:]] - 2, 0)
        # not settled: the group's integers stay as they were (a state measured within the bound)

    for count in [c for c in (blocks, blocks // 2) if c > 0]:
        savings = reduction_savings(current, levels)
        priority = [np.full(c.shape, -np.inf) for c in current]
        for a in range(1, len(current)):
            impact = steps[a] * np.maximum(worst[a], 1e-300)
            priority[a] = np.where((current[a] != 0) & (savings[a] > 0), savings[a] / impact, -np.inf)
        finite = [p[np.isfinite(p)] for p in priority]
        if not any(f.size for f in finite):
            break
        top = max(float(f.max()) for f in finite if f.size)
        thresholds = np.concatenate([[np.inf], top * np.power(2.0, -np.arange(LADDER) / 2.0)])
        for columns in np.array_split(np.arange(D), max(1, min(count, D))):
            if columns.size:
                search(columns, priority, thresholds)
    figures["moved"] = int(sum(int(np.abs(a - b).sum()) for a, b in zip(q, current)))
    return current, figures


def _bisect_each(passes: Callable[[NDArray[np.int64]], NDArray[np.bool_]], n: int, top: int) -> NDArray[np.int64]:
    """``(n,)`` indices in ``0..top``: for each entry the largest seen to pass, by bisection in lockstep, where
    index 0 is known to pass and ``top + 1`` is taken to fail (``ceil(log2(top + 1))`` calls)."""
    lo = np.zeros(n, np.int64)
    hi = np.full(n, top + 1, np.int64)
    while np.any(hi - lo > 1):
        todo = hi - lo > 1
        mid = np.where(todo, (lo + hi) // 2, lo)
        ok = np.asarray(passes(mid), dtype=bool)
        lo = np.where(todo & ok, mid, lo)
        hi = np.where(todo & ~ok, mid, hi)
    return lo
