"""The exact slack search (``motionrep_transform._greedy``): synthesis functions, and what it may change."""

from __future__ import annotations

import numpy as np
import pytest

from motionrep.model.synthetic import humanoid_skeleton, synthetic_motion
from motionrep.pipeline.compress import compress_motion, decompress
from motionrep.pipeline.evaluate import MotionContext, max_joint_error
from motionrep.plugin.registry import get_codec, get_representation
from motionrep_transform._greedy import _peaks, synthesis
from motionrep_transform._stream2 import unpack
from motionrep_transform._wavelet import inverse, level_sizes, num_levels

from helpers import without


@pytest.mark.parametrize("frames", [1, 3, 4, 9, 33, 64, 65, 130, 517])
def test_synthesis_functions_are_the_inverse_wavelet_of_each_coefficient(frames):
    """Every row's function, shifted from one row or computed directly, has the values of the inverse wavelet of
    that unit coefficient (the same operations on the same numbers: compared exactly)."""
    levels = num_levels(frames)
    sizes = level_sizes(frames, levels)
    firsts, counts, starts, pool = synthesis(frames, levels)
    for a, n in enumerate(sizes):
        arrays = [np.zeros((s, n)) for s in sizes]
        arrays[a][np.arange(n), np.arange(n)] = 1.0
        full = inverse(arrays) if levels else arrays[0]
        for i in range(n):
            expect = np.zeros(frames)
            expect[firsts[a][i]:firsts[a][i] + counts[a][i]] = pool[starts[a][i]:starts[a][i] + counts[a][i]]
            assert np.array_equal(expect, full[:, i]), (a, i)


@pytest.fixture(scope="module")
def walk():
    return synthetic_motion(humanoid_skeleton(), frames=240, fps=60, seed=5)


@pytest.mark.parametrize("passes", [1, 3])
def test_each_pass_moves_a_coefficient_at_most_one_step_and_keeps_the_bound(walk, passes):
    kept = compress_motion(walk, "transform", max_error="1%", params={"slack": 0})
    spent = compress_motion(walk, "transform", max_error="1%", params={"slack": passes})
    a = unpack(kept.container.arrays["data"].tobytes())
    b = unpack(spent.container.arrays["data"].tobytes())
    assert a.region_exponents.tolist() == b.region_exponents.tolist()
    assert np.array_equal(a.coefficients[0], b.coefficients[0])
    steps = 0
    for x, y in zip(a.coefficients[1:], b.coefficients[1:]):
        assert np.all((np.abs(y) <= np.abs(x)) & (np.abs(y) >= np.abs(x) - passes))
        assert np.all((y == 0) | (np.sign(y) == np.sign(x)))
        steps = max(steps, int(np.abs(x - y).max(initial=0)))
    assert steps == passes  # some coefficient moved in every pass
    assert spent.container.payload_bytes < kept.container.payload_bytes
    assert max_joint_error(walk, decompress(spent.data)).max_error <= spent.bound


def test_a_context_without_feature_edits_spends_the_slack_by_thresholds(walk):
    """A context without ``feature_edits`` (a third party's, or a representation without a pose plan) gets the
    threshold search of ``_slack``: at most one step per round, two rounds."""
    codec, rep = get_codec("transform"), get_representation("root-quat-axis-angle")
    bound = 0.01 * 170.0
    f, w = rep.to_features(walk), rep.weights(walk)

    def encode(slack, wrap):
        params = codec.parse_params({} if slack is None else {"slack": slack})
        ctx = MotionContext(walk, rep, codec, params, bound, 0, None)
        ctx = without(ctx, "feature_chain")  # open loop: the figures below are of that quantisation
        return unpack(codec.encode(f, w, without(ctx, "feature_edits") if wrap else ctx).arrays["data"].tobytes())

    kept, thresholds, exact = encode(0, True), encode(3, True), encode(3, False)
    moved = [np.abs(x - y) for x, y in zip(kept.coefficients[1:], thresholds.coefficients[1:])]
    assert max(int(m.max(initial=0)) for m in moved) == 2 and sum(int(m.sum()) for m in moved) > 0
    assert any(not np.array_equal(x, y) for x, y in zip(thresholds.coefficients, exact.coefficients))
    # slack unset: three feature groups there (five passes with feature edits)
    by_default = encode(None, True)
    assert all(np.array_equal(x, y) for x, y in zip(thresholds.coefficients, by_default.coefficients))


def test_moves_saving_too_little_are_not_tried(walk, monkeypatch):
    """Moves whose estimated savings are at most ``min_saving`` are not tried: none at all above every saving (the
    integers of slack=0), fewer tried at the default than with every move tried, each result within the bound."""
    import motionrep_transform._codec as codec_module

    def encode(min_saving):
        monkeypatch.setattr(codec_module, "MIN_SAVING", min_saving)
        events = []
        r = compress_motion(walk, "transform", max_error="1%", params={"slack": 2},
                            progress=lambda stage, fields: events.append((stage, dict(fields))))
        assert max_joint_error(walk, decompress(r.data)).max_error <= r.bound
        return r, [f for stage, f in events if stage == "slack"][0]

    everything, all_tried = encode(0.0)
    default, default_tried = encode(0.2)
    nothing, none_tried = encode(float("inf"))
    kept = compress_motion(walk, "transform", max_error="1%", params={"slack": 0})
    payload = lambda r: r.container.arrays["data"].tobytes()  # noqa: E731 - the params differ in the header
    assert none_tried["tried"] == 0 and none_tried["moved"] == 0 and payload(nothing) == payload(kept)
    assert 0 < default_tried["tried"] < all_tried["tried"] and default_tried["moved"] > 0
    assert default.container.payload_bytes < kept.container.payload_bytes


def test_the_default_slack_is_five_passes_with_feature_edits(walk):
    """``slack`` unset: five passes of the move-by-move search (the payload of slack=5, not of 3 or 6)."""
    def payload(**params):
        return compress_motion(walk, "transform", max_error="1%", params=params).container.arrays["data"].tobytes()

    default = payload()
    assert default == payload(slack=5) and default != payload(slack=3) and default != payload(slack=6)


@pytest.mark.parametrize("bound", ["0.3%", "1%", "4%"])
def test_failed_moves_checked_first_where_they_failed_decide_as_before(walk, monkeypatch, bound):
    """The search tells the kernel which frame to check first (``leads``): where each move that failed did fail,
    else its synthesis function's largest value (found once per row, not at every try). The same moves are
    accepted as when the kernel starts every move at its largest change itself, so the payload is the same."""
    from motionrep.pipeline.edits import FeatureEdits

    apply = FeatureEdits.apply
    named, tries = [], []

    def encode(keep):
        def patched(self, columns, firsts, counts, deltas, bound, *args, leads=None, starts=None, **kwargs):
            if leads is not None and keep:
                named.append(leads.copy())
                tries.append((np.asarray(counts).copy(), np.asarray(starts).copy(), np.asarray(deltas)))
            return apply(self, columns, firsts, counts, deltas, bound, *args, leads=leads if keep else None,
                         starts=starts, **kwargs)

        monkeypatch.setattr(FeatureEdits, "apply", patched)
        return compress_motion(walk, "transform", max_error=bound).container.arrays["data"].tobytes()

    led = encode(True)
    assert len(named) > 1 and all((leads >= 0).all() for leads in named)
    counts, starts, pool = tries[0]  # the first pass: every move starts at its largest value
    peaks = [int(np.argmax(np.abs(pool[a:a + n]))) for a, n in zip(starts, counts)]
    assert named[0].tolist() == peaks
    assert led == encode(False)


@pytest.mark.parametrize("frames", [9, 65, 517, 1247])
def test_each_rows_peak_is_its_largest_value(frames):
    """Every detail row's peak (rows sharing their values, shifted, and rows computed directly) is the offset of
    the largest |value| of its synthesis function."""
    levels = num_levels(frames)
    firsts, counts, starts, pool = synthesis(frames, levels)
    count = np.concatenate(counts[1:])
    start = np.concatenate(starts[1:])
    expect = [int(np.argmax(np.abs(pool[a:a + n]))) if n else 0 for a, n in zip(start, count)]
    assert count.size > 0 and _peaks(count.size, count, start, pool).tolist() == expect


def test_a_peak_is_the_first_of_equal_values_and_an_empty_row_has_peak_zero():
    flat = np.array([1.0, -3.0, 3.0, 0.5, 2.0, 2.0])
    assert _peaks(3, np.array([3, 3, 0]), np.array([0, 3, 0]), flat).tolist() == [1, 1, 0]
    assert _peaks(2, np.array([0, 0]), np.array([0, 0]), np.zeros(0)).tolist() == [0, 0]
    assert _peaks(0, np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)).tolist() == []
