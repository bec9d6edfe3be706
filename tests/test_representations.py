"""The shipped pose representations: conformance, real-clip round trips and continuity, layouts, weights,
the dual-quaternion algebra and diagnostic, and bad input from the command line."""

from __future__ import annotations

import numpy as np
import pytest

import motionrep
from motionrep import Motion
from motionrep.plugin import registry as plugins
from motionrep.errors import ValidationError
from motionrep.io import FeatureClip, read, read_bvh, read_features, write, write_features
from motionrep.io._bvh import channel_values
from motionrep.model.kinematics import character_height, forward_kinematics, global_positions
from motionrep.plugin.representation import joint_reach
from motionrep.model.rotations import axis_angle_to_quat, euler_to_quat, quat_conjugate, quat_multiply, quat_to_matrix
from motionrep.model.synthetic import (chain_skeleton, humanoid_skeleton, odd_skeleton, random_unit_quaternions,
                                 spinning_motion, synthetic_motion)
from motionrep.testing import check_representation

from helpers import mutant, real_params, run_cli_caught

#: Every shipped representation and the plugin module that registers it.
SHIPPED = {
    "root-quat-axis-angle": "motionrep_rootquat",
    "dual-quaternion": "motionrep_dualquat",
    "ortho6d": "motionrep_ortho6d",
    "euler": "motionrep_euler",
}


@pytest.fixture
def reps(monkeypatch):
    """The shipped representations, looked up through the plugin registry (loaded with only their plugins, so
    these tests do not depend on the codec plugins)."""
    monkeypatch.setattr(plugins, "DEFAULT_PLUGINS", tuple(SHIPPED.values()))
    return {name: plugins.get_representation(name) for name in SHIPPED}


# ---- contract ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_conformance_suite(reps, name):
    check_representation(reps[name])


def test_registered_by_their_plugins_through_the_hook(reps):
    infos = {i.name: i for i in plugins.plugin_infos()}
    assert sorted(infos) == sorted(SHIPPED.values())
    for name, module in SHIPPED.items():
        info = infos[module]
        assert info.shipped and info.distribution == "motionrep"
        assert info.version == motionrep.__version__
        assert info.hooks == ["register_representations"]
        assert info.representations == [name]
        assert plugins.provider_of(name, kind="representation") == module
        assert isinstance(reps[name].version, int) and reps[name].version == 1


# ---- the conformance suite catches broken representations ------------------------------------------------
def _mutant(reps, name, **methods):
    return mutant(reps[name], **methods)


def test_suite_catches_a_lossy_round_trip(reps):
    def from_features(self, features, skeleton, fps):  # forgets the joints' translation columns
        m = type(reps["ortho6d"]).from_features(self, features, skeleton, fps)
        return m.replace(joint_translations=None)

    motion = synthetic_motion(odd_skeleton(), frames=20)
    with pytest.raises(AssertionError, match="round trip"):
        check_representation(_mutant(reps, "ortho6d", from_features=from_features), [motion])


def test_suite_catches_missing_validation(reps):
    Euler = type(reps["euler"])

    def from_features(self, features, skeleton, fps):
        f = np.asarray(features, float)
        if f.ndim == 2 and f.shape[1] != self.width(skeleton):
            f = f[:, :self.width(skeleton)]  # silently truncates instead of refusing
        return Euler.from_features(self, f, skeleton, fps)

    with pytest.raises(AssertionError, match="width .* expected a motionrep ValidationError"):
        check_representation(_mutant(reps, "euler", from_features=from_features), [synthetic_motion(frames=5)])


# ---- real clips: round trip and continuity ------------------------------------------------------------------
def _step_angle(q):
    """``(F, ..., 4)`` unit quaternions -> ``(F - 1, ...)`` rotation angle (radians) between consecutive frames."""
    d = quat_multiply(quat_conjugate(q[:-1]), q[1:])
    return 2.0 * np.arctan2(np.linalg.norm(d[..., :3], axis=-1), np.abs(d[..., 3]))


def _blocks(names, suffixes):
    """Joint names and ``(R, k)`` column indices of every joint having all of ``suffixes`` (in that order)."""
    index = {n: i for i, n in enumerate(names)}
    joints = [n.rsplit("/", 1)[0] for n in names if n.endswith("/" + suffixes[0])]
    return joints, np.array([[index[f"{j}/{s}"] for s in suffixes] for j in joints], dtype=np.int64)


def _check_rootquat(f, names, motion, phi):
    sk = motion.skeleton
    root, cols = _blocks(names, ("qx", "qy", "qz", "qw"))
    if root:
        step = np.linalg.norm(np.diff(f[:, cols[0]], axis=0), axis=-1)
        assert np.all(step <= phi[:, 0] / 2 + 1e-12), "root quaternion changes sign or jumps"
    joints, cols = _blocks(names, ("aa_x", "aa_y", "aa_z"))
    aa = f[:, cols]  # (F, R, 3)
    theta = np.linalg.norm(aa, axis=-1)
    # d(rotation vector) <= |angular step| * (theta / 2) / sin(theta / 2), the log map's largest stretch
    stretch = np.where(theta < 1e-6, 1.0, (theta / 2) / np.maximum(np.abs(np.sin(theta / 2)), 1e-300))
    k = np.maximum(np.maximum(stretch[:-1], stretch[1:]), 1.0)
    idx = [sk.index(j) for j in joints]
    step = np.linalg.norm(np.diff(aa, axis=0), axis=-1)
    assert np.all(step <= 1.05 * phi[:, idx] * k + 1e-9), "an axis-angle vector wraps between frames"


def _check_dualquat(f, names, motion, phi):
    sk = motion.skeleton
    joints, cols = _blocks(names, ("real_x", "real_y", "real_z", "real_w", "dual_x", "dual_y", "dual_z",
                                   "dual_w"))
    assert joints == list(sk.names)
    dq = f[:, cols]
    world = np.empty_like(motion.rotations)  # world rotations, composed down the hierarchy
    world[:, 0] = motion.rotations[:, 0]
    for j in range(1, sk.num_joints):
        world[:, j] = quat_multiply(world[:, sk.parents[j]], motion.rotations[:, j])
    gphi = _step_angle(world)
    positions = global_positions(motion)
    t = positions[:, :sk.num_joints] - positions[:, :1]
    real_step = np.linalg.norm(np.diff(dq[..., :4], axis=0), axis=-1)
    assert np.all(real_step <= gphi / 2 + 1e-12), "a real part changes sign or jumps"
    dual_step = np.linalg.norm(np.diff(dq[..., 4:], axis=0), axis=-1)
    bound = 0.5 * np.linalg.norm(np.diff(t, axis=0), axis=-1) + 0.25 * np.linalg.norm(t[:-1], axis=-1) * gphi
    assert np.all(dual_step <= bound + 1e-9 * character_height(sk)), "a dual part jumps"


def _check_ortho6d(f, names, motion, phi):
    joints, cols = _blocks(names, ("m00", "m10", "m20", "m01", "m11", "m21"))
    six = f[:, cols]
    idx = [motion.skeleton.index(j) for j in joints]
    for half in (slice(0, 3), slice(3, 6)):  # each matrix column turns by at most the rotation's angle
        step = np.linalg.norm(np.diff(six[..., half], axis=0), axis=-1)
        assert np.all(step <= phi[:, idx] + 1e-12)


def _check_euler(f, names, motion, phi):
    sk = motion.skeleton
    for j, order in enumerate(sk.rotation_orders):
        if len(order) != 3:
            continue
        a = f[:, [names.index(f"{sk.names[j]}/{c}rotation") for c in order]]  # degrees
        step = np.abs(np.diff(a, axis=0))
        dphi = np.rad2deg(phi[:, j])
        cos_mid = np.abs(np.cos(np.deg2rad(a[:, 1])))
        secant = 1.0 / np.maximum(np.minimum(cos_mid[:-1], cos_mid[1:]), 1e-12)
        # first order: |d middle| <= |angular step|, |d first|, |d last| <= |angular step| / |cos middle|;
        # a factor 2 covers the change of the middle angle within one frame step.
        assert np.all(step[:, 1] <= 2 * dphi + 1e-9), f"{sk.names[j]}: middle angle jumps"
        assert np.all(step[:, [0, 2]] <= 2 * (dphi * secant)[:, None] + 1e-9), f"{sk.names[j]}: angle wraps"


_CONTINUITY = {"root-quat-axis-angle": _check_rootquat, "dual-quaternion": _check_dualquat,
               "ortho6d": _check_ortho6d, "euler": _check_euler}


@pytest.mark.parametrize("path", real_params())
def test_real_clip_round_trip_and_continuity(reps, path):
    motion = read_bvh(path)
    sk = motion.skeleton
    scale = character_height(sk)
    reference = global_positions(motion)
    phi = _step_angle(motion.rotations)  # the clip's own angular step per frame and joint
    for name, rep in reps.items():
        f = rep.to_features(motion)
        names = rep.feature_names(sk)
        assert f.shape == (motion.num_frames, rep.width(sk)) == (motion.num_frames, len(names))
        decoded = rep.from_features(f, sk, motion.fps)
        err = np.linalg.norm(global_positions(decoded) - reference, axis=-1).max()
        assert err <= 1e-6 * scale, f"{name}: round trip error {err:g} > 1e-6 x height {scale:g}"
        np.testing.assert_array_equal(decoded.joint_translations, motion.joint_translations)
        np.testing.assert_array_equal(decoded.root_translation, motion.root_translation)
        if motion.num_frames > 1:
            _CONTINUITY[name](f, names, motion, phi)
        if name == "euler":
            _check_euler_is_the_files_own_channels(f, names, motion)


def _check_euler_is_the_files_own_channels(f, names, motion):
    """Wherever a joint's channels in the file are continuous, the euler features are the file's values (up to
    full turns); elsewhere (a switch of Euler solution near gimbal lock) the features stay continuous."""
    sk = motion.skeleton
    values = channel_values(motion)
    start = np.cumsum([0] + [len(c) for c in sk.channels])
    compared = 0
    for j, channels in enumerate(sk.channels):
        rot = [k for k, c in enumerate(channels) if c.endswith("rotation")]
        if not rot:
            continue
        file_values = values[:, start[j] + np.array(rot)]
        feature = f[:, [names.index(f"{sk.names[j]}/{channels[k]}") for k in rot]]
        wrapped_steps = (np.diff(file_values, axis=0) + 180.0) % 360.0 - 180.0
        if np.all(np.abs(wrapped_steps) < 45.0):
            diff = (feature - file_values + 180.0) % 360.0 - 180.0
            np.testing.assert_allclose(diff, 0.0, atol=1e-9, err_msg=sk.names[j])
            compared += 1
    assert compared > 0




# ---- layouts and weights ---------------------------------------------------------------------------------
def test_column_names_follow_the_documented_layout(reps):
    sk = odd_skeleton()  # root (ZXY, no position), x_only (X), zy (ZY), fixed (none), slider (6 channels),
    #                      piston (position only), tip (YZX)
    T = ["tx", "ty", "tz"]

    def names(*blocks):
        return [f"{j}/{s}" for j, suffixes in blocks for s in suffixes]

    aa = ["aa_x", "aa_y", "aa_z"]
    assert reps["root-quat-axis-angle"].feature_names(sk) == names(
        ("root", T), ("root", ["qx", "qy", "qz", "qw"]), ("x_only", aa), ("zy", aa), ("slider", aa),
        ("slider", T), ("piston", T), ("tip", aa))
    six = ["m00", "m10", "m20", "m01", "m11", "m21"]
    assert reps["ortho6d"].feature_names(sk) == names(
        ("root", T), ("root", six), ("x_only", six), ("zy", six), ("slider", six), ("slider", T),
        ("piston", T), ("tip", six))
    assert reps["euler"].feature_names(sk) == names(
        ("root", T), ("root", ["Zrotation", "Xrotation", "Yrotation"]), ("x_only", ["Xrotation"]),
        ("zy", ["Zrotation", "Yrotation"]), ("slider", ["Yrotation", "Xrotation", "Zrotation"]), ("slider", T),
        ("piston", T), ("tip", ["Yrotation", "Zrotation", "Xrotation"]))
    dq = ["real_x", "real_y", "real_z", "real_w", "dual_x", "dual_y", "dual_z", "dual_w"]
    assert reps["dual-quaternion"].feature_names(sk) == names(
        ("root", T), ("root", dq), ("x_only", dq), ("zy", dq), ("fixed", dq), ("slider", dq), ("slider", T),
        ("piston", dq), ("piston", T), ("tip", dq))
    for rep in reps.values():
        assert rep.width(sk) == len(rep.feature_names(sk))


def _rest_chain():
    """A 4-joint chain along +Y (bones of 10, end site 10) in its rest pose at frame 0, then moving."""
    sk = chain_skeleton(4)
    m = synthetic_motion(sk, frames=10, seed=3)
    rot = m.rotations.copy()
    rot[0] = (0.0, 0.0, 0.0, 1.0)
    return m.replace(rotations=rot)


def test_weights_follow_tojo_eq3(reps):
    m = _rest_chain()
    reach = [40.0, 30.0, 20.0, 10.0]  # distance to the farthest descendant, end site included
    np.testing.assert_allclose(joint_reach(m), reach)
    np.testing.assert_allclose(reps["root-quat-axis-angle"].weights(m),
                               [1, 1, 1] + [40] * 4 + [30] * 3 + [20] * 3 + [10] * 3)
    np.testing.assert_allclose(reps["ortho6d"].weights(m), [1, 1, 1] + [r for r in reach for _ in range(6)])
    np.testing.assert_allclose(reps["euler"].weights(m),
                               [1, 1, 1] + [r * np.pi / 180 for r in reach for _ in range(3)])
    # dual quaternion: real part = longest bone to a direct child, dual part = 1
    np.testing.assert_allclose(reps["dual-quaternion"].weights(m), [1, 1, 1] + ([10] * 4 + [1] * 4) * 4)


def test_weights_of_translation_columns_and_joints_without_rotation(reps):
    m = synthetic_motion(odd_skeleton(), frames=5)
    for name, rep in reps.items():
        w = rep.weights(m)
        names = rep.feature_names(m.skeleton)
        for n, wn in zip(names, w):
            if n.endswith(("/tx", "/ty", "/tz")) or "/dual_" in n:
                assert wn == 1.0, (name, n)
        if name == "dual-quaternion":  # 'fixed' has no rotation channels: its real part is never decoded
            assert all(wn == 0.0 for n, wn in zip(names, w) if n.startswith("fixed/real"))


def test_weighted_feature_error_is_about_a_position_error(reps):
    """w * (feature error) approximates the joint-position error for a small change of one rotation."""
    m = _rest_chain().frames(slice(0, 1))
    for name in ("root-quat-axis-angle", "ortho6d", "euler"):
        rep = reps[name]
        f = rep.to_features(m)
        w = rep.weights(m)
        col = rep.feature_names(m.skeleton).index({"root-quat-axis-angle": "j1/aa_x", "ortho6d": "j1/m21",
                                                     "euler": "j1/Zrotation"}[name])
        g = f.copy()
        g[0, col] += 1e-4 * (180 / np.pi if name == "euler" else 1.0)
        moved = np.linalg.norm(global_positions(rep.from_features(g, m.skeleton, m.fps)) - global_positions(m),
                               axis=-1).max()
        assert moved == pytest.approx(w[col] * abs(g[0, col] - f[0, col]), rel=0.05), name


# ---- specific behaviour ------------------------------------------------------------------------------------
def test_rootquat_decoding_normalises_the_root_quaternion(reps):
    rep = reps["root-quat-axis-angle"]
    m = synthetic_motion(frames=10)
    f = rep.to_features(m)
    g = f.copy()
    g[:, 3:7] *= 3.0
    np.testing.assert_allclose(global_positions(rep.from_features(g, m.skeleton, m.fps)), global_positions(m),
                               atol=1e-9)
    g[4, 3:7] = 0.0
    with pytest.raises(ValidationError):
        rep.from_features(g, m.skeleton, m.fps)


def test_rootquat_first_frame_and_values(reps):
    rep = reps["root-quat-axis-angle"]
    sk = chain_skeleton(3)
    q_root = axis_angle_to_quat([0.0, 2.5, 0.0])
    q_root = -q_root if q_root[3] > 0 else q_root  # input with w < 0
    rot = np.array([[q_root, axis_angle_to_quat([0.3, 0.0, 0.0]), axis_angle_to_quat([0.0, 0.0, -0.2])]])
    m = Motion(sk, 30.0, np.zeros((1, 3)), rot)
    f = rep.to_features(m)[0]
    np.testing.assert_allclose(f[3:7], -q_root)  # frame 0: w >= 0
    np.testing.assert_allclose(f[7:10], [0.3, 0.0, 0.0])
    np.testing.assert_allclose(f[10:13], [0.0, 0.0, -0.2])


def test_euler_degrees_branch_and_decoded_branch(reps):
    rep = reps["euler"]
    sk = chain_skeleton(2, orders=("ZXY", "ZXY"))
    angles = np.array([[30.0, 20.0, 10.0], [30.0, 25.0, 12.0]])
    rot = np.stack([euler_to_quat(angles, "ZXY", degrees=True)] * 2, axis=1)
    m = Motion(sk, 30.0, np.zeros((2, 3)), rot)
    np.testing.assert_allclose(rep.to_features(m)[:, 3:6], angles, atol=1e-9)
    # the file used the other solution at frame 0: features follow it for the whole clip
    branch = np.ones((2, 2), bool)
    f = rep.to_features(m.replace(euler_branch=branch))
    other = np.stack([angles[:, 0] + 180.0, 180.0 - angles[:, 1], angles[:, 2] + 180.0], axis=-1)
    other -= 360.0 * np.floor((other[:1] + 180.0) / 360.0)
    np.testing.assert_allclose(f[:, 3:6], other, atol=1e-9)
    decoded = rep.from_features(f, sk, m.fps)
    assert decoded.euler_branch.all()
    np.testing.assert_allclose(global_positions(decoded), global_positions(m), atol=1e-9)


def test_joints_without_rotation_channels_decode_to_identity(reps):
    m = synthetic_motion(odd_skeleton(), frames=8)
    fixed = m.skeleton.index("fixed")
    for rep in reps.values():
        f = rep.to_features(m)
        noisy = f + np.random.default_rng(1).normal(size=f.shape) * 1e-2
        decoded = rep.from_features(noisy, m.skeleton, m.fps)
        np.testing.assert_allclose(decoded.rotations[:, fixed], np.tile([0.0, 0.0, 0.0, 1.0], (8, 1)))


# ---- dual quaternions -----------------------------------------------------------------------------------------
def _transform_points(dq, p):
    from motionrep_dualquat import dualquat_to_rotation_translation

    q, t = dualquat_to_rotation_translation(dq)
    return (quat_to_matrix(q) @ p[..., None])[..., 0] + t


def test_dualquat_algebra_matches_rigid_transforms():
    from motionrep_dualquat import (dualquat_conjugate, dualquat_from_rotation_translation, dualquat_multiply,
                                    dualquat_normalize, dualquat_to_rotation_translation)

    rng = np.random.default_rng(0)
    qa, qb = random_unit_quaternions((5, 3), seed=1), random_unit_quaternions((5, 3), seed=2)
    ta, tb = rng.normal(size=(5, 3, 3)) * 10, rng.normal(size=(5, 3, 3)) * 10
    a = dualquat_from_rotation_translation(qa, ta)
    b = dualquat_from_rotation_translation(qb, tb)
    q, t = dualquat_to_rotation_translation(a)
    np.testing.assert_allclose(q, qa)
    np.testing.assert_allclose(t, ta, atol=1e-12)
    p = rng.normal(size=(5, 3, 3))
    # a b applies b, then a
    np.testing.assert_allclose(_transform_points(dualquat_multiply(a, b), p),
                               _transform_points(a, _transform_points(b, p)), atol=1e-9)
    identity = np.array([0, 0, 0, 1, 0, 0, 0, 0], float)
    np.testing.assert_allclose(dualquat_multiply(a, dualquat_conjugate(a)), np.broadcast_to(identity, a.shape),
                               atol=1e-12)
    # eq. 13: unit conditions |q_r| = 1 and <q_r, q_d> = 0; idempotent; the identity on unit dual quaternions
    raw = rng.normal(size=(7, 8))
    n = dualquat_normalize(raw)
    np.testing.assert_allclose(np.linalg.norm(n[:, :4], axis=-1), 1.0)
    np.testing.assert_allclose(np.sum(n[:, :4] * n[:, 4:], axis=-1), 0.0, atol=1e-12)
    np.testing.assert_allclose(dualquat_normalize(n), n, atol=1e-12)
    np.testing.assert_allclose(dualquat_normalize(a), a, atol=1e-12)
    with pytest.raises(ValidationError):
        dualquat_normalize(np.zeros(8))
    with pytest.raises(ValidationError):
        dualquat_multiply(np.zeros(7), np.zeros(8))


def test_dualquat_decodes_unit_rotations_on_a_deep_chain():
    # Each world rotation is its own normalised real part: the decoder once rebuilt it as G_parent (G_parent* r),
    # |G_parent|^2 r, which doubled the norm error at every level (5e-9 on a 42-joint BVH, overflow at 60 deep).
    # Two joints without rotation channels in the chain take their parent's world rotation.
    orders = tuple("" if j in (20, 41) else ("ZXY", "YXZ", "XYZ")[j % 3] for j in range(60))
    m = synthetic_motion(chain_skeleton(60, orders), frames=40, seed=3)
    rep = plugins.get_representation("dual-quaternion")
    decoded = rep.from_features(rep.to_features(m), m.skeleton, m.fps)
    # tolerances: a handful of roundings in the normalisation and one quaternion product per joint
    np.testing.assert_allclose(np.linalg.norm(decoded.rotations, axis=-1), 1.0, rtol=0, atol=1e-12)
    sign = np.where(np.sum(decoded.rotations * m.rotations, axis=-1, keepdims=True) < 0, -1.0, 1.0)
    np.testing.assert_allclose(sign * decoded.rotations, m.rotations, rtol=0, atol=1e-12)


def test_dualquat_make_continuous_follows_the_real_part():
    from motionrep_dualquat import dualquat_make_continuous

    # a real part barely turning while the dual part swings through zero (a foot passing the root in cm):
    # the 8-D distance would flip the real part; the real part's own continuity must win
    real = np.array([[0.0, 0.0, 0.0, 1.0], [0.0, 0.01, 0.0, 1.0]])
    real /= np.linalg.norm(real, axis=-1, keepdims=True)
    dual = np.array([[5.0, 0.0, 0.0, 0.0], [-5.0, 0.0, 0.0, 0.0]])
    dq = np.concatenate([real, dual], axis=-1)
    flipped = dq.copy()
    flipped[1] *= -1
    out = dualquat_make_continuous(flipped)
    np.testing.assert_allclose(out, dq)


def test_dualquat_features_are_current_coordinates(reps):
    rep = reps["dual-quaternion"]
    m = spinning_motion(humanoid_skeleton(), frames=30)
    f = rep.to_features(m)
    sk = m.skeleton
    lay_cols = np.array([[rep.feature_names(sk).index(f"{j}/{c}") for c in
                          ("real_x", "real_y", "real_z", "real_w", "dual_x", "dual_y", "dual_z", "dual_w")]
                         for j in sk.names])
    dq = f[:, lay_cols]
    fk = forward_kinematics(m)
    world = fk.rotations[:, :sk.num_joints]
    np.testing.assert_allclose(np.abs(np.sum(dq[..., :4] * world, axis=-1)), 1.0, atol=1e-9)  # same rotation
    np.testing.assert_allclose(dq[:, 0, 4:], 0.0, atol=1e-12)  # the root's translation is zeroed
    implied = _transform_points(dq, np.zeros((m.num_frames, sk.num_joints, 3)))
    np.testing.assert_allclose(implied, fk.positions[:, :sk.num_joints] - fk.positions[:, :1], atol=1e-9)
    assert dq[0, :, 3].min() >= 0  # frame 0: real w >= 0


def test_dual_part_offset_error(reps):
    from motionrep_dualquat import dual_part_offset_error, dual_part_offsets

    rep = reps["dual-quaternion"]
    m = synthetic_motion(odd_skeleton(), frames=15)
    sk = m.skeleton
    f = rep.to_features(m)
    lossless = dual_part_offset_error(f, sk)
    assert lossless.max_error < 1e-10 and lossless.mean_error <= lossless.max_error
    expected = m.local_translations()
    np.testing.assert_allclose(dual_part_offsets(f, sk)[:, 1:], expected[:, 1:], atol=1e-10)
    # move the dual part of 'zy' by eps orthogonally to its real part: its implied position moves by exactly
    # 2 eps (t = 2 q_d q_r*), so its own offset and its child's are off by 2 eps; nothing else changes
    names = rep.feature_names(sk)
    real = f[:, [names.index(f"zy/real_{c}") for c in "xyzw"]]
    dual_cols = [names.index(f"zy/dual_{c}") for c in "xyzw"]
    eps = 0.25
    g = f.copy()
    g[:, dual_cols] += eps * quat_multiply(real, [0.0, 0.0, 1.0, 0.0])
    report = dual_part_offset_error(g, sk)
    assert report.max_error == pytest.approx(2 * eps, rel=1e-9)
    assert report.joint in ("zy", "fixed")
    assert report.mean_error == pytest.approx(2 * 2 * eps / (sk.num_joints - 1), rel=1e-9)
    # the decoded motion does not notice
    np.testing.assert_allclose(global_positions(rep.from_features(g, sk, m.fps)), global_positions(m), atol=1e-9)
    with pytest.raises(ValidationError):
        dual_part_offset_error(f[:, :-1], sk)


@pytest.mark.parametrize("path", real_params("cmu/pybvh"))
def test_dual_part_offset_error_after_a_lossy_round_trip(reps, path):
    """After a lossy round trip (truncated SVD of the weighted features) the implied offsets drift, by an amount
    of the order of the FK error; the diagnostic reports it, and where."""
    from motionrep_dualquat import dual_part_offset_error

    rep = reps["dual-quaternion"]
    m = read_bvh(path)
    scale = character_height(m.skeleton)
    f, w = rep.to_features(m), rep.weights(m)
    ws = np.where(w > 0, w, 1.0)
    mean = f.mean(axis=0)
    u, s, vt = np.linalg.svd((f - mean) * ws, full_matrices=False)
    lossy = (u[:, :32] * s[:32]) @ vt[:32] / ws + mean
    fk_error = np.linalg.norm(global_positions(rep.from_features(lossy, m.skeleton, m.fps)) - global_positions(m),
                              axis=-1).max()
    report = dual_part_offset_error(lossy, m.skeleton)
    assert 1e-4 * scale < report.max_error < 10 * max(fk_error, 1e-3 * scale)
    assert 0 < report.mean_error < report.max_error
    assert report.joint in m.skeleton.names and 0 <= report.frame < m.num_frames


# ---- command line ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", [".npz", ".h5"])
@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_convert_stores_features_and_decodes_them(reps, tmp_path, name, suffix):
    m = synthetic_motion(humanoid_skeleton(), frames=30)
    src = tmp_path / "walk.bvh"
    write(m, src)
    original = read(src)
    stored = tmp_path / f"walk{suffix}"
    result = run_cli_caught("convert", str(src), str(stored), "--representation", name)
    assert result.exit_code == 0, result.output
    clip = read_features(stored)
    assert clip.representation == name and clip.representation_version == reps[name].version
    assert clip.skeleton == original.skeleton
    np.testing.assert_array_equal(clip.features, reps[name].to_features(original))
    assert list(clip.feature_names) == reps[name].feature_names(original.skeleton)
    back = tmp_path / "walk2.bvh"
    result = run_cli_caught("convert", str(stored), str(back))
    assert result.exit_code == 0, result.output
    err = np.linalg.norm(global_positions(read(back)) - global_positions(original), axis=-1).max()
    assert err <= 1e-6 * character_height(original.skeleton)


@pytest.mark.parametrize("path", real_params("cmu/pybvh"))
def test_convert_real_clip_through_dual_quaternions(reps, tmp_path, path):
    original = read_bvh(path)
    for suffix in (".npz", ".h5"):
        stored = tmp_path / f"walk{suffix}"
        back = tmp_path / f"walk2{suffix}.bvh"
        assert run_cli_caught("convert", str(path), str(stored), "--representation",
                                   "dual-quaternion").exit_code == 0
        assert run_cli_caught("convert", str(stored), str(back)).exit_code == 0
        err = np.linalg.norm(global_positions(read(back)) - global_positions(original), axis=-1).max()
        assert err <= 1e-6 * character_height(original.skeleton)


def test_unknown_representation_is_a_one_line_error(reps, tmp_path):
    src = tmp_path / "walk.bvh"
    write(synthetic_motion(frames=3), src)
    result = run_cli_caught("convert", str(src), str(tmp_path / "x.npz"), "--representation", "quatz")
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "unknown representation 'quatz'" in lines[0]
    for name in SHIPPED:
        assert name in lines[0]
    assert not (tmp_path / "x.npz").exists()


@pytest.mark.parametrize("suffix", [".npz", ".h5"])
def test_features_of_the_wrong_width_are_a_one_line_error(reps, tmp_path, suffix):
    m = synthetic_motion(frames=4)
    rep = reps["dual-quaternion"]
    f = rep.to_features(m)
    bad = FeatureClip(m.skeleton, m.fps, rep.name, rep.version, f[:, :-1], tuple(rep.feature_names(m.skeleton))[:-1])
    path = tmp_path / f"bad{suffix}"
    write_features(bad, path)
    out = tmp_path / "out.bvh"
    result = run_cli_caught("convert", str(path), str(out))
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1
    assert str(path) in lines[0] and "'dual-quaternion'" in lines[0] and f"(4, {f.shape[1] - 1})" in lines[0]
    assert not out.exists()
    with pytest.raises(ValidationError, match=r"expects features of shape \(frames, \d+\)"):
        rep.from_features(f[:, :-1], m.skeleton, m.fps)


def test_per_skeleton_remembers_the_last_skeleton_by_identity():
    from motionrep.plugin.representation import per_skeleton

    calls = []

    @per_skeleton
    def build(skeleton):
        calls.append(skeleton)
        return len(calls)

    a, b = humanoid_skeleton(), humanoid_skeleton()
    assert a == b and a is not b
    assert [build(a), build(a), build(b), build(b), build(a)] == [1, 1, 2, 2, 3]
    assert calls == [a, b, a]
    assert build.__name__ == "build"


@pytest.mark.parametrize("name", sorted(SHIPPED))
@pytest.mark.parametrize("make_skeleton", [humanoid_skeleton, odd_skeleton])
def test_decoding_one_pose_at_a_time_matches_decoding_the_clip(name, make_skeleton):
    # the per-skeleton decode plan is built on the first call and reused, also for another skeleton in between
    rep = plugins.get_representation(name)
    sk = make_skeleton()
    motion = synthetic_motion(sk, frames=12, seed=3)
    f = rep.to_features(motion)
    whole = rep.from_features(f, sk, motion.fps)
    other = chain_skeleton()
    for i in (0, 5, 11):
        one = rep.from_features(f[i:i + 1], sk, motion.fps)
        rep.from_features(rep.to_features(synthetic_motion(other, frames=2)), other, 30.0)
        np.testing.assert_allclose(one.rotations[0], whole.rotations[i], atol=1e-15)
        np.testing.assert_array_equal(one.root_translation[0], whole.root_translation[i])
        np.testing.assert_array_equal(one.joint_translations[0], whole.joint_translations[i])
