"""Closed-loop quantisation along the skeleton (``context.feature_chain``): the bound, the bytes, and the open-loop
path that contexts without a chain keep. Determinism across processes and thread counts is tested on the whole
codec (closed loop by default) in ``tests/test_transform.py``."""

from __future__ import annotations

import numpy as np
import pytest

from motionrep.model._pose import Motion, Skeleton
from motionrep.model.synthetic import humanoid_skeleton, synthetic_motion
from motionrep.pipeline.compress import compress_motion, decompress
from motionrep.pipeline.evaluate import MotionContext, max_joint_error
from motionrep.plugin.registry import get_codec, get_representation
from motionrep_transform._stream2 import unpack

from helpers import without


@pytest.fixture(scope="module")
def walk():
    return synthetic_motion(humanoid_skeleton(), frames=200, fps=60, seed=11)


def _coincident_and_translated() -> Motion:
    """A skeleton with a child at its parent (the pelvis at the root) and a joint with animated translation."""
    rot = ("Zrotation", "Xrotation", "Yrotation")
    pos = ("Xposition", "Yposition", "Zposition")
    sk = Skeleton(names=("root", "pelvis", "spine", "head", "left", "lfoot", "right", "rfoot"),
                  parents=np.array([-1, 0, 1, 2, 1, 4, 1, 6]),
                  offsets=np.array([[0, 90, 0], [0, 0, 0], [0, 20, 0], [0, 30, 0], [10, -5, 0], [0, -40, 0],
                                    [-10, -5, 0], [0, -40, 0]], float),
                  channels=(pos + rot, rot, rot, pos + rot, rot, rot, rot, rot),
                  end_site_parents=np.array([3, 5, 7]), end_site_offsets=np.array([[0, 10, 0], [0, -40, 0],
                                                                                    [0, -40, 0]], float))
    m = synthetic_motion(sk, frames=150, fps=60, seed=4)
    t = np.zeros((m.num_frames, 1, 3))
    t[:, 0] = [0.0, 30.0, 0.0]
    t[:, 0, 0] += 2.0 * np.sin(np.linspace(0, 6, m.num_frames))
    return Motion(sk, m.fps, m.root_translation, m.rotations, t)


def _encode(motion, bound, chain: bool, **params):
    codec, rep = get_codec("transform"), get_representation("root-quat-axis-angle")
    ctx = MotionContext(motion, rep, codec, codec.parse_params(params), bound, 0, None)
    context = ctx if chain else without(ctx, "feature_chain")
    payload = codec.encode(rep.to_features(motion), rep.weights(motion), context)
    reached = ctx.evaluate_payload(payload).max_error
    return payload.arrays["data"].tobytes(), reached


@pytest.mark.parametrize("max_error", ["0.05%", "0.5%", "2%", "8%"])
def test_the_bound_holds_in_closed_loop_through_the_decoder(walk, max_error):
    r = compress_motion(walk, "transform", max_error=max_error)
    assert max_joint_error(walk, decompress(r.data)).max_error <= r.bound


@pytest.mark.parametrize("percent", [0.05, 0.5, 3.0])
def test_the_bound_holds_with_a_coincident_child_and_animated_translations(percent):
    m = _coincident_and_translated()
    bound = percent / 100 * 170.0
    data, reached = _encode(m, bound, chain=True)
    assert reached <= bound
    r = compress_motion(m, "transform", max_error=f"{percent}%")
    assert max_joint_error(m, decompress(r.data)).max_error <= r.bound


def test_a_context_without_a_chain_quantises_open_loop(walk):
    """Without ``feature_chain`` (a third party's context) the codec is the open-loop one: the bytes of
    ``closed_loop=false``, within the bound, and not those of the closed loop."""
    bound = 0.005 * 170.0
    closed, reached_closed = _encode(walk, bound, chain=True)
    open_loop, reached_open = _encode(walk, bound, chain=False)
    switched_off, _ = _encode(walk, bound, chain=True, closed_loop=False)
    assert open_loop == switched_off and open_loop != closed
    assert reached_closed <= bound and reached_open <= bound
    # the same payload layout either way: any decoder of version 3 reads both
    a, b = unpack(closed), unpack(open_loop)
    assert (a.num_frames, a.num_features) == (b.num_frames, b.num_features)


def test_closed_loop_is_true_or_false():
    from motionrep.errors import ParameterError

    codec = get_codec("transform")
    assert codec.parse_params({}).closed_loop is True
    assert codec.parse_params({"closed_loop": "false"}).closed_loop is False
    assert codec.parse_params({"closed_loop": "yes"}).closed_loop is True
    with pytest.raises(ParameterError, match="closed_loop"):
        codec.parse_params({"closed_loop": "sometimes"})


def test_closed_loop_quantises_the_groups_in_turn(walk, monkeypatch):
    """The codec asks for every group's targets in order, each time with the earlier groups' decoded values."""
    from motionrep.pipeline.chain import FeatureChain

    calls = []
    targets = FeatureChain.targets

    def spy(self, group, decoded, *rest):
        calls.append(group)
        return targets(self, group, decoded, *rest)

    monkeypatch.setattr(FeatureChain, "targets", spy)
    compress_motion(walk, "transform", max_error="1%")
    n = max(calls) + 1
    assert n > 2 and len(calls) % n == 0 and calls == list(range(n)) * (len(calls) // n)


def test_regions_below_the_closed_loop_window_are_searched_below_it(walk, monkeypatch):
    """The closed loop's bisection starts in a narrower window; a region that fails even at its low end is bisected
    again below it (here every region: a window of the full window's top exponent only), and the payload meets the
    bound at about the full window's bytes."""
    import motionrep_transform._codec as codec_module

    full = compress_motion(walk, "transform", max_error="2%")
    windows = []

    def recorded(passes, low, high, **options):
        windows.append((np.asarray(low).size, int(np.max(high))))
        return largest(passes, low, high, **options)

    largest = codec_module.largest_passing_each
    monkeypatch.setattr(codec_module, "largest_passing_each", recorded)
    monkeypatch.setattr(codec_module, "_WARM_BELOW", 1 - codec_module._SEARCH_ABOVE)
    monkeypatch.setattr(codec_module, "_WARM_ABOVE", codec_module._SEARCH_ABOVE)
    narrow = compress_motion(walk, "transform", max_error="2%")
    assert len(windows) == 2 and windows[1][0] == windows[0][0] and windows[1][1] < windows[0][1] - 1
    assert narrow.report.max_error_percent <= 2.0
    assert max_joint_error(walk, decompress(narrow.data)).max_error_percent <= 2.0
    assert abs(len(narrow.data) - len(full.data)) < 0.05 * len(full.data)


def test_closed_loop_bisects_an_octave_either_side_of_the_bound(walk, monkeypatch):
    """Closed loop, the region exponents are bisected over [k0 - 8, k0 + 8) around the bound's exponent k0, neither
    end tested: four whole-clip measurements, and no region above k0 + 7 (the regions that would pass above it, here
    most of the walk's at 2 %, are at k0 + 7; the full window took them to k0 + 23)."""
    import motionrep_transform._codec as codec_module

    calls = []

    def recorded(passes, low, high, **options):
        def counted(k):
            calls[-1] += 1
            return passes(k)
        calls.append(0)
        return largest(counted, low, high, **options)

    largest = codec_module.largest_passing_each
    monkeypatch.setattr(codec_module, "largest_passing_each", recorded)
    result = compress_motion(walk, "transform", max_error="2%")
    k0 = int(codec_module._log_step(0.02 * result.report.height))
    exponents = unpack(np.asarray(result.container.arrays["data"]).tobytes()).region_exponents
    assert calls[0] == 4 and exponents.max() == k0 + 7 and np.sum(exponents == k0 + 7) > exponents.size // 2


def _plans(motion, region=16):
    """Two plans of ``motion``'s features in closed loop (each its own chain), and the rounding."""
    from motionrep_transform._codec import _chain, _sensitivity, feature_exponents
    from motionrep_transform._plan import _Plan

    codec, rep = get_codec("transform"), get_representation("root-quat-axis-angle")
    ctx = MotionContext(motion, rep, codec, codec.parse_params({}), 1.0, 0, None)
    f = rep.to_features(motion)
    out = []
    for _ in range(2):
        chain = _chain(ctx, f)
        exp = feature_exponents(_sensitivity(ctx, f, rep.weights(motion), chain)[0])
        out.append(_Plan(f, exp, region, chain))
    return out


@pytest.mark.parametrize("frames", [1, 2, 3, 15, 16, 17, 200])
def test_incremental_quantisation_is_the_whole_quantisation(frames):
    """Closed loop, each quantisation after the first recomputes only what changed since the last (the frames
    whose decoded parents changed, the groups whose coefficients changed): the same integers and decoded values,
    bit for bit, as quantising the whole clip (the same code on the same numbers), over a settle-like sequence of
    exponents (one region lowered, several, none, the same exponents again, all); clips of 1-3 frames (no
    wavelet levels), of one region, and longer."""
    motion = synthetic_motion(humanoid_skeleton(), frames=frames, fps=60, seed=2)
    inc, whole = _plans(motion)
    assert inc.chain is not None
    rng = np.random.default_rng(frames)
    k = np.full(inc.regions, -12, np.int64)
    sequence = [k.copy()]
    for step in range(14):
        k = k.copy()
        if step % 5 == 4:
            k -= 3  # every region
        elif step % 5 != 2:  # (2: the same exponents again)
            k[rng.integers(0, inc.regions, size=1 + step % 3)] -= 1 + step % 2
        sequence.append(k)
    for k in sequence:
        got = inc._quantise(k, 0.45)
        want = whole._quantise(k, 0.45, incremental=False)
        assert all(np.array_equal(a, b) for a, b in zip(got, want))
        # every group's targets, coefficients, integers, dequantised coefficients and decoded columns
        assert np.array_equal(inc._run[1], whole._run[1])
        assert all(np.array_equal(a, b) for x, y in zip(inc._run[2], whole._run[2]) for a, b in zip(x, y))
        d = inc.decoded(k, 0.45)
        assert np.array_equal(d, whole.decoded(k, 0.45))


def test_decoded_is_the_same_array_only_while_nothing_changes(walk):
    inc, _ = _plans(walk)
    k = np.full(inc.regions, 4, np.int64)
    a = inc.decoded(k, 0.45)
    assert inc.decoded(k, 0.45) is a  # the same exponents
    inc.quantise(k - 1, 0.45)  # a quantisation that changes the values, not through decoded()
    b = inc.decoded(k, 0.45)
    assert b is not a and np.array_equal(b, a)
    assert not np.array_equal(inc.decoded(k - 2, 0.45), a)


def test_a_chain_run_by_someone_else_makes_the_next_quantisation_whole(walk, monkeypatch):
    inc, whole = _plans(walk)
    k = np.full(inc.regions, 4, np.int64)
    inc._quantise(k, 0.45)
    noisy = inc.chain._true + 0.02
    for g in range(len(inc.chain.groups)):
        inc.chain.targets(g, noisy)
    k[3] -= 2
    got = inc._quantise(k, 0.45)
    want = whole._quantise(k, 0.45, incremental=False)
    assert all(np.array_equal(a, b) for a, b in zip(got, want))


@pytest.mark.parametrize("frames, region", [(64, 4), (200, 16), (37, 8), (9, 16)])
def test_next_exponent_is_where_a_region_first_sets_another_coefficient(frames, region):
    """Brute force: lowering region r from e + 1 to e changes the exponents of a set of coefficients that grows
    as e falls; next_exponent is the largest e below k_r - 1 whose set holds a coefficient that lowering r by one
    does not change (k_r - 1 when there is none)."""
    from motionrep_transform._plan import _Plan

    plan = _Plan(np.zeros((frames, 2)), np.zeros(2, np.int64), region)
    rng = np.random.default_rng(frames)
    for _ in range(6):
        k = rng.integers(-6, 7, plan.regions)
        for r in range(plan.regions):
            def moved(e):
                a, b = k.copy(), k.copy()
                a[r], b[r] = e + 1, e
                return np.concatenate([(x != y).reshape(-1) for x, y in zip(plan.exponents(a), plan.exponents(b))])
            now = moved(k[r] - 1)
            want = next((e for e in range(k[r] - 2, -40, -1) if np.any(moved(e) & ~now)), k[r] - 1)
            assert plan.next_exponent(k, r) == want, (k, r)


@pytest.mark.parametrize("frames, region", [(64, 4), (200, 16), (37, 8), (9, 16)])
def test_first_change_is_the_largest_exponent_that_changes_a_step(frames, region):
    """Brute force: first_change is the largest e below k_r at which region r, lowered from k_r to e, changes the
    exponent of any coefficient (k_r - 1 when lowering it by one does; with one region, always)."""
    from motionrep_transform._plan import _Plan

    plan = _Plan(np.zeros((frames, 2)), np.zeros(2, np.int64), region)
    rng = np.random.default_rng(frames + 1)
    seen = set()
    for _ in range(6):
        k = rng.integers(-6, 7, plan.regions)
        now = plan.exponents(k)
        for r in range(plan.regions):
            def changes(e):
                a = k.copy()
                a[r] = e
                return any(np.any(x != y) for x, y in zip(plan.exponents(a), now))
            want = next((e for e in range(k[r] - 1, -40, -1) if changes(e)), None)
            assert plan.first_change(k, r) == want, (k, r)
            seen.add(want < k[r] - 1)
    assert seen == {True, False} or plan.regions == 1


def test_settle_lowers_a_region_to_where_it_changes_a_step():
    """Region 1's error stays the same until its exponent reaches 3, because above that it changes no step at all
    (first_change says so): told, it goes to 3 at its first failure, one round before the rule that waits to see
    the same error twice, and ends at the same exponents."""
    from motionrep_transform._codec import TransformCodec

    calls = []

    def errors(k):
        calls.append(k.copy())
        e = np.where(k <= np.array([11, 3, 5]), 0.5, 1.5)
        e[0] = 0.5 if k[0] <= 11 else 1.0 + 0.01 * k[0]
        return e

    def next_exponent(k, r):
        return 3 if r == 1 else int(k[r]) - 1

    def first_change(k, r):
        return 3 if r == 1 and k[r] > 3 else int(k[r]) - 1

    start = np.array([12, 12, 5])
    waits = TransformCodec._settle(start, errors, 1.0, -50, next_exponent)
    rounds = len(calls)
    calls.clear()
    told = TransformCodec._settle(start, errors, 1.0, -50, next_exponent, first_change)
    np.testing.assert_array_equal(told, waits)
    assert told[1] == 3 and len(calls) == rounds - 1
    assert calls[1][1] == 3  # the second round measures region 1 at 3 already


def test_settle_jumps_a_region_whose_error_does_not_move():
    """Region 1's error stays the same until its exponent reaches 3 (a coarse coefficient it sets only from
    there): lowered one at a time it takes a round per exponent; told where it next sets another coefficient, it
    goes there once its error did not move: the same exponent for it in fewer rounds, and its neighbours lowered
    less (after a region's third failure its neighbours are lowered with it)."""
    from motionrep_transform._codec import TransformCodec

    calls = []

    def errors(k):
        calls.append(k.copy())
        e = np.where(k <= np.array([10, 3, 5]), 0.5, 1.5)
        e[0] = 0.5 if k[0] <= 10 else 1.0 + 0.01 * k[0]  # moves with its exponent
        return e

    start = np.array([12, 12, 5])
    slow = TransformCodec._settle(start, errors, 1.0, -50)
    rounds = len(calls)
    calls.clear()
    fast = TransformCodec._settle(start, errors, 1.0, -50, lambda k, r: 3 if r == 1 else int(k[r]) - 1)
    assert slow[1] == fast[1] == 3 and np.all(fast >= slow) and np.all(errors(fast) <= 1.0)
    assert fast[0] == 10 and fast[2] == 5 and len(calls) - 1 < rounds


def _numpy_round(c, step, rounding):
    """The numpy arithmetic the compiled rounding replaced: ``sign(c) floor(|c| / step + rounding)`` and ``q step``."""
    a = np.floor(np.abs(c) / step + rounding)
    q = a.astype(np.int64) * np.sign(c).astype(np.int64)
    return q, q * step


def test_the_compiled_rounding_is_numpys_arithmetic_bit_for_bit():
    """``_plan._round`` (``_c/mrtransform.c``'s ``mrt_round``: scalar IEEE operations without FMA contraction, in
    numpy's order, so the same bits on every CPU) against numpy: every row (blocks of 128 and a remainder), a subset
    of rows, one row; zeros of either sign, halves, whether the dequantised values changed, and a step too small."""
    from motionrep.errors import BoundNotMetError
    from motionrep_transform._plan import _round

    rng = np.random.default_rng(3)
    for n, m in ((1, 1), (1, 7), (130, 5), (300, 12)):
        c = rng.normal(size=(n, m)) * 10.0 ** rng.integers(-6, 3, (n, m))
        c.flat[::7] = 0.0
        c.flat[3::11] = -0.0
        table = 2.0 ** (rng.integers(-60, 8, (9, 20)) / 8)
        rows = rng.integers(0, 9, n)
        cols = rng.choice(20, m, replace=False).astype(np.int64)
        c.flat[5::13] = (rng.integers(-9, 9, c.flat[5::13].size) + 0.5) * table[rows][:, cols].flat[5::13]
        for rounding in (0.5, 0.3125):
            want_q, want_d = _numpy_round(c, table[rows][:, cols], rounding)
            q, d = np.full((n, m), 7, np.int64), np.full((n, m), 7.0)
            assert not _round(c, table, rows, cols, rounding, q, d, None, True)  # every value changed
            assert np.array_equal(q, want_q) and np.array_equal(d.view(np.int64), want_d.view(np.int64))
            assert _round(c, table, rows, cols, rounding, q, d, None, True)  # the same again
            assert not _round(c, table, rows, cols, rounding, q, d)  # (without compare)
            subset = np.unique(rng.integers(0, n, max(1, n // 3)))
            q2, d2 = np.full((n, m), 7, np.int64), np.full((n, m), 7.0)
            _round(c, table, rows, cols, rounding, q2, d2, subset)
            assert np.array_equal(q2[subset], want_q[subset]) and np.array_equal(d2[subset], want_d[subset])
            assert np.all(np.delete(q2, subset, axis=0) == 7) and np.all(np.delete(d2, subset, axis=0) == 7.0)
        assert np.array_equal(np.signbit(d), np.zeros_like(d, bool) | (q < 0))  # no -0.0 where q is 0
    huge = np.array([[1.0, 2.0 ** 61], [3.0, 4.0]])
    with pytest.raises(BoundNotMetError):
        _round(huge, np.full((1, 2), 0.25), np.zeros(2, np.int64), np.arange(2), 0.5, np.empty((2, 2), np.int64),
               np.empty((2, 2)))
    _round(huge, np.full((1, 2), 1.0), np.zeros(2, np.int64), np.arange(2), 0.0, np.empty((2, 2), np.int64),
           np.empty((2, 2)))  # 2 ** 61 <= MAX_MAGNITUDE


def test_put_columns_is_numpys_column_assignment():
    """``_cdecode.put_columns`` (the closed loop's writes of a group's integers and decoded columns) against numpy's
    ``dst[:, cols] = src`` and, for the rows that changed, ``np.any(src != dst[:, cols], axis=1)`` (a float
    comparison: -0.0 equals 0.0, NaN differs from itself); one row, and refusals."""
    from motionrep_transform._cdecode import put_columns

    rng = np.random.default_rng(4)
    for F in (1, 50):
        cols = np.array([7, 2, 5], np.int64)
        dst = rng.normal(size=(F, 9))
        src = dst[:, cols].copy()
        src[F // 2, 1] += 1.0
        src[0, 0] = -dst[0, 7] if dst[0, 7] == 0.0 else src[0, 0]
        dst[-1, 2] = 0.0
        src[-1, 1] = -0.0
        if F > 2:
            dst[1, 5], src[1, 2] = np.nan, np.nan
        want, want_changed = dst.copy(), np.zeros(F, bool)
        want_changed |= np.any(src != want[:, cols], axis=1)
        want[:, cols] = src
        changed = np.zeros(F, bool)
        put_columns(src, dst, cols, changed.view(np.uint8))
        assert np.array_equal(dst.view(np.int64), want.view(np.int64)) and np.array_equal(changed, want_changed)
        ints, q = np.zeros((F, 9), np.int64), rng.integers(-9, 9, (F, 3))
        put_columns(q, ints, cols)
        assert np.array_equal(ints[:, cols], q) and not ints[:, [0, 1, 3, 4, 6, 8]].any()
    with pytest.raises(ValueError):
        put_columns(np.zeros((2, 1)), np.zeros((2, 3)), np.array([3], np.int64))
    with pytest.raises(ValueError):
        put_columns(np.zeros((2, 1), np.int64), np.zeros((2, 3), np.int64), np.array([0], np.int64),
                    np.zeros(2, np.uint8))  # changed only for float64
