"""Forward kinematics against an independent computation (scipy Rotation chained joint by joint in a plain
loop), analytic poses, and character height."""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from motionrep import Motion, Skeleton
from motionrep.io import read_bvh
from motionrep.model.kinematics import (
    character_height,
    forward_kinematics,
    global_positions,
    point_names,
    quat_to_matrix_fast,
    rest_positions,
)
from motionrep.model.rotations import euler_to_quat, matrix_to_quat
from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, random_unit_quaternions, synthetic_motion

from helpers import SHARED_DATA, real_params, requires_shared


def reference_fk(motion: Motion):
    """World positions (F, J + E, 3) and world rotations (list of scipy Rotations, joints then end sites),
    computed joint by joint with scipy, independently of motionrep.model.kinematics."""
    sk = motion.skeleton
    F, J = motion.num_frames, sk.num_joints
    local = np.broadcast_to(sk.offsets, (F, J, 3)).copy()
    local[:, 0] = motion.root_translation
    for k, j in enumerate(sk.translated_joints):
        local[:, j] = motion.joint_translations[:, k]
    world_rot: list[Rotation] = []
    world_pos = np.zeros((F, J, 3))
    for j in range(J):
        r = Rotation.from_quat(np.array(motion.rotations[:, j]))
        p = int(sk.parents[j])
        if p < 0:
            world_rot.append(r)
            world_pos[:, j] = local[:, j]
        else:
            world_rot.append(world_rot[p] * r)
            world_pos[:, j] = world_pos[:, p] + world_rot[p].apply(local[:, j])
    sites = []
    for p, off in zip(sk.end_site_parents.tolist(), sk.end_site_offsets):
        sites.append(world_pos[:, p] + world_rot[p].apply(np.array(off)))
        world_rot.append(world_rot[p])
    if sites:
        world_pos = np.concatenate([world_pos, np.stack(sites, axis=1)], axis=1)
    return world_pos, world_rot


def check_against_reference(motion: Motion, rotations_too: bool = True) -> None:
    height = character_height(motion.skeleton)
    scale = max(height, 1e-12)
    ref_pos, ref_rot = reference_fk(motion)
    pos = global_positions(motion)
    assert pos.shape == ref_pos.shape
    err = np.abs(pos - ref_pos).max() / scale
    assert err <= 1e-9, f"FK differs from the scipy chain by {err:.3g} x height"
    if rotations_too:
        fk = forward_kinematics(motion)
        np.testing.assert_array_equal(fk.positions, pos)
        want = np.stack([r.as_matrix() for r in ref_rot], axis=1)
        np.testing.assert_allclose(fk.matrices, want, atol=1e-12)
        q = fk.rotations
        assert q.shape == pos.shape[:2] + (4,)
        np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-12)
        assert np.all(q[..., 3] >= 0)
        d = np.minimum(np.abs(q - np.stack([r.as_quat() for r in ref_rot], axis=1)).max(-1),
                       np.abs(q + np.stack([r.as_quat() for r in ref_rot], axis=1)).max(-1))
        assert d.max() <= 1e-12


@pytest.mark.parametrize("path", real_params())
def test_fk_matches_scipy_chain_on_real_files(path):
    motion = read_bvh(path)
    check_against_reference(motion, rotations_too=motion.num_frames * motion.num_joints < 40000)


@pytest.mark.parametrize("order", ["ZXY", "XYZ", "YZX", "ZYX", "XZY", "YXZ"])
def test_fk_matches_scipy_chain_on_generated_motions(order):
    check_against_reference(synthetic_motion(humanoid_skeleton(order), frames=60, seed=ord(order[0])))


def test_fk_generated_edge_skeletons():
    # position channels on non-root joints (before and after rotations, partial), a joint without channels,
    # one- and two-axis joints, several end sites on one joint, joints not in depth-first order
    sk = Skeleton(
        names=("hips", "a", "b", "c", "d", "e"),
        parents=[-1, 0, 0, 1, 3, 2],
        offsets=[[1, 2, 3], [0, 10, 0], [5, 0, 0], [0, 7, 1], [0, 0, 4], [2, 2, 2]],
        channels=(("Xrotation", "Yrotation", "Zrotation", "Xposition", "Yposition", "Zposition"),
                  ("Yposition", "Zrotation", "Xrotation"),
                  (),
                  ("Xrotation",),
                  ("Zrotation", "Yrotation", "Xposition", "Yposition", "Zposition"),
                  ("Yrotation", "Zrotation", "Xrotation")),
        end_site_parents=[4, 4, 5, 0],
        end_site_offsets=[[0, 1, 0], [1, 0, 0], [0, 0, 3], [0, -5, 0]],
    )
    F = 700
    rng = np.random.default_rng(3)
    rot = random_unit_quaternions((F, 6), seed=4)
    rot[:, 2] = (0, 0, 0, 1)
    rot[:, 3] = euler_to_quat(rng.uniform(-180, 180, (F, 1)), "X", degrees=True)
    m = Motion(sk, 30.0, rng.normal(size=(F, 3)), rot, rng.normal(size=(F, 2, 3)) * 3)
    check_against_reference(m)


def test_fk_spans_several_chunks():
    sk = chain_skeleton(40)
    m = synthetic_motion(sk, frames=4000, seed=1)  # 160000 joint-frames: three chunks
    check_against_reference(m, rotations_too=False)


def test_fk_analytic_poses():
    # the root turns 90 degrees about Z: a child 10 up the Y axis lands 10 along -X
    sk = Skeleton(("root", "child"), [-1, 0], [[0, 0, 0], [0, 10, 0]],
                  end_site_parents=[1], end_site_offsets=[[0, 5, 0]])
    rot = np.zeros((2, 2, 4))
    rot[..., 3] = 1.0
    rot[1, 0] = euler_to_quat([90.0], "Z", degrees=True)
    rot[1, 1] = euler_to_quat([-90.0], "Z", degrees=True)  # and the child turns back
    m = Motion(sk, 30.0, [[0, 0, 0], [1, 2, 3]], rot)
    pos = global_positions(m)
    np.testing.assert_allclose(pos[0], [[0, 0, 0], [0, 10, 0], [0, 15, 0]], atol=1e-12)
    np.testing.assert_allclose(pos[1], [[1, 2, 3], [-9, 2, 3], [-9, 7, 3]], atol=1e-12)
    fk = forward_kinematics(m)
    np.testing.assert_allclose(fk.matrices[1, 0], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)
    np.testing.assert_allclose(fk.matrices[1, 1], np.eye(3), atol=1e-15)
    np.testing.assert_allclose(fk.matrices[1, 2], np.eye(3), atol=1e-15)  # an end site has its joint's rotation
    np.testing.assert_allclose(fk.rotations[1, 0], matrix_to_quat(fk.matrices[1, 0]), atol=1e-15)


def test_fk_normalises_rotations():
    m = synthetic_motion(chain_skeleton(5), frames=10)
    stretched = m.rotations * (1.0 + 5e-7)  # within Motion's tolerance for unit length
    m2 = m.replace(rotations=stretched)
    np.testing.assert_allclose(global_positions(m2), global_positions(m), atol=1e-12)


def test_quat_to_matrix_fast_matches_scipy():
    q = random_unit_quaternions((7, 5), seed=2)
    np.testing.assert_allclose(quat_to_matrix_fast(q), Rotation.from_quat(q.reshape(-1, 4)).as_matrix()
                               .reshape(7, 5, 3, 3), atol=1e-15)


def test_point_names():
    sk = Skeleton(("r", "a"), [-1, 0], np.zeros((2, 3)), end_site_parents=[1, 1, 0],
                  end_site_offsets=np.ones((3, 3)))
    assert point_names(sk) == ("r", "a", "a/End Site 1", "a/End Site 2", "r/End Site")


# ---- character height ----------------------------------------------------------------------------------------
def test_character_height_hand_made():
    # rest pose: root at (0, 100, 0); spine up 50; head end site up 20 -> top at 170; a leg down 90 from the
    # root with a foot end site 8 further down -> bottom at 2; arms reach x = +-60; extent: y 168, x 120
    sk = Skeleton(
        names=("hips", "spine", "arm_l", "arm_r", "leg"),
        parents=[-1, 0, 1, 1, 0],
        offsets=[[0, 100, 0], [0, 50, 0], [20, 0, 0], [-20, 0, 0], [0, -90, 0]],
        channels=(("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"),
                  ("Xposition", "Yposition", "Zposition", "Zrotation"), ("Zrotation",), ("Zrotation",), ()),
        end_site_parents=[1, 2, 3, 4],
        end_site_offsets=[[0, 20, 0], [40, 0, 0], [-40, 0, 0], [0, -8, 3]],
    )
    rest = rest_positions(sk)
    np.testing.assert_allclose(rest[[0, 1, 4]], [[0, 100, 0], [0, 150, 0], [0, 10, 0]])
    np.testing.assert_allclose(rest[5:], [[0, 170, 0], [60, 150, 0], [-60, 150, 0], [0, 2, 3]])
    assert character_height(sk) == pytest.approx(168.0)
    # a wider character: the largest extent over the three axes wins
    wide = sk.replace(end_site_offsets=[[0, 20, 0], [150, 0, 0], [-40, 0, 0], [0, -8, 3]])
    assert character_height(wide) == pytest.approx(230.0)  # x from -60 to 170
    # position channels are not applied: animating them does not change the height
    F = 3
    rot = np.zeros((F, 5, 4))
    rot[..., 3] = 1.0
    m = Motion(sk, 30.0, np.zeros((F, 3)), rot, np.full((F, 1, 3), 1000.0))
    assert character_height(m.skeleton) == pytest.approx(168.0)
    assert character_height(Skeleton(("only",), [-1], [[1, 2, 3]])) == 0.0


def _offsets_from_text(path) -> np.ndarray:
    """Rest positions of a BVH file computed from its text alone (brace depth and OFFSET lines)."""
    stack: list[np.ndarray] = []
    points = []
    pending = None
    for line in path.read_text().splitlines():
        words = line.split()
        if not words:
            continue
        if words[0] == "MOTION":
            break
        if words[0] == "OFFSET":
            pending = np.array([float(w) for w in words[1:4]])
            base = stack[-1] if stack else np.zeros(3)
            stack.append(base + pending)
            points.append(stack[-1])
        elif words[0] == "}":
            stack.pop()
    return np.array(points)


@requires_shared
@pytest.mark.realdata
@pytest.mark.parametrize("name", ["dataset-1_bow_active_001.bvh", "dataset-1_dash_normal_001.bvh"])
def test_character_height_with_position_channels_on_every_joint(name):
    path = SHARED_DATA / "other" / "bandai_namco" / name
    motion = read_bvh(path)
    sk = motion.skeleton
    assert all(axes == "XYZ" for axes in sk.position_axes)  # 6 channels on every joint
    text = path.read_text()
    assert len(re.findall(r"\bOFFSET\b", text)) == sk.num_joints + sk.num_end_sites
    points = _offsets_from_text(path)
    want = float(np.max(points.max(axis=0) - points.min(axis=0)))
    assert character_height(sk) == pytest.approx(want, rel=1e-12)
    assert want > 100.0  # a person in centimetres, not collapsed to a point
    # applying the position channels instead would give another (per-frame) size
    pos = global_positions(motion)
    assert np.all(np.isfinite(pos))
