"""Feature chains (``motionrep.pipeline.chain``): depth groups, closed-loop targets and sensitivities."""

from __future__ import annotations

import numpy as np
import pytest

from motionrep.errors import ValidationError

from motionrep.model.kinematics import forward_kinematics
from motionrep.model.synthetic import humanoid_skeleton, synthetic_motion
from motionrep.pipeline.evaluate import MotionContext
from motionrep.plugin.registry import get_codec, get_representation


@pytest.fixture(scope="module")
def walk():
    return synthetic_motion(humanoid_skeleton(), frames=90, fps=60, seed=3)


def _context(motion, representation="root-quat-axis-angle"):
    rep = get_representation(representation)
    codec = get_codec("transform")
    return MotionContext(motion, rep, codec, codec.parse_params({}), 1.0, 0, None), rep


def _fk(motion, rep, features):
    return forward_kinematics(rep.from_features(features, motion.skeleton, motion.fps))


def test_groups_hold_every_column_once_by_depth(walk):
    ctx, rep = _context(walk)
    f = rep.to_features(walk)
    chain = ctx.feature_chain(f)
    cols = np.concatenate(chain.groups)
    assert sorted(cols.tolist()) == list(range(f.shape[1]))
    names = rep.layout(walk.skeleton).names
    depth = walk.skeleton.depths
    index = {n: j for j, n in enumerate(walk.skeleton.names)}
    seen = [sorted({int(depth[index[names[c].split("/")[0]]]) for c in g}) for g in chain.groups]
    assert all(len(s) == 1 for s in seen) and [s[0] for s in seen] == sorted(s[0] for s in seen)
    assert set(chain.groups[0].tolist()) >= {0, 1, 2}  # the root's translation first


def test_targets_of_exact_parents_are_the_features(walk):
    """With every earlier group decoded exactly, each group's targets are its own features (to rounding)."""
    ctx, rep = _context(walk)
    f = rep.to_features(walk)
    chain = ctx.feature_chain(f)
    for g, cols in enumerate(chain.groups):
        np.testing.assert_allclose(chain.targets(g, f), f[:, cols], atol=1e-9)


def test_targets_read_only_the_earlier_groups_and_close_the_loop(walk):
    """Whatever the features held before (every rotation off by about 3 degrees), each group decoded as its
    targets puts every point where it belongs and every joint with several points below it (orientation
    feedback) at its true global rotation: the targets read only the groups before their own."""
    ctx, rep = _context(walk)
    sk = walk.skeleton
    f = rep.to_features(walk)
    chain = ctx.feature_chain(f)
    decoded = f.copy()
    rng = np.random.default_rng(0)
    decoded[:, 3:] += rng.normal(0.0, 0.05, decoded[:, 3:].shape)  # every rotation off by about 3 degrees
    out = decoded.copy()
    for g, cols in enumerate(chain.groups):
        out[:, cols] = chain.targets(g, out)  # each group decoded as its targets (no quantisation error)
    true = forward_kinematics(walk)
    got = _fk(walk, rep, out)
    J = sk.num_joints
    several = [j for j in range(1, J) if len(sk.children[j]) > 1]
    single = [j for j in range(1, J) if len(sk.children[j]) == 1 and not np.any(sk.end_site_parents == j)]
    assert several and single
    # the joints that keep their true global rotation are exactly those with several points below them
    for j in several:
        dot = np.abs(np.sum(got.rotations[:, j] * true.rotations[:, j], axis=-1))
        np.testing.assert_allclose(dot, 1.0, atol=1e-9)
    # with every group its targets, every point lands where it should (the loop closes exactly)
    np.testing.assert_allclose(got.positions, true.positions, atol=1e-7)


def test_an_open_loop_error_moves_what_the_closed_loop_keeps(walk):
    """The same parent error, children left as they were (open loop), moves the hands; the loop puts them back."""
    ctx, rep = _context(walk)
    f = rep.to_features(walk)
    chain = ctx.feature_chain(f)
    decoded = f.copy()
    decoded[:, chain.groups[1]] += 0.02
    open_loop = _fk(walk, rep, decoded).positions
    closed = decoded.copy()
    for g in range(2, len(chain.groups)):
        closed[:, chain.groups[g]] = chain.targets(g, closed)
    closed_pos = _fk(walk, rep, closed).positions
    true = forward_kinematics(walk).positions
    far = np.sqrt(np.sum((open_loop - true) ** 2, axis=-1)).max()
    near = np.sqrt(np.sum((closed_pos - true) ** 2, axis=-1)).max()
    assert near < 0.5 * far


def test_sensitivities_count_the_points_directly_below(walk):
    """Closed loop, a rotation's sensitivity is about its own bones: never above the open-loop one, and well below
    it for the spine, whose open-loop lever reaches the hands."""
    ctx, rep = _context(walk)
    f = rep.to_features(walk)
    chain = ctx.feature_chain(f)
    closed = chain.sensitivity(f)
    opened = ctx.feature_sensitivity(f)
    assert closed.shape == opened.shape
    assert np.all(closed <= opened * (1 + 1e-6) + 1e-9)
    names = rep.layout(walk.skeleton).names
    root_quat = [c for c, n in enumerate(names) if n.startswith(walk.skeleton.names[0] + "/q")]
    assert np.percentile(closed[:, root_quat], 90) < 0.5 * np.percentile(opened[:, root_quat], 90)
    np.testing.assert_allclose(closed[:, :3], opened[:, :3])  # the root's translation moves everything


def test_sensitivity_is_the_largest_move_of_the_lever_points(walk):
    """The sensitivity measures only the lever points of each feature: the same numbers as measuring every point
    and keeping the lever points' largest move (0 for a feature without any; compared bit for bit: the same
    elementwise numpy arithmetic on this machine, max is exact)."""
    from motionrep.pipeline.chain import sensitivity_samples

    ctx, rep = _context(walk)
    f = rep.to_features(walk)
    chain = ctx.feature_chain(f)
    chain.lever_points[5] = False  # a feature that moves none of its lever points
    chain.lever_points[7, :] = False
    chain.lever_points[7, -1] = True  # one point only
    x, moved, h = sensitivity_samples(f)
    D, n = moved.shape[:2]
    base = ctx._positions(x)
    pos = ctx._positions(moved.reshape(D * n, D)).reshape(D, n, base.shape[1], 3)
    every = np.sqrt(np.sum((pos - base[None]) ** 2, axis=-1))  # (D, n, points)
    expected = (np.where(chain.lever_points[:, None, :], every, 0.0).max(axis=2) / h[:, None]).T
    got = chain.sensitivity(f)
    assert np.array_equal(got, expected)
    assert np.all(got[:, 5] == 0.0) and np.all(got[:, 7] == every[7, :, -1] / h[7])


def test_a_child_at_its_parent_passes_the_lever_on():
    """A joint whose only child sits at the joint itself gets the lever of that child's children (else its steps
    would be unbounded: a root whose only child is at the root)."""
    from motionrep.model._pose import Motion, Skeleton

    sk = Skeleton(names=("root", "pelvis", "left", "right"), parents=np.array([-1, 0, 1, 1]),
                  offsets=np.array([[0.0, 90.0, 0.0], [0.0, 0.0, 0.0], [10.0, -40.0, 0.0], [-10.0, -40.0, 0.0]]),
                  channels=(("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"),
                            ("Zrotation", "Xrotation", "Yrotation"), ("Zrotation", "Xrotation", "Yrotation"),
                            ("Zrotation", "Xrotation", "Yrotation")),
                  end_site_parents=np.array([2, 3]), end_site_offsets=np.array([[0.0, -40.0, 0.0]] * 2))
    m = synthetic_motion(sk, frames=30, fps=30, seed=1)
    m = Motion(sk, 30.0, m.root_translation, m.rotations)
    ctx, rep = _context(m)
    chain = ctx.feature_chain(rep.to_features(m))
    names = rep.layout(sk).names
    root_q = names.index("root/qx")
    J = sk.num_joints
    assert chain.lever_points[root_q, :J].tolist() == [False, False, True, True]
    assert chain.sensitivity(rep.to_features(m))[:, root_q].max() > 1.0


def test_only_local_quaternions_and_rotation_vectors_have_a_chain(walk):
    """Other rotation blocks (Euler angles here) get None: the codec then quantises open loop."""
    ctx, rep = _context(walk, "euler")
    assert ctx.feature_chain(rep.to_features(walk)) is None


def test_a_joint_with_many_children_stays_open_loop():
    """A joint with more than ``MAX_CHILDREN`` child joints (a hand with five fingers) keeps its children's true
    features as their targets (each would take a copy of its noise) and its open-loop lever (every point)."""
    from motionrep.model._pose import Motion, Skeleton
    from motionrep.pipeline.chain import MAX_CHILDREN

    rot = ("Zrotation", "Xrotation", "Yrotation")
    n = MAX_CHILDREN + 1
    names = ("root", "hand") + tuple(f"finger{i}" for i in range(n))
    offsets = np.array([[0.0, 90.0, 0.0], [0.0, 30.0, 0.0]] + [[2.0 * i - n, 8.0, 0.0] for i in range(n)])
    sk = Skeleton(names=names, parents=np.array([-1, 0] + [1] * n), offsets=offsets,
                  channels=(("Xposition", "Yposition", "Zposition") + rot,) + (rot,) * (n + 1),
                  end_site_parents=np.arange(2, 2 + n), end_site_offsets=np.array([[0.0, 3.0, 0.0]] * n))
    m = synthetic_motion(sk, frames=40, fps=30, seed=2)
    m = Motion(sk, 30.0, m.root_translation, m.rotations)
    ctx, rep = _context(m)
    f = rep.to_features(m)
    chain = ctx.feature_chain(f)
    names_f = rep.layout(sk).names
    hand = [c for c, name in enumerate(names_f) if name.startswith("hand/")]
    assert chain.lever_points[hand].all()
    decoded = f.copy()
    decoded[:, hand] += 0.05
    fingers = len(chain.groups) - 1
    np.testing.assert_array_equal(chain.targets(0, decoded), f[:, chain.groups[0]])
    for g in range(1, fingers + 1):
        chain.targets(g, decoded)
    np.testing.assert_array_equal(chain.targets(fingers, decoded), f[:, chain.groups[fingers]])


def _still_rig():
    """A spine with a neck (long bone) and a still collar whose shoulder is nearer the spine than the neck (a short
    lever), and a leg whose still toe carries a long end site (a long lever); every other joint moves."""
    from motionrep.model._pose import Motion, Skeleton

    rot = ("Zrotation", "Xrotation", "Yrotation")
    names = ("root", "spine", "neck", "collar", "shoulder", "ankle", "toe")
    parents = np.array([-1, 0, 1, 1, 3, 0, 5])
    offsets = np.array([[0.0, 90.0, 0.0], [0.0, 10.0, 0.0], [0.0, 30.0, 0.0], [5.0, 8.0, 0.0], [10.0, 0.0, 0.0],
                        [10.0, -40.0, 0.0], [0.0, -5.0, 0.0]])
    sk = Skeleton(names=names, parents=parents, offsets=offsets,
                  channels=(("Xposition", "Yposition", "Zposition") + rot,) + (rot,) * 6,
                  end_site_parents=np.array([2, 4, 6]),
                  end_site_offsets=np.array([[0.0, 10.0, 0.0], [20.0, 0.0, 0.0], [0.0, 0.0, 25.0]]))
    m = synthetic_motion(sk, frames=64, fps=30, seed=4)
    rotations = m.rotations.copy()
    rotations[:, [3, 6]] = rotations[:1, [3, 6]]  # the collar and the toe never move
    return Motion(sk, 30.0, m.root_translation, rotations)


def test_a_still_joint_keeps_its_true_values_where_its_parent_lever_stays():
    """A joint that never moves keeps its true values (it would take a copy of its parent's noise) when its
    parent's lever reaching through it gets no longer (the collar: its shoulder is nearer the spine than the neck);
    not when the lever would (the toe's long end site would lengthen the ankle's lever fivefold)."""
    m = _still_rig()
    sk = m.skeleton
    ctx, rep = _context(m)
    f = rep.to_features(m)
    chain = ctx.feature_chain(f)
    assert chain.held.tolist() == [False, False, False, True, False, False, False]
    names = rep.layout(sk).names
    cols = {j: [c for c, n in enumerate(names) if n.startswith(sk.names[j] + "/")] for j in range(sk.num_joints)}
    J = sk.num_joints
    # the spine's lever reaches through the collar to the shoulder and its end site; the ankle's stops at the toe
    assert chain.lever_points[cols[1][0], :J].tolist() == [False, False, True, True, True, False, False]
    assert chain.lever_points[cols[5][0], :J].tolist() == [False] * 6 + [True]
    assert not chain.lever_points[cols[5][0], J + 2]
    # the spine and the ankle decoded off: the collar's targets are its true values, the toe's take the feedback
    decoded = f.copy()
    decoded[:, cols[1] + cols[5]] += 0.03
    for g, group in enumerate(chain.groups):
        out = chain.targets(g, decoded)
        for j, still in ((3, True), (6, False)):
            at = [i for i, c in enumerate(group.tolist()) if c in cols[j]]
            if at:
                same = np.allclose(out[:, at], f[:, cols[j]], atol=1e-12)
                assert same == still


@pytest.mark.parametrize("bound", ["2%", "0.0588%"])
def test_the_bound_holds_with_still_joints(bound):
    """Encoded closed loop with a still joint held (and one not), the decoded clip is within the bound, measured
    again here by FK on the decoded motion (the core measures the bytes written too)."""
    from motionrep.pipeline.compress import compress_motion, decompress

    m = _still_rig()
    result = compress_motion(m, "transform", max_error=bound)
    back = decompress(result.container)
    err = np.sqrt(np.sum((forward_kinematics(back).positions - forward_kinematics(m).positions) ** 2, axis=-1))
    assert float(err.max()) <= result.bound
    assert result.bound > 0


def _run(chain, decoded, frames_of=None, previous=None):
    """One run of every group in order (each group decoded as its targets plus a fixed offset, so that the later
    groups see values the chain did not compute), by frames when ``frames_of(g, out)`` is given."""
    out = decoded.copy()
    targets = []
    for g, cols in enumerate(chain.groups):
        if frames_of is None:
            t = chain.targets(g, out)
        else:
            t = chain.targets(g, out, frames_of(g, out), previous[g])
        targets.append(t)
        out[:, cols] = t + 0.01 * decoded[:, cols]
    return out, targets


def test_targets_by_frames_are_the_targets_of_every_frame(walk):
    """A run by frames (only the frames whose earlier groups changed since the last run computed, the others
    taken from it) gives the bits of a run over every frame: each frame's targets depend on that frame alone, by the
    same arithmetic (compared bit for bit: scalar IEEE C without FMA contraction, as test_chain_kernels)."""
    ctx, rep = _context(walk)
    f = rep.to_features(walk)
    chain = ctx.feature_chain(f)
    rng = np.random.default_rng(5)
    first = f.copy()
    first[:, 3:] += rng.normal(0.0, 0.02, first[:, 3:].shape)
    before, kept = _run(chain, first)
    assert chain.complete
    second = first.copy()
    rows = np.array([0, 7, 8, 40, walk.num_frames - 1])
    second[rows, 3:] += 0.03  # these frames change in every group
    third = first.copy()
    third[50:53, chain.groups[2]] -= 0.02  # these change from the third group on
    for changed in (second, third, first):
        runs = chain.runs

        def frames_of(g, out):
            done = np.concatenate(chain.groups[:g]) if g else np.zeros(0, np.int64)
            return np.flatnonzero(np.any(out[:, done] != before[:, done], axis=1))

        got_out, got = _run(chain, changed, frames_of, kept)
        assert chain.runs == runs + 1 and chain.complete and chain._incremental  # this run went by frames
        want_out, want = _run(ctx.feature_chain(f), changed)
        for a, b in zip(got, want):
            assert np.array_equal(a, b)
        assert np.array_equal(got_out, want_out)
        # the chain state is that of the run just done: the next run by frames starts from it
        before, kept = got_out, got


def test_targets_by_frames_fall_back_to_every_frame(walk):
    """Frames are only a hint: after an incomplete run (or out of order) every frame is computed."""
    ctx, rep = _context(walk)
    f = rep.to_features(walk)
    chain = ctx.feature_chain(f)
    noisy = f + 0.01
    _, kept = _run(chain, noisy)
    chain.targets(0, noisy)  # a run that stops after its first group
    assert not chain.complete
    none = np.zeros(0, np.int64)
    got_out, got = _run(chain, noisy, lambda g, out: none, [np.zeros_like(k) for k in kept])
    assert not chain._incremental
    for a, b in zip(got, kept):
        assert np.array_equal(a, b)  # computed, not the (zero) previous values
    g = len(chain.groups) - 1
    assert np.array_equal(chain.targets(g, got_out, none, np.zeros_like(kept[g])), kept[g])  # out of order


def test_chain_kernels_by_frames_write_only_those_frames(walk):
    from motionrep._ccore import chain_pose, chain_targets

    ctx, rep = _context(walk)
    f = rep.to_features(walk)
    chain = ctx.feature_chain(f)
    g = 2
    d = chain._group_depth[g]
    for depth in range(d):
        chain._pose(depth, f)
    want = np.full((walk.num_frames, chain.groups[g].size), 7.0)
    chain_targets(chain._rot, chain._pos, *chain._at[d], want)
    frames = np.array([3, 4, 60], np.int64)
    got = np.full_like(want, 7.0)
    chain_targets(chain._rot, chain._pos, *chain._at[d], got, frames)
    assert np.array_equal(got[frames], want[frames])
    assert np.all(np.delete(got, frames, axis=0) == 7.0)
    with pytest.raises(ValueError, match="out of range"):
        chain_targets(chain._rot, chain._pos, *chain._at[d], got, np.array([walk.num_frames], np.int64))
    rot, pos = chain._rot.copy(), chain._pos.copy()
    chain._rot[:], chain._pos[:] = 0.0, 0.0
    chain._pose(0, f, frames)
    for depth in range(1, d):
        chain._pose(depth, f, frames)
    js = np.flatnonzero(walk.skeleton.depths < d)
    assert np.array_equal(chain._rot[js][:, frames], rot[js][:, frames])
    assert np.array_equal(chain._pos[js][:, frames], pos[js][:, frames])
    assert np.all(np.delete(chain._rot[js], frames, axis=1) == 0.0)
    with pytest.raises(ValueError, match="out of range"):
        chain_pose(f, np.array([-1]), np.zeros((1, 4), np.int64), js[:1], np.array([-1]), np.full((1, 3), -1),
                   np.zeros((1, 3)), chain._rot, chain._pos, np.array([-1], np.int64))


def test_a_decoded_quaternion_of_zero_length_leaves_the_run_open_loop(walk):
    """The root's decoded quaternion of zero length in one frame: posing it raises ValidationError, the run's later
    groups take their true values, and the next run computes every frame."""
    ctx, rep = _context(walk)
    f = rep.to_features(walk)
    chain = ctx.feature_chain(f)
    bad = f.copy()
    bad[5, chain._levels[0][3][0]] = 0.0  # the root's quaternion columns
    with pytest.raises(ValidationError, match="zero"):
        chain._pose(0, bad)
    assert np.array_equal(chain.targets(0, bad), f[:, chain.groups[0]])
    assert np.array_equal(chain.targets(1, bad), f[:, chain.groups[1]])
    assert not chain.complete


def test_whole_array_lengths_are_those_of_one_joint_at_a_time():
    """The chain's set-up measures its bones and levers for many joints at once (``_longest``, ``_distances``):
    the same float64 bits as one joint (or pair) at a time, as it measured them until 0a46dc9, and as over every
    frame for the joints that are not translated. Elementwise IEEE operations and sums of three in order: bitwise
    on any machine."""
    from motionrep.pipeline.chain import _distances, _longest

    rng = np.random.default_rng(3)
    F, J, P = 37, 6, 9
    pos = rng.normal(scale=10.0 ** rng.integers(-3, 4, size=(1, P, 1)), size=(F, P, 3))
    joints, points = np.array([0, 1, 1, 4, 5, 2]), np.array([3, 2, 8, 7, 6, 6])
    v, dist = _distances(pos, joints, points)
    for k, (j, p) in enumerate(zip(joints, points)):
        alone = pos[:, p] - pos[:, j]
        assert v[:, k].tobytes() == alone.tobytes()
        assert dist[:, k].tobytes() == np.sqrt(np.sum(alone * alone, axis=1)).tobytes()
        assert float(dist[:, k].max()) == float(np.sqrt(np.sum(alone * alone, axis=1)).max())
    offsets = rng.normal(scale=20.0, size=(J, 3))
    for translated in (np.zeros(0, np.int64), np.array([2, 4])):
        local = np.broadcast_to(offsets, (F, J, 3)).copy()
        local[:, translated] = rng.normal(scale=5.0, size=(F, translated.size, 3))
        want = np.sqrt(np.sum(local ** 2, axis=2)).max(axis=0)
        assert _longest(local, translated).tobytes() == want.tobytes()


def test_sensitivity_copies_feature_major_are_the_transposed_copies(walk):
    """The sensitivity's moved copies built feature-major (``moved_by_feature``, handed to the plan's decode
    without transposing) are the same float64 bits as the copies transposed, and the chain's and the context's
    sensitivities are those of the copies decoded pose-major (the same additions and the same decode: bitwise)."""
    from motionrep.pipeline.chain import FeatureChain, moved_by_feature, sensitivity_samples

    context, rep = _context(walk)
    features = rep.to_features(walk)
    x, moved, h = sensitivity_samples(features)
    D, n = moved.shape[:2]
    X = moved_by_feature(x, h)
    assert X.flags.c_contiguous and X.tobytes() == np.ascontiguousarray(moved.reshape(D * n, D).T).tobytes()
    chain = context.feature_chain(features)
    pose_major = FeatureChain(features, walk.skeleton, context._plan, context._positions)
    assert chain.sensitivity(features).tobytes() == pose_major.sensitivity(features).tobytes()
    want = context._positions(moved.reshape(D * n, D))
    assert context._positions_by_feature(X, D * n).tobytes() == want.tobytes()
