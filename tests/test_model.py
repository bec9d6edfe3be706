"""Skeleton and Motion: every validation path raises ValidationError quoting what was wrong; derived facts."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from motionrep import Motion, Skeleton
from motionrep.model._pose import DEFAULT_JOINT_CHANNELS, DEFAULT_ROOT_CHANNELS
from motionrep.errors import MotionrepError, ValidationError
from motionrep.model.rotations import euler_to_quat
from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, synthetic_motion


def three_joints(**changes) -> Skeleton:
    fields = dict(names=("root", "a", "b"), parents=[-1, 0, 1], offsets=[[0, 0, 0], [0, 1, 0], [0, 2, 0]])
    fields.update(changes)
    return Skeleton(**fields)


def identity_motion(sk: Skeleton, frames: int = 2, **changes) -> Motion:
    rot = np.zeros((frames, sk.num_joints, 4))
    rot[..., 3] = 1.0
    fields = dict(skeleton=sk, fps=30.0, root_translation=np.zeros((frames, 3)), rotations=rot)
    fields.update(changes)
    return Motion(**fields)


# ---- Skeleton ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("changes, quoted", [
    (dict(names="root"), "sequence of strings"),
    (dict(names=("root", 5, "b")), "sequence of strings"),
    (dict(names=(), parents=[], offsets=np.zeros((0, 3))), "at least one joint"),
    (dict(names=("root", "", "b")), "invalid joint name ''"),
    (dict(names=("root", " a", "b")), "invalid joint name ' a'"),
    (dict(names=("root", "a{", "b")), "invalid joint name 'a{'"),
    (dict(names=("root", "a\tb", "b")), "invalid joint name 'a\\tb'"),
    (dict(names=("root", "a", "a")), "duplicate joint name 'a' (joints 1 and 2)"),
    (dict(parents=["x", 0, 1]), "parents must be integers"),
    (dict(parents=[-1, 0]), "parents must have shape (3,) for 3 names, got (2,)"),
    (dict(parents=[0, 0, 1]), "joint 0 ('root') must be the root (parent -1), got parent 0"),
    (dict(parents=[-1, 2, 0]), "joint 1 ('a') has parent 2"),
    (dict(parents=[-1, -1, 0]), "joint 1 ('a') has parent -1"),
    (dict(parents=[-1, 0, 2]), "joint 2 ('b') has parent 2"),
    (dict(offsets=[[0, 0, 0], [0, 1, 0]]), "offsets must have shape (3, 3), got (2, 3)"),
    (dict(offsets=[[0, 0, 0], [0, 1, 0], [0, 2]]), "offsets must be numeric"),
    (dict(offsets=[[0, 0, 0], [0, np.nan, 0], [0, 2, 0]]), "offsets must be finite, found nan at index (1, 1)"),
    (dict(offsets=[[0, 0, 0], [0, 1, 0], [np.inf, 2, 0]]), "offsets must be finite, found inf at index (2, 0)"),
    (dict(offsets="abc"), "offsets must be numeric"),
    (dict(channels=(DEFAULT_ROOT_CHANNELS, DEFAULT_JOINT_CHANNELS)), "channels must list 3 joints, got 2"),
    (dict(channels=(DEFAULT_ROOT_CHANNELS, ("Xrotation", "Wrotation"), ())),
     "joint 'a' has unknown channel 'Wrotation'"),
    (dict(channels=(DEFAULT_ROOT_CHANNELS, ("xrotation",), ())), "unknown channel 'xrotation'"),
    (dict(channels=(DEFAULT_ROOT_CHANNELS, ("Xrotation", "Yrotation", "Xrotation"), ())),
     "joint 'a' lists a channel twice: Xrotation Yrotation Xrotation"),
    (dict(end_site_parents=[3], end_site_offsets=[[0, 1, 0]]), "end_site_parents must index joints 0..2, got [3]"),
    (dict(end_site_parents=[-1], end_site_offsets=[[0, 1, 0]]), "end_site_parents must index joints 0..2, got [-1]"),
    (dict(end_site_parents=["x"], end_site_offsets=[[0, 1, 0]]), "end_site_parents must be integers"),
    (dict(end_site_parents=[2], end_site_offsets=[[0, 1]]), "end_site_offsets must have shape (1, 3), got (1, 2)"),
    (dict(end_site_parents=[2, 1], end_site_offsets=[[0, 1, 0]]), "end_site_offsets must have shape (2, 3)"),
    (dict(end_site_parents=[2], end_site_offsets=[[0, np.nan, 0]]), "end_site_offsets must be finite"),
    (dict(units=3), "units must be a string or None, got 3"),
])
def test_skeleton_validation_quotes_the_problem(changes, quoted):
    with pytest.raises(ValidationError) as info:
        three_joints(**changes)
    assert quoted in str(info.value)
    assert isinstance(info.value, (MotionrepError, ValueError))


def test_skeleton_index_of_missing_joint():
    with pytest.raises(ValidationError, match="no joint named 'nope' in this skeleton"):
        three_joints().index("nope")
    assert three_joints().index("b") == 2


def test_skeleton_defaults_and_derived_facts():
    sk = three_joints(end_site_parents=[2], end_site_offsets=[0, 3, 0])  # a flat list of E * 3 values
    assert sk.channels == (DEFAULT_ROOT_CHANNELS, DEFAULT_JOINT_CHANNELS, DEFAULT_JOINT_CHANNELS)
    assert sk.rotation_orders == ("ZXY", "ZXY", "ZXY")
    assert sk.position_axes == ("XYZ", "", "")
    assert sk.num_channels == 12
    assert sk.translated_joints.tolist() == []
    assert sk.rotated_joints.tolist() == [0, 1, 2]
    assert sk.children == ((1,), (2,), ())
    assert sk.depths.tolist() == [0, 1, 2]
    assert sk.end_site_offsets.tolist() == [[0.0, 3.0, 0.0]]
    assert sk.num_end_sites == 1 and sk.num_joints == 3
    # arrays are read-only copies: changing the input afterwards changes nothing
    offsets = np.array([[0.0, 0, 0], [0, 1, 0], [0, 2, 0]])
    sk2 = three_joints(offsets=offsets)
    offsets[1, 1] = 99.0
    assert sk2.offsets[1, 1] == 1.0
    with pytest.raises(ValueError):
        sk2.offsets[0, 0] = 1.0


def test_skeleton_mixed_layouts():
    sk = three_joints(channels=(("Zrotation", "Xposition", "Yrotation"), ("Yposition",), ()))
    assert sk.rotation_orders == ("ZY", "", "")
    assert sk.position_axes == ("X", "Y", "")
    assert sk.translated_joints.tolist() == [1]
    assert sk.rotated_joints.tolist() == [0]
    assert sk.num_channels == 4


def test_skeleton_equality_and_replace():
    a, b = three_joints(), three_joints()
    assert a == b and a.same_structure(b)
    c = a.replace(offsets=[[0, 0, 0], [0, 1, 0], [0, 5, 0]])
    assert c != a and c.same_structure(a)
    with pytest.raises(ValidationError, match="duplicate joint name"):
        a.replace(names=("root", "b", "b"))
    with pytest.raises(TypeError):
        hash(a)


# ---- Motion --------------------------------------------------------------------------------------------------
def test_motion_validation_quotes_the_problem():
    sk = three_joints()
    cases = [
        (dict(skeleton="x"), "skeleton must be a Skeleton, got str"),
        (dict(fps="fast"), "fps must be a number, got 'fast'"),
        (dict(fps=0.0), "fps must be finite and > 0, got 0.0"),
        (dict(fps=-30), "fps must be finite and > 0, got -30"),
        (dict(fps=float("inf")), "fps must be finite and > 0, got inf"),
        (dict(fps=float("nan")), "fps must be finite and > 0, got nan"),
        (dict(rotations=np.zeros((2, 2, 4))), "rotations must have shape (?, 3, 4), got (2, 2, 4)"),
        (dict(rotations=np.zeros((2, 3, 3))), "rotations must have shape (?, 3, 4), got (2, 3, 3)"),
        (dict(rotations=np.zeros((0, 3, 4)), root_translation=np.zeros((0, 3))), "at least one frame"),
        (dict(rotations=[[["a"] * 4] * 3] * 2), "rotations must be numeric"),
        (dict(root_translation=np.zeros((3, 3))), "root_translation must have shape (2, 3), got (3, 3)"),
        (dict(root_translation=[[0, 0, 0], [0, np.nan, 0]]),
         "root_translation must be finite, found nan at index (1, 1)"),
        (dict(joint_translations=np.zeros((2, 1, 3))), "joint_translations must have shape (2, 0, 3), got (2, 1, 3)"),
        (dict(euler_branch=np.zeros((2, 2), bool)), "euler_branch must be a (2, 3) bool array, got bool (2, 2)"),
        (dict(euler_branch=np.zeros((2, 3))), "euler_branch must be a (2, 3) bool array, got float64 (2, 3)"),
    ]
    for changes, quoted in cases:
        with pytest.raises(ValidationError) as info:
            identity_motion(sk, **changes)
        assert quoted in str(info.value), (changes, str(info.value))


def test_motion_rotations_must_be_unit():
    sk = three_joints()
    rot = np.zeros((2, 3, 4))
    rot[..., 3] = 1.0
    rot[1, 2] = [0, 0, 0, 1.01]
    with pytest.raises(ValidationError, match=r"unit quaternions \(xyzw\); frame 1, joint 'b' has norm 1.01"):
        identity_motion(sk, rotations=rot)
    rot[1, 2] = [0, 0, 0, 0]
    with pytest.raises(ValidationError, match="frame 1, joint 'b' has norm 0"):
        identity_motion(sk, rotations=rot)
    rot[1, 2] = [0, np.nan, 0, 1]
    with pytest.raises(ValidationError, match=r"rotations must be finite, found nan at index \(1, 2, 1\)"):
        identity_motion(sk, rotations=rot)
    rot[1, 2] = [0, 0, 0, 1 + 5e-7]  # within the documented 1e-6 tolerance
    assert identity_motion(sk, rotations=rot).num_frames == 2


def test_motion_translated_joints_and_defaults():
    sk = three_joints(channels=(DEFAULT_ROOT_CHANNELS, ("Yposition", "Zrotation"), ("Xrotation",)))
    m = identity_motion(sk, frames=4)
    assert m.joint_translations.shape == (4, 1, 3)
    np.testing.assert_array_equal(m.joint_translations[:, 0], np.broadcast_to(sk.offsets[1], (4, 3)))
    with pytest.raises(ValidationError, match=r"joint_translations must have shape \(4, 1, 3\), got \(4, 2, 3\)"):
        identity_motion(sk, frames=4, joint_translations=np.zeros((4, 2, 3)))
    jt = np.zeros((4, 1, 3))
    jt[:, 0, 1] = np.arange(4)
    m = identity_motion(sk, frames=4, joint_translations=jt)
    lt = m.local_translations()
    assert lt.shape == (4, 3, 3)
    np.testing.assert_array_equal(lt[:, 1, 1], np.arange(4))
    np.testing.assert_array_equal(lt[:, 2], np.broadcast_to(sk.offsets[2], (4, 3)))


def test_motion_properties_frames_and_immutability():
    m = synthetic_motion(humanoid_skeleton(), frames=10, fps=50.0)
    assert m.num_frames == 10 and m.num_joints == 15
    assert m.frame_time == pytest.approx(0.02) and m.duration == pytest.approx(0.2)
    sub = m.frames(slice(2, 5))
    assert sub.num_frames == 3
    np.testing.assert_array_equal(sub.rotations, m.rotations[2:5])
    picked = m.frames(np.array([0, 9]))
    np.testing.assert_array_equal(picked.root_translation, m.root_translation[[0, 9]])
    with pytest.raises(ValueError):
        m.rotations[0, 0, 0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.fps = 10.0  # frozen dataclass
    # replace() validates again
    with pytest.raises(ValidationError, match="fps must be finite"):
        m.replace(fps=0)
    branch = np.zeros((10, 15), int)
    assert m.replace(euler_branch=branch).euler_branch.dtype == bool
    assert "10 frames at 50 fps, 15 joints" in repr(m)
    assert "15 joints" in repr(m.skeleton)


def test_motion_does_not_alias_caller_arrays():
    sk = chain_skeleton(3)
    rot = euler_to_quat(np.zeros((2, 3, 3)), "ZXY")
    root = np.zeros((2, 3))
    m = Motion(sk, 30.0, root, rot)
    rot[0, 0] = [1, 0, 0, 0]
    root[0, 0] = 5.0
    assert m.rotations[0, 0, 3] == 1.0 and m.root_translation[0, 0] == 0.0
    # a Motion built from another Motion's (immutable) arrays shares them safely
    m2 = Motion(sk, 30.0, m.root_translation, m.rotations)
    assert m2.rotations is m.rotations
