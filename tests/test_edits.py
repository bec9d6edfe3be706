"""Feature edits (``motionrep.pipeline.edits``, ``MotionContext.feature_edits``): the error of changes to one feature
column over a stretch of frames, computed in C only where the change moves something.

The kernel runs the pose plan's conversions and FK's arithmetic operation for operation (scalar IEEE float64, no
fused multiply-add, ``setup.py``), so its distances are compared with the context's ``frame_errors`` bit for bit,
on this machine, in one process."""

from __future__ import annotations

import numpy as np
import pytest

from motionrep import Skeleton
from motionrep.errors import ValidationError
from motionrep.model.synthetic import humanoid_skeleton, odd_skeleton, synthetic_motion
from motionrep.pipeline.edits import FeatureEdits
from motionrep.pipeline.evaluate import MotionContext
from motionrep.plugin.registry import get_codec, get_representation

REPRESENTATIONS = ["root-quat-axis-angle", "euler", "ortho6d", "dual-quaternion"]


def _skeleton() -> Skeleton:
    """The humanoid with a fixed root axis and a joint that moves along Y (a translated joint)."""
    sk = humanoid_skeleton()
    chans = list(sk.channels)
    chans[0] = ("Xposition", "Zposition") + tuple(c for c in chans[0] if c.endswith("rotation"))
    chans[5] = ("Yposition",) + tuple(c for c in chans[5] if c.endswith("rotation"))
    return Skeleton(sk.names, sk.parents, sk.offsets, tuple(chans), sk.end_site_parents, sk.end_site_offsets)


def _context(name: str, skeleton: Skeleton | None = None, frames: int = 60, seed: int = 3):
    m = synthetic_motion(skeleton or _skeleton(), frames=frames, seed=seed)
    rep = get_representation(name)
    ctx = MotionContext(m, rep, get_codec("transform"), None)
    rng = np.random.default_rng(seed)
    f = rep.to_features(m) + rng.normal(scale=1e-2, size=(frames, rep.width(m.skeleton)))
    return ctx, f, rng


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)


def _random_edits(rng, F: int, D: int, m: int, scale: float):
    cols = rng.integers(0, D, m)
    counts = rng.integers(1, 12, m)
    firsts = rng.integers(0, F - counts + 1)
    return cols, firsts, counts, scale * rng.normal(size=int(counts.sum()))


@pytest.mark.parametrize("name", REPRESENTATIONS)
@pytest.mark.parametrize("skeleton", ["humanoid", "odd"])
def test_edits_keep_the_distances_the_context_measures(name, skeleton):
    ctx, f, rng = _context(name, odd_skeleton() if skeleton == "odd" else None)
    edits = ctx.feature_edits(f)
    assert np.array_equal(_bits(edits.frame_errors()), _bits(ctx.frame_errors(f)))
    assert np.array_equal(edits.features, f)
    F, D = f.shape
    bound = float(np.quantile(ctx.frame_errors(f), 0.8))
    cols, firsts, counts, deltas = _random_edits(rng, F, D, 300, 3e-3)
    accepted = edits.apply(cols, firsts, counts, deltas, bound)
    assert 0 < accepted.sum() < accepted.size
    now = edits.features.copy()
    # the state is that of the features the accepted edits made, bit for bit
    expected = f.copy()
    start = np.concatenate([[0], np.cumsum(counts)])
    for e in np.flatnonzero(accepted):
        rows = np.arange(firsts[e], firsts[e] + counts[e])
        expected[rows, cols[e]] = expected[rows, cols[e]] + deltas[start[e]:start[e + 1]]
    assert np.array_equal(now, expected)
    assert np.array_equal(_bits(edits.frame_errors()), _bits(ctx.frame_errors(now)))
    full = ctx.evaluator._distances(ctx._positions(now), None)
    assert np.array_equal(_bits(edits.point_errors()), _bits(full))


@pytest.mark.parametrize("name", REPRESENTATIONS)
def test_an_edit_is_accepted_when_every_point_it_moves_stays_within_the_bound(name):
    """The decisions, edit by edit, against measuring each candidate whole: accepted exactly when no point the
    column moves is over the bound in a frame the edit touches."""
    ctx, f, rng = _context(name, frames=40, seed=5)
    edits = ctx.feature_edits(f)
    F, D = f.shape
    bound = float(np.quantile(ctx.frame_errors(f), 0.9))
    cols, firsts, counts, deltas = _random_edits(rng, F, D, 120, 4e-3)
    state = f.copy()
    start = np.concatenate([[0], np.cumsum(counts)])
    for e in range(cols.size):
        trial = state.copy()
        rows = np.arange(firsts[e], firsts[e] + counts[e])
        trial[rows, cols[e]] = trial[rows, cols[e]] + deltas[start[e]:start[e + 1]]
        dist = ctx.evaluator._distances(ctx._positions(trial), None)[rows][:, edits.moved_points[cols[e]]]
        expect = bool(np.all(dist <= bound))
        got = edits.apply(cols[e:e + 1], firsts[e:e + 1], counts[e:e + 1], deltas[start[e]:start[e + 1]], bound)
        assert got.tolist() == [expect]
        if expect:
            state = trial
    assert np.array_equal(edits.features, state)


def test_without_commit_nothing_changes():
    ctx, f, rng = _context("root-quat-axis-angle")
    edits = ctx.feature_edits(f)
    before = edits.point_errors()
    F, D = f.shape
    bound = float(np.quantile(ctx.frame_errors(f), 0.7))
    cols, firsts, counts, deltas = _random_edits(rng, F, D, 100, 3e-3)
    tried = edits.apply(cols, firsts, counts, deltas, bound, commit=False)
    assert np.array_equal(edits.features, f) and np.array_equal(_bits(edits.point_errors()), _bits(before))
    start = np.concatenate([[0], np.cumsum(counts)])
    alone = [bool(edits.apply(cols[e:e + 1], firsts[e:e + 1], counts[e:e + 1], deltas[start[e]:start[e + 1]],
                              bound, commit=False)[0]) for e in range(cols.size)]
    assert tried.tolist() == alone and 0 < sum(alone) < len(alone)


@pytest.mark.parametrize("name", REPRESENTATIONS)
def test_moved_points_are_the_points_a_column_moves(name):
    ctx, f, _ = _context(name, odd_skeleton(), frames=8)
    edits = ctx.feature_edits(f)
    base = ctx.evaluator._distances(ctx._positions(f), None)
    pos = ctx._positions(f)
    for c in range(f.shape[1]):
        g = f.copy()
        g[:, c] += 1e-3
        moved = np.any(ctx._positions(g) != pos, axis=(0, 2))
        # a point a column cannot move keeps its position exactly; the points it may move are those below its
        # joint (the joint itself too, which its own rotation does not move)
        assert not np.any(moved & ~edits.moved_points[c]), c
        assert np.sum(edits.moved_points[c] & ~moved) <= 1, c
    assert base.shape == (8, edits.moved_points.shape[1])


@pytest.mark.parametrize("name", ["root-quat-axis-angle", "euler"])
def test_changes_let_through_on_room_alone_are_bounded_correctly(name):
    """Changes the kernel lets through without computing them (a bound on how far they move any point leaves room
    under the bound) are computed when the call ends: large random changes under a generous bound, then the same
    under a tight one, end in the state of the accepted changes, bit for bit."""
    from motionrep.pipeline.edits import _layout

    ctx, f, rng = _context(name, humanoid_skeleton(), frames=30, seed=7)  # no translated joint: every bound
    F, D = f.shape
    skeleton, plan = ctx.motion.skeleton, ctx._plan
    layout, _, lip = _layout(F, D, skeleton, plan)
    at = 6 + 3 * skeleton.num_joints + skeleton.num_end_sites  # the layout's lip_kind (D,)
    kind = layout[at:at + D]
    assert np.any(kind == 1) and (name != "root-quat-axis-angle" or np.any(kind >= 2))
    pos = ctx._positions(f)
    # each bound holds: a change of one column at one frame moves no point farther than it says for that point
    # (points near the column's joint less than those far below it: the bounds differ point by point)
    assert np.any((lip[kind > 0] > 0) & (lip[kind > 0] < lip[kind > 0].max(axis=1, keepdims=True)))
    for c in np.flatnonzero(kind > 0):
        for t in range(0, F, 7):
            for delta in (1e-3, 0.05, -0.2):
                g = f.copy()
                g[t, c] += delta
                shift = np.linalg.norm(ctx._positions(g)[t] - pos[t], axis=-1)
                if kind[c] == 1:
                    limit = abs(delta) * lip[c]
                else:
                    cols = plan.columns[kind[c] - 2][:4]
                    x = abs(delta) / min(np.linalg.norm(f[t, cols]), np.linalg.norm(g[t, cols]))
                    limit = lip[c] * 2 * x / np.sqrt(1 - x * x) if x < 0.5 else np.full(lip.shape[1], np.inf)
                assert np.all(shift <= limit * (1 + 1e-9) + 1e-12), (c, t, delta)
    for bound in (1e3, float(np.quantile(ctx.frame_errors(f), 0.6))):
        edits = ctx.feature_edits(f)
        cols, firsts, counts, deltas = _random_edits(rng, F, D, 400, 2e-3)
        edits.apply(cols, firsts, counts, deltas, bound)
        now = edits.features.copy()
        assert np.array_equal(_bits(edits.point_errors()),
                              _bits(ctx.evaluator._distances(ctx._positions(now), None)))



def _mixed_edits(name: str, seed: int, m: int):
    """A 50-frame context, its features, a bound at the 70th percentile of their frames' errors and ``m`` edits
    of 1-29 frames, half of them small (they pass on room) and half large (most fail)."""
    ctx, f, rng = _context(name, humanoid_skeleton(), frames=50, seed=seed)
    F, D = f.shape
    cols = rng.integers(0, D, m)
    counts = rng.integers(1, 30, m)
    firsts = rng.integers(0, F - counts + 1)
    scale = np.where(rng.random(m) < 0.5, 1e-4, 2e-2)
    deltas = np.repeat(scale, counts) * rng.normal(size=int(counts.sum()))
    return ctx, f, rng, float(np.quantile(ctx.frame_errors(f), 0.7)), (cols, firsts, counts, deltas)


@pytest.mark.parametrize("name", ["root-quat-axis-angle", "euler"])
def test_one_call_decides_as_the_edits_one_by_one(name):
    """Many edits in one call, half of them small (let through on room alone: their frames stay marked, and later
    edits there are computed with the marked joints above them) and half large (most fail after some of their
    frames were let through or computed, and are undone), decide as the same edits one call each and leave the
    state of the accepted ones, bit for bit (scalar IEEE C without fused multiply-add: see the module docstring)."""
    m = 400
    ctx, f, rng, bound, (cols, firsts, counts, deltas) = _mixed_edits(name, 11, m)
    together = ctx.feature_edits(f)
    got = together.apply(cols, firsts, counts, deltas, bound)
    alone = ctx.feature_edits(f)
    start = np.concatenate([[0], np.cumsum(counts)])
    one = [bool(alone.apply(cols[e:e + 1], firsts[e:e + 1], counts[e:e + 1], deltas[start[e]:start[e + 1]],
                            bound)[0]) for e in range(m)]
    assert got.tolist() == one and 0.2 * m < sum(one) < 0.8 * m
    assert np.array_equal(together.features, alone.features)
    full = ctx.evaluator._distances(ctx._positions(together.features.copy()), None)
    assert np.array_equal(_bits(together.point_errors()), _bits(full))
    assert np.array_equal(_bits(alone.point_errors()), _bits(full))


@pytest.mark.parametrize("name", ["root-quat-axis-angle", "euler"])
def test_one_call_decides_as_measuring_each_candidate_whole(name):
    """One call of many edits (small ones let through on room, large ones whose frames without room are computed
    in the kernel's order, closest to the bound first, most failing at some frame other than the first) against
    measuring every candidate whole in numpy, edit after edit on the state the accepted ones left: the same
    decisions, and the same final state bit for bit (scalar IEEE C without fused multiply-add, as the module's
    other bitwise tests)."""
    m = 300
    ctx, f, rng, bound, (cols, firsts, counts, deltas) = _mixed_edits(name, 17, m)
    edits = ctx.feature_edits(f)
    leads = np.full(m, -1, np.int64)
    got = edits.apply(cols, firsts, counts, deltas, bound, leads=leads)
    state = f.copy()
    start = np.concatenate([[0], np.cumsum(counts)])
    expect, later = [], 0
    for e in range(m):
        trial = state.copy()
        rows = np.arange(firsts[e], firsts[e] + counts[e])
        trial[rows, cols[e]] = trial[rows, cols[e]] + deltas[start[e]:start[e + 1]]
        dist = ctx.evaluator._distances(ctx._positions(trial), None)[rows][:, edits.moved_points[cols[e]]]
        over = np.any(dist > bound, axis=1)
        expect.append(not over.any())
        if over.any():  # the frame told back is one where the edit fails
            assert over[leads[e]], e
            later += int(leads[e] != np.argmax(np.abs(deltas[start[e]:start[e + 1]])))
        else:
            state = trial
    assert got.tolist() == expect and 0.2 * m < sum(expect) < 0.8 * m and later > 10
    assert np.array_equal(_bits(edits.features), _bits(state))
    assert np.array_equal(_bits(edits.point_errors()),
                          _bits(ctx.evaluator._distances(ctx._positions(edits.features.copy()), None)))


@pytest.mark.parametrize("name", ["root-quat-axis-angle", "euler"])
def test_the_frame_checked_first_changes_no_decision(name):
    """``leads`` names the frame of each edit to check first: any choice decides every edit as the default (the
    frame of the largest change) and leaves the same state, bit for bit; where an edit fails it is set to a frame
    where it fails (that frame's change alone, checked on the same state, fails too)."""
    m = 300
    ctx, f, rng, bound, (cols, firsts, counts, deltas) = _mixed_edits(name, 13, m)
    default = ctx.feature_edits(f)
    expect = default.apply(cols, firsts, counts, deltas, bound)
    led = ctx.feature_edits(f)
    leads = np.where(rng.random(m) < 0.5, -1, rng.integers(0, counts))
    given = leads.copy()
    assert np.array_equal(led.apply(cols, firsts, counts, deltas, bound, leads=leads), expect)
    assert 0.2 * m < expect.sum() < 0.8 * m
    assert np.array_equal(_bits(led.features), _bits(default.features))
    assert np.array_equal(_bits(led.point_errors()), _bits(default.point_errors()))
    assert np.array_equal(leads[expect], given[expect])
    assert np.all((leads[~expect] >= 0) & (leads[~expect] < counts[~expect]))
    # one edit at a time: the frame told back fails on its own
    one = ctx.feature_edits(f)
    start = np.concatenate([[0], np.cumsum(counts)])
    for e in range(m):
        d = deltas[start[e]:start[e + 1]]
        lead = np.array([-1])
        if not one.apply(cols[e:e + 1], firsts[e:e + 1], counts[e:e + 1], d, bound, leads=lead)[0]:
            k = int(lead[0])
            assert not one.apply([cols[e]], [firsts[e] + k], [1], d[k:k + 1], bound, commit=False)[0], e
    with pytest.raises(ValidationError, match="leads"):
        led.apply(cols[:2], firsts[:2], counts[:2], deltas[:int(counts[:2].sum())], bound, leads=np.zeros(2))


def test_edits_of_shared_values_times_a_scale_are_the_same_edits():
    """``starts`` and ``scales``: edit ``e`` adds ``deltas[starts[e]:][:counts[e]] * scales[e]`` (a pool of
    shapes the edits share, as the slack search's synthesis functions): the same decisions and state, bit for bit,
    as the products written out."""
    m = 300
    ctx, f, rng, bound, (cols, firsts, counts, _) = _mixed_edits("root-quat-axis-angle", 17, m)
    pool = rng.normal(size=64)
    starts = rng.integers(0, pool.size - counts + 1)
    scales = np.where(rng.random(m) < 0.5, 1e-4, 2e-2) * rng.choice([-1.0, 1.0], m)
    written = np.concatenate([pool[s:s + n] * k for s, n, k in zip(starts, counts, scales)])
    a, b = ctx.feature_edits(f), ctx.feature_edits(f)
    expect = a.apply(cols, firsts, counts, written, bound)
    assert 0.2 * m < expect.sum() < 0.8 * m
    assert np.array_equal(b.apply(cols, firsts, counts, pool, bound, starts=starts, scales=scales), expect)
    assert np.array_equal(_bits(a.features), _bits(b.features))
    assert np.array_equal(_bits(a.point_errors()), _bits(b.point_errors()))
    for bad in (dict(starts=starts), dict(starts=starts[:-1], scales=scales[:-1]),
                dict(starts=np.full(m, pool.size - 1), scales=scales), dict(starts=-starts - 1, scales=scales)):
        with pytest.raises(ValidationError):
            b.apply(cols, firsts, counts, pool, bound, **bad)


def test_bad_edits_and_features_are_refused():
    ctx, f, _ = _context("root-quat-axis-angle", frames=10)
    edits = ctx.feature_edits(f)
    D = f.shape[1]
    for cols, firsts, counts in (([D], [0], [1]), ([0], [9], [2]), ([0], [-1], [1]), ([-1], [0], [1])):
        with pytest.raises(ValidationError):
            edits.apply(cols, firsts, counts, np.zeros(int(np.sum(counts))), 1.0)
    with pytest.raises(ValidationError, match="deltas"):
        edits.apply([0], [0], [3], np.zeros(2), 1.0)
    with pytest.raises(ValidationError):
        ctx.feature_edits(f[:, :-1])
    bad = f.copy()
    bad[2, 4] = np.nan
    with pytest.raises(ValidationError):
        ctx.feature_edits(bad)
    assert edits.apply([], [], [], np.zeros(0), 1.0).shape == (0,)


def test_a_representation_without_a_plan_gets_no_edits():
    ctx, f, _ = _context("root-quat-axis-angle", frames=10)
    ctx._plan = None
    assert ctx.feature_edits(f) is None


def test_the_kernel_checks_its_arrays():
    """The C layer refuses arrays that would make it read or write out of bounds (the Python class builds them
    right; this is the last line)."""
    from motionrep._ccore import edits as kernel

    ctx, f, _ = _context("root-quat-axis-angle", frames=6)
    e = ctx.feature_edits(f)
    layout = e._layout.copy()
    layout[6] = 3  # the root's parent
    with pytest.raises(ValueError):
        kernel(layout, *e._plan, e._geom, e._state, None, None, 0.0, False, None)
    with pytest.raises(ValueError):
        kernel(e._layout, *e._plan, e._geom, e._state[:-1], None, None, 0.0, False, None)
    with pytest.raises(ValueError):
        kernel(e._layout, *e._plan, e._geom, e._state, np.array([[0, 5, 2]]), np.zeros(2), 1.0, True,
               np.zeros(1, np.uint8))
    with pytest.raises(TypeError):
        kernel(e._layout, *e._plan, e._geom, e._state.astype(np.float32), None, None, 0.0, False, None)
    assert isinstance(e, FeatureEdits)


def test_the_conformance_suite_checks_a_pose_plan_through_the_context():
    """A representation whose plan decodes otherwise than its ``from_features`` (here: one that decodes without
    the plan) fails ``check_representation``."""
    from dataclasses import replace

    from motionrep.model.poseplan import EULER
    from motionrep.testing import check_representation

    base = get_representation("root-quat-axis-angle")

    class WrongPlan(type(base)):
        def pose_plan(self, skeleton):
            plan = super().pose_plan(skeleton)
            kinds = plan.kinds.copy()
            kinds[1:] = EULER  # rotation vectors read as Euler angles
            axes = plan.axes.copy()
            axes[1:] = [0, 1, 2]
            return replace(plan, kinds=kinds, axes=axes)

        def from_features(self, features, skeleton, fps):
            return base.from_features(features, skeleton, fps)

    check_representation(base, [synthetic_motion(frames=12, seed=1)])
    with pytest.raises(AssertionError, match="pose plan decodes features otherwise"):
        check_representation(WrongPlan(), [synthetic_motion(frames=12, seed=1)])
