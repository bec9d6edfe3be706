"""Spending the bound's slack (``motionrep_transform._slack``, the threshold search of a context without feature
edits; ``_greedy`` for the exact one): its pieces, and what the search may change in a payload (only integers, each
at most one step towards zero per round or pass, the bound kept). Determinism across processes and
thread counts is tested on the whole codec in ``tests/test_transform.py``."""

from __future__ import annotations

import numpy as np
import pytest

from motionrep.model.synthetic import humanoid_skeleton, synthetic_motion
from motionrep.pipeline.compress import compress_motion, decompress
from motionrep.pipeline.evaluate import max_joint_error
from motionrep.plugin.coding import NUM_TOKENS, Model, _probabilities
from motionrep_transform._codec import window_minimum
from motionrep_transform._slack import (_bisect_each, _code_length_of, _code_lengths, _fit_each, frame_sensitivity,
                                       reduction_savings)
from motionrep_transform._stream import MAX_ZERO, _approx_steps, _fit, _passes
from motionrep_transform._stream import _parent_rows
from transform_reference_v1 import _contexts, _parents
from motionrep_transform._stream2 import unpack
from motionrep_transform._wavelet import forward, level_sizes, num_levels

from helpers import without


def test_code_lengths_are_the_models_costs():
    model = Model(150, 20)
    for a in (0, 1, 2, 5, 15, 16, 17, 100, 4000):
        assert _code_lengths(model, np.array([a]))[0] == pytest.approx(model.cost(np.array([a])), abs=1e-9)


def test_savings_are_zero_on_zeros_and_large_on_isolated_ones():
    rng = np.random.default_rng(1)
    x = np.cumsum(rng.normal(size=(200, 3)), axis=0)
    levels = num_levels(200)
    q = [np.rint(c / 2.0).astype(np.int64) for c in forward(x, levels)]
    saved = reduction_savings(q, levels)
    assert np.all(saved[0] == 0)  # the approximation is never moved
    for c, s in zip(q[1:], saved[1:]):
        assert np.all(s[c == 0] == 0)
    finest, s = q[-1], saved[-1]
    assert np.mean(finest == 0) > 0.8 and np.any(np.abs(finest) == 1)
    # where a zero is likelier than a +-1 (here: everywhere), zeroing a +-1 saves more than its sign bit
    assert np.all(s[np.abs(finest) == 1] > 1)


def _savings_pass_by_pass(coefficients, levels):
    """:func:`reduction_savings` as it was before (c819464: the contexts of ``._stream`` pass by pass, every
    coefficient tokenized): the reference the faster formulation must match bit for bit."""
    mags = [np.abs(c) for c in coefficients]
    mags[0] = _approx_steps(coefficients[0])
    out = [np.zeros(c.shape) for c in coefficients]
    parents = {index: _parents(mags, index) for index in range(1, levels + 1)}
    passes = [(index, odd, _contexts(parents[index], mags[index], odd, group))
              for index, odd, group in _passes(levels)]
    if not passes:
        return out
    ctx = np.concatenate([c.reshape(-1) for _, _, c in passes])
    val = np.concatenate([coefficients[i][int(odd)::2].reshape(-1) for i, odd, _ in passes])
    mag = np.abs(val)
    saved = np.zeros(ctx.size)
    moved = np.flatnonzero(mag > 0)
    if moved.size:
        used = np.unique(ctx[moved])
        zero, decay = _fit_each(ctx, val, used)
        table = np.zeros((zero.size, NUM_TOKENS))
        table[used] = np.stack([_probabilities(int(zero[k]), int(decay[k])) for k in used])
        rows = ctx[moved]
        saved[moved] = _code_length_of(table, rows, mag[moved]) - _code_length_of(table, rows, mag[moved] - 1)
    start = 0
    for index, odd, c in passes:
        out[index][int(odd)::2] = saved[start:start + c.size].reshape(c.shape)
        start += c.size
    return out


@pytest.mark.parametrize("frames", [1, 3, 4, 5, 7, 9, 17, 31, 64, 97, 200, 1001, 1250])
def test_savings_are_those_of_the_pass_by_pass_formulation_bit_for_bit(frames):
    """The savings (contexts of both passes at once, a table of context sizes, only the non-zero coefficients
    tokenized) are the same float64 bits as the first formulation's, on sparse and dense arrays, small and large
    magnitudes (context sums past the cap, tokens past the direct ones), odd and even level sizes (a level
    longer than twice the one above) and all zeros.  Integers and the same elementwise float operations on the
    same numbers: bitwise on any machine."""
    rng = np.random.default_rng(frames)
    levels = num_levels(frames)
    for density in (0.0, 0.02, 0.3, 1.0):
        for scale in (0.7, 4.0, 60.0, 5e4):
            q = []
            for size in level_sizes(frames, levels):
                c = np.rint(rng.laplace(scale=scale, size=(size, 5))).astype(np.int64)
                q.append(np.where(rng.random(c.shape) < density, c, 0))
            got, want = reduction_savings(q, levels), _savings_pass_by_pass(q, levels)
            assert len(got) == len(want)
            for g, w in zip(got, want):
                assert g.shape == w.shape and g.dtype == w.dtype and g.tobytes() == w.tobytes(), (density, scale)


def test_parents_are_those_of_the_padded_gather():
    """``_stream._parent_rows`` (sums on the coarser array, then the even and the odd rows that take them) gives
    the same integers as the first formulation (a zero-padded copy gathered at every row, the rows interleaved),
    for the approximation's differences and the detail
    levels, levels of equal, shorter, twice and more than twice the coarser one's rows (the last row repeated),
    an empty coarser array; whole numbers: exact."""
    rng = np.random.default_rng(7)
    for m in (0, 1, 2, 3, 8, 33):
        for n in sorted({0, 1, max(m - 1, 0), m, m + 1, max(2 * m - 1, 0), 2 * m, 2 * m + 1, 3 * m + 2}):
            coarse, fine = (np.abs(rng.integers(-70, 70, size=(rows, 4))) for rows in (m, n))
            for index, mags in ((1, [coarse, fine]), (2, [coarse[:1], coarse, fine])):
                (even, odd), want = _parent_rows(mags, index), _parents(mags, index)
                for got, rows in ((even, want[0::2]), (odd, want[1::2])):
                    assert got.dtype == np.int64 and got.shape == rows.shape, (m, n, index)
                    assert np.array_equal(got, rows), (m, n, index)


def test_every_context_is_fitted_as_one_at_a_time():
    """All contexts' models at once (:func:`_fit_each`, elementwise sums) are those of ``_fit`` on each
    context's values (the same indices), on values of small and large magnitudes, a context of zeros only and
    context numbers that are not used."""
    rng = np.random.default_rng(4)
    for scale in (0.3, 3.0, 300.0):
        values = np.rint(rng.laplace(scale=scale, size=3000)).astype(np.int64)
        ctx = rng.choice([0, 2, 3, 7, 9], size=values.size)
        values[ctx == 9] = 0
        zero, decay = _fit_each(ctx, values)
        for k in range(10):
            model = _fit(values[ctx == k])
            assert (zero[k], decay[k]) == (model.zero, model.decay), (scale, k)
        # only some contexts fitted: those as among all, the others (MAX_ZERO, 0)
        some_zero, some_decay = _fit_each(ctx, values, np.array([2, 7]))
        assert some_zero.tolist() == [MAX_ZERO, MAX_ZERO, zero[2], MAX_ZERO, MAX_ZERO, MAX_ZERO, MAX_ZERO, zero[7],
                                      MAX_ZERO, MAX_ZERO]
        assert some_decay.tolist() == [0, 0, decay[2], 0, 0, 0, 0, decay[7], 0, 0]


def test_frame_sensitivity_interpolates_samples_spread_over_the_clip():
    samples = np.array([[1.0, 10.0], [3.0, 10.0], [5.0, 4.0]])
    s = frame_sensitivity(samples, 5)
    assert s[:, 0].tolist() == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert s[0, 1] == 10.0 and s[-1, 1] == 4.0
    assert frame_sensitivity(samples[:1], 4).shape == (4, 2)


def test_bisect_each_finds_every_largest_passing_index():
    limits = np.array([0, 3, 7, 16, 11])
    calls = []

    def passes(i):
        calls.append(1)
        return i <= limits

    assert _bisect_each(passes, 5, 16).tolist() == limits.tolist()
    assert len(calls) == 5  # ceil(log2(17)): index 0 is known to pass, 17 taken to fail


def test_window_minimum_of_columns_is_that_of_each_column():
    rng = np.random.default_rng(2)
    v = rng.integers(-50, 50, size=(40, 3))
    for span in (0, 1, 3, 39, 60):
        out = window_minimum(v, span)
        for c in range(3):
            assert out[:, c].tolist() == window_minimum(v[:, c], span).tolist()


@pytest.fixture(scope="module")
def walk():
    return synthetic_motion(humanoid_skeleton(), frames=240, fps=60, seed=5)


@pytest.mark.parametrize("max_error", ["2%", "0.1%"])
def test_the_search_only_moves_integers_towards_zero_and_keeps_the_bound(walk, max_error):
    events = []
    kept = compress_motion(walk, "transform", max_error=max_error, params={"slack": 0})
    spent = compress_motion(walk, "transform", max_error=max_error, params={"slack": 2},
                            progress=lambda stage, fields: events.append((stage, dict(fields))))
    a = unpack(kept.container.arrays["data"].tobytes())
    b = unpack(spent.container.arrays["data"].tobytes())
    # the same steps: region and feature exponents are not touched
    assert a.region_exponents.tolist() == b.region_exponents.tolist()
    active = [c for c in range(a.num_features) if any(np.any(x[:, c]) for x in b.coefficients)]
    assert a.feature_exponents[active].tolist() == b.feature_exponents[active].tolist()  # (v2 stores no step
    # for a feature whose coefficients are all zero)
    assert np.array_equal(a.coefficients[0], b.coefficients[0])  # nor is the approximation
    moved = 0
    for x, y in zip(a.coefficients[1:], b.coefficients[1:]):
        # at most one step per pass, two passes
        assert np.all((np.abs(y) <= np.abs(x)) & (np.abs(y) >= np.abs(x) - 2))
        assert np.all((y == 0) | (np.sign(y) == np.sign(x)))
        moved += int(np.abs(x - y).sum())
    slack = [fields for stage, fields in events if stage == "slack"]
    assert moved > 0 and slack and slack[0]["moved"] == moved
    assert spent.container.payload_bytes < kept.container.payload_bytes
    assert max_joint_error(walk, decompress(spent.data)).max_error <= spent.bound


def test_without_frame_errors_nothing_is_searched():
    """A context that measures region by region only (no ``frame_errors``) keeps the rounded integers: the
    search would cost one evaluation per stretch per step."""
    from motionrep.plugin.registry import get_codec, get_representation
    from motionrep.pipeline.evaluate import MotionContext

    m = synthetic_motion(humanoid_skeleton(), frames=64, fps=30, seed=1)
    codec, rep = get_codec("transform"), get_representation("root-quat-axis-angle")
    params = codec.parse_params({})
    inner = MotionContext(m, rep, codec, params, 0.02 * 1.7, 0, None)
    a = codec.encode(rep.to_features(m), rep.weights(m), without(inner, "frame_errors"))
    inner0 = MotionContext(m, rep, codec, codec.parse_params({"slack": 0}), 0.02 * 1.7, 0, None)
    b = codec.encode(rep.to_features(m), rep.weights(m), without(inner0, "frame_errors"))
    assert a.arrays["data"].tobytes() == b.arrays["data"].tobytes()


def _fit_counts_every_token(counts):
    """:func:`._slack._fit_counts` as it was until 0a46dc9 (every token's product summed): the reference."""
    from motionrep.plugin.coding import _fit_tables

    n = counts.shape[0]
    counts = counts.astype(np.float64)
    nonzero = counts.sum(axis=1) - counts[:, 0]
    zero_bits, tail_bits = _fit_tables()
    zb = zero_bits[:MAX_ZERO + 1]
    z = np.argmin(zb[None, :, 0] * counts[:, 0, None] + zb[None, :, 1] * nonzero[:, None], axis=1)
    d = np.concatenate([np.argmin((tail_bits[None, :, :] * counts[k:k + 8, None, 1:]).sum(axis=2), axis=1)
                        for k in range(0, n, 8)] + [np.zeros(0, np.int64)])
    d[nonzero == 0] = 0
    z[counts.sum(axis=1) == 0] = MAX_ZERO
    return z, d


@pytest.mark.parametrize("last", [0, 1, 6, 7, 8, 9, 15, 16, 17, 23, 24, 40, 63, 64, 71, 72])
def test_fits_summing_only_the_tokens_counted_are_those_of_every_token(last):
    """:func:`_fit_counts` sums the products of the tokens up to the last one counted (rounded up to eight,
    :func:`_tail_costs`): the same float64 sums, bit for bit, and the same indices as summing all
    ``NUM_TOKENS - 1`` (numpy adds a contiguous axis in eight interleaved
    partial sums, so the products of zero counts left out only added exact zeros). Counts of every spread, from
    one to millions, contexts of zeros only and of no values. A numpy that summed in another order fails here."""
    from motionrep.plugin.coding import _fit_tables
    from motionrep_transform._slack import _fit_counts, _tail_costs

    rng = np.random.default_rng(last)
    for trial in range(6):
        n = int(rng.integers(1, 40))
        counts = np.zeros((n, NUM_TOKENS), np.int64)
        scale = 10.0 ** rng.integers(0, 7)
        width = last + 2  # tokens 0 .. last + 1: the tail's columns 0 .. last
        counts[:, :width] = np.rint(rng.exponential(scale, size=(n, width)) * (rng.random((n, width)) < 0.6))
        counts[0] = 0
        if n > 1:
            counts[1, 1:] = 0
        tail_bits = _fit_tables()[1]
        every = (tail_bits[None, :, :] * counts[:, None, 1:].astype(np.float64)).sum(axis=2)
        assert _tail_costs(counts[:, 1:].astype(np.float64), tail_bits).tobytes() == every.tobytes(), (last, trial)
        want = _fit_counts_every_token(counts)
        got = _fit_counts(counts)
        assert got[0].tolist() == want[0].tolist() and got[1].tolist() == want[1].tolist(), (last, trial)
        some = np.flatnonzero(rng.random(n) < 0.5)
        part = _fit_counts(counts, some)
        assert part[0][some].tolist() == want[0][some].tolist() and part[1][some].tolist() == want[1][some].tolist()
