"""The quantisation of one clip for the ``transform`` codec (:mod:`._codec`): its wavelet coefficients, the step of
every coefficient from the feature and region exponents, and the integers, open loop or closed loop along the
skeleton (a context's feature chain, :mod:`motionrep.pipeline.chain`: group by group, each group's targets from
what the decoder makes of the groups before it)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from motionrep.errors import BoundNotMetError, naming
from motionrep.plugin.coding import MAX_MAGNITUDE, step_scale

from ._cdecode import put_columns, rounded
from ._decoder import reconstruct, synthesised
from ._stream import Quantised
from ._wavelet import coefficient_frames, forward, forward_rows, num_levels

__all__ = ["coefficient_exponents", "steps_of", "window_minimum"]

#: A coefficient of detail level j reaches about 3 * 2 ** j frames on each side of its centre.
_REACH = 3


class _Plan:
    """The quantisation of one clip: its wavelet coefficients and which regions each coefficient reaches; with a
    feature chain (``context.feature_chain``), quantised closed loop, group by group (:meth:`quantise`)."""

    def __init__(self, features: NDArray[np.float64], feature_exp: NDArray[np.int64], region: int, chain=None):
        self.num_frames, self.num_features = features.shape
        self.region = region
        self.regions = -(-self.num_frames // region)
        self.levels = num_levels(self.num_frames)
        self.feature_exp = feature_exp
        self.chain = chain
        frames = coefficient_frames(self.num_frames, self.levels)
        spans = [self.levels] + list(range(self.levels, 0, -1))
        self.region_of = [np.minimum(f // region, self.regions - 1) for f in frames]
        self.reach = [int(math.ceil(_REACH * 2 ** j / region)) for j in spans]
        # open loop: the coefficients of the features, computed once (in closed loop each quantisation transforms
        # its groups' targets)
        self.coefficients: list[NDArray[np.float64]] = []
        if chain is None:
            self.coefficients = forward(features, self.levels) if self.levels else [features.copy()]
        self._all = np.arange(self.num_features, dtype=np.int64)  # every column of the table of steps
        # the last quantisation (region exponents, rounding) -> integers: the search ends on the exponents it last
        # measured, which the encoder then quantises again
        self._last: tuple[bytes, float, list[NDArray[np.int64]]] | None = None
        # closed loop: the last quantisation, group by group (targets, coefficients, integers, dequantised
        # coefficients; its synthesised columns in self._work), with the chain's run count after it, for the next one
        # to recompute only what changed
        self._run: tuple[int, list[tuple[NDArray[np.float64], ...]]] | None = None
        # closed loop: (F, D) what the decoder makes of the last quantisation, group by group (each run writes every
        # group's columns before the next group's targets read them; a run after a complete one rewrites only the
        # groups whose dequantised coefficients changed)
        self._work = np.zeros((self.num_frames, self.num_features)) if chain is not None else None
        # closed loop: the columns in no group (features the plan fixes), quantised to 0 (their steps unused)
        self._outside = None if chain is None else np.setdiff1d(self._all, np.concatenate([self._all[:0], *chain.groups]))
        #: closed loop: quantise() recomputes only what changed since the last quantisation (the same integers);
        #: false while every quantisation changes every step (the region search's bisection), which saves the
        #: comparisons
        self.incremental = True
        self._serial = 0  # quantisations computed
        self._same = False  # the last one decoded to the same values as the one before it
        # the last decoded() and the quantisation it came from: reused while nothing changes
        self._decoded: tuple[int, NDArray[np.float64]] | None = None
        # first_change: the window minima of the last region exponents asked about, per reach
        self._minima: tuple[bytes, dict[int, NDArray[np.int64]]] = (b"", {})
        self._regions_of: list[NDArray[np.int64]] | None = None

    def exponents(self, region_exp: NDArray[np.int64]) -> list[NDArray[np.int64]]:
        """``(n, D)`` step exponent of every coefficient for region exponents ``k``."""
        return coefficient_exponents(region_exp, self.region_of, self.reach, self.feature_exp)

    def next_exponent(self, region_exp: NDArray[np.int64], region: int) -> int:
        """The largest exponent below ``region_exp[region] - 1`` at which region ``region`` would set the step of a
        coefficient that it does not set now (one whose window's other regions hold an exponent below its own):
        ``m - 1`` for the largest such window minimum ``m``; ``region_exp[region] - 1`` when there is none."""
        here = int(region_exp[region])
        m = self._window_minima(region_exp, region)
        m = m[m < here]
        return here - 1 if not m.size else min(here - 1, int(m.max()) - 1)

    def first_change(self, region_exp: NDArray[np.int64], region: int) -> int:
        """The largest exponent below ``region_exp[region]`` at which region ``region`` changes the step of any
        coefficient: ``region_exp[region] - 1`` when it sets one now (a coefficient whose window's other regions
        hold nothing below its exponent), else :meth:`next_exponent` (the exponents in between change no step)."""
        k = np.asarray(region_exp, np.int64)
        here = int(k[region])
        # it sets a coefficient when a window that holds it has its exponent as the minimum (the minima of all
        # windows computed once for the exponents of a settling round, which asks about each region over the bound)
        key = k.tobytes()
        if self._minima[0] != key:
            self._minima = (key, {})
        minima = self._minima[1]
        for near, span in self._near(region):
            if span not in minima:
                minima[span] = window_minimum(k, span)
            if near.size and int(minima[span][near].max()) >= here:
                return here - 1
        m = self._window_minima(k, region)
        return here - 1 if not m.size or int(m.max()) >= here else int(m.max()) - 1

    def _window_minima(self, region_exp: NDArray[np.int64], region: int) -> NDArray[np.int64]:
        """The minimum of the other regions' exponents over the window of every coefficient that reaches region
        ``region`` (a window of no other region: the int64 maximum), all arrays together."""
        others = np.asarray(region_exp, np.int64).copy()
        others[region] = np.iinfo(np.int64).max
        out = [np.zeros(0, np.int64)]
        for near, span in self._near(region):
            out.append(window_minimum(others, span)[near])
        return np.concatenate(out)

    def _near(self, region: int) -> list[tuple[NDArray[np.int64], int]]:
        """Per coefficient array, the regions of its coefficients whose window holds region ``region`` (each
        region once: coefficients of one region share their window) and the array's reach."""
        if self._regions_of is None:  # the distinct regions of every array's coefficients, sorted
            self._regions_of = [np.unique(rows) for rows in self.region_of]
        return [(present[np.searchsorted(present, region - span):np.searchsorted(present, region + span, "right")],
                 span) for present, span in zip(self._regions_of, self.reach)]

    def _step_rows(self, region_exp: NDArray[np.int64]
                   ) -> tuple[NDArray[np.int64], NDArray[np.float64], list[NDArray[np.int64]]]:
        """The distinct region exponents ``(m,)`` (sorted), the table ``(m, D)`` of their steps
        ``2 ** ((b_c + k) / 8)``, and per coefficient array ``(n,)`` the row of the table each of its rows takes."""
        # the windows' minima as indices into the sorted distinct k (order-preserving, so the minimum of the
        # indices is the index of the minimum): one table of steps for every array, its rows those k's
        distinct, index = np.unique(np.asarray(region_exp, np.int64).reshape(-1), return_inverse=True)
        table = step_scale(distinct[:, None] + self.feature_exp[None, :])
        minima: dict[int, NDArray[np.int64]] = {}  # arrays of one reach share their windows' minima
        out = []
        for rows, span in zip(self.region_of, self.reach):
            if span not in minima:
                minima[span] = window_minimum(index.reshape(-1), span)
            out.append(minima[span][rows])
        return distinct, table, out

    def quantise(self, region_exp: NDArray[np.int64], rounding: float) -> list[NDArray[np.int64]]:
        """``sign(c) floor(|c| / step + rounding)`` of every coefficient (its step ``2 ** ((b_c + k) / 8)``,
        :meth:`exponents`, from :meth:`_step_rows`' table: the same numbers as :func:`steps_of`).

        With a chain, group by group: the coefficients of a group are those of its targets given what the decoder
        makes of the integers of the groups before it (each group's columns synthesised alone: the inverse wavelet
        runs column by column, so they have the decoder's values).  The same exponents and rounding as the call
        before: a copy of its result.

        Closed loop, after a first quantisation, only what changed since the last one is computed again (the same
        values as computing it all, :meth:`_quantise`)."""
        key = np.asarray(region_exp, np.int64).tobytes()
        if self._last is not None and self._last[0] == key and self._last[1] == rounding:
            return [q.copy() for q in self._last[2]]
        out = self._quantise(region_exp, rounding, self.incremental)
        self._last = (key, rounding, [q.copy() for q in out])
        return out

    def _quantise(self, region_exp: NDArray[np.int64], rounding: float, incremental: bool = True
                  ) -> list[NDArray[np.int64]]:
        """The integers of :meth:`quantise`. Closed loop with ``incremental`` and a last run to start from (the
        chain run by nobody else since), each group computes only what the changes above it reach: its targets in
        the frames where the decoded columns of the groups before it changed (a frame's targets depend on that
        frame's decoded values alone: :meth:`FeatureChain.targets <motionrep.pipeline.chain.FeatureChain.targets>`),
        its coefficients only if any target changed, its synthesis only if a dequantised coefficient changed; the
        rest is the last run's, the same values (tested against ``incremental=False``). A group whose coefficients
        did not change is rounded again only in the rows whose region exponent changed (elementwise: the same
        bits)."""
        distinct, table, row_lists = self._step_rows(region_exp)
        if self.chain is None:
            out = []
            for c, rows in zip(self.coefficients, row_lists):
                q = np.empty(c.shape, np.int64)
                _round(c, table, rows, self._all, rounding, q, np.empty(c.shape))
                out.append(q)
            return out
        sizes = [r.size for r in row_lists]
        # the arrays of every level one after the other (storage order), so that a group is one block of columns:
        # each coefficient row's row of the table and its region exponent
        rows = np.concatenate(row_lists)
        row_k = distinct[rows]
        out = np.empty((self.num_frames, self.num_features), np.int64)  # (every group writes its columns)
        if self._outside.size:
            out[:, self._outside] = 0
        decoded = self._work
        last = self._run if incremental and self._run is not None and self._run[0] == self.chain.runs else None
        self._run = None
        changed = np.zeros(self.num_frames, bool)  # frames whose decoded values changed since the last run
        k_rows = None if last is None else np.flatnonzero(row_k != last[1])  # rows whose steps changed
        state = []
        everywhere = last is None  # every frame changed (or no last run): the groups from here on computed whole
        for g, cols in enumerate(self.chain.groups):
            before = None if last is None else last[2][g]
            if everywhere:
                targets = self.chain.targets(g, decoded)
                fresh = True
            else:
                frames = np.flatnonzero(changed)
                targets = self.chain.targets(g, decoded, frames, before[0])
                fresh = frames.size > 0
            if fresh or 2 * k_rows.size > rows.size:  # rounded whole
                c = forward_rows(targets) if fresh else before[1]
                # into the last run's arrays (dropped with it: self._run is None until this run completes), comparing
                q, dequantised = (np.empty(c.shape, np.int64), np.empty(c.shape)) if before is None else before[2:4]
                same = _round(c, table, rows, cols, rounding, q, dequantised, None, not everywhere)
            else:  # the same coefficients: rounded again where the steps changed
                c, q, dequantised = before[1:4]
                same = not k_rows.size or _round(c, table, rows, cols, rounding, q, dequantised, k_rows, True)
            put_columns(q, out, cols)
            if not same:  # (else decoded's columns hold the last run's values, the same)
                values = synthesised([dequantised], self.levels) if self.levels else dequantised
                put_columns(values, decoded, cols, None if everywhere else changed.view(np.uint8))
                everywhere = everywhere or bool(changed.all())
            state.append((targets, c, q, dequantised))
        if self.chain.complete:
            self._run = (self.chain.runs, row_k, state)
        self._serial += 1
        self._same = last is not None and not changed.any()
        return np.split(out, np.cumsum(sizes)[:-1], axis=0)

    def decoded(self, region_exp: NDArray[np.int64], rounding: float) -> NDArray[np.float64]:
        """``(F, D)`` features the payload of region exponents ``k`` decodes to: the decoder's own
        :func:`reconstruct` of ``self.quantised(k, rounding)``. Closed loop, when the quantisation decoded to the
        same values as the last one (every group's dequantised coefficients the same), the very array returned
        last time (the caller may tell by identity that nothing changed; it must not write to it)."""
        quantised = self.quantised(region_exp, rounding)
        if self.chain is not None and self._decoded is not None and (
                self._decoded[0] == self._serial or (self._same and self._decoded[0] == self._serial - 1)):
            self._decoded = (self._serial, self._decoded[1])
        else:
            self._decoded = (self._serial, reconstruct(quantised))
        return self._decoded[1]

    def quantised(self, region_exp: NDArray[np.int64], rounding: float) -> Quantised:
        return Quantised(self.num_frames, self.num_features, self.region, self.feature_exp,
                         np.asarray(region_exp, np.int64), self.quantise(region_exp, rounding))


def _round(c: NDArray[np.float64], table: NDArray[np.float64], rows: NDArray[np.int64], cols: NDArray[np.int64],
           rounding: float, q: NDArray[np.int64], dequantised: NDArray[np.float64],
           subset: NDArray[np.int64] | None = None, compare: bool = False) -> bool:
    """``q = sign(c) floor(|c| / step + rounding)`` and ``dequantised = q step`` of coefficients ``c`` ``(n, m)``,
    ``step = table[rows][:, cols]``, in the rows ``subset`` (or every row), written into ``q`` and ``dequantised``
    (compiled: ``_c/module.c``'s ``rounded``, numpy's elementwise arithmetic in one pass). Returns, with
    ``compare``, whether every value written to ``dequantised`` equals the one it replaced.

    Raises:
        BoundNotMetError: a step so small that an integer exceeds :data:`MAX_MAGNITUDE`."""
    status = rounded(c, table, rows, cols, rounding, q, dequantised, subset, compare)
    if status < 0:
        raise naming(BoundNotMetError("transform: the bound needs steps too small to code; give a larger "
                                      "max_error", None, None), "max_error")
    return status == 1


def steps_of(exponents: list[NDArray[np.int64]]) -> list[NDArray[np.float64]]:
    """``2 ** (e / 8)`` of every exponent array (through a table of the distinct values: the same bits as
    :func:`motionrep.plugin.coding.step_scale`, faster)."""
    low = min(int(e.min()) for e in exponents if e.size)
    high = max(int(e.max()) for e in exponents if e.size)
    table = step_scale(np.arange(low, high + 1))
    return [np.asarray(table)[e - low] for e in exponents]


def coefficient_exponents(region_exp: NDArray[np.int64], region_of: list[NDArray[np.int64]], reach: list[int],
                          feature_exp: NDArray[np.int64]) -> list[NDArray[np.int64]]:
    """Per coefficient array, ``(n, D)`` exponents ``b_c + min(k_r over the regions within reach)``."""
    out = []
    for rows, span in zip(region_of, reach):
        k = window_minimum(region_exp, span)
        out.append(k[rows][:, None] + feature_exp[None, :])
    return out


def window_minimum(values: NDArray[np.int64], span: int) -> NDArray[np.int64]:
    """``(n, ...)``: ``out[i] = min(values[max(0, i - span) : i + span + 1])`` along the first axis (the ends
    extended by their nearest value), in O(n log span) time and O(n) memory: minima over windows of 1, 2, 4, ...
    values by doubling, then each window as two overlapping power-of-two windows (scipy's
    ``minimum_filter1d(values, 2 span + 1, mode="nearest")`` without importing scipy.ndimage, 1.5 s of start-up
    for every process that opens a transform clip; a sliding window view would take O(n span) time, and the
    coarse levels' spans of a long clip reach thousands of regions)."""
    v = np.asarray(values)
    n = v.shape[0]
    if span <= 0 or n == 0:
        return v
    if span >= n - 1:  # every window holds every value
        return np.broadcast_to(v.min(axis=0), v.shape).copy()
    width = 2 * span + 1
    m = np.concatenate([np.repeat(v[:1], span, axis=0), v, np.repeat(v[-1:], span, axis=0)])
    p = 1
    while 2 * p <= width:  # m[i] = min of the p values from i on
        m = np.minimum(m[:-p], m[p:])
        p *= 2
    return np.minimum(m[:n], m[width - p:width - p + n])
