"""The dual-quaternion representation's internals: the conformance suite catches a mutant of it that depends on
quaternion signs, and decoding reads only the real parts (its layout and world rotations are this plugin's own).
Its behaviour and algebra through the core are tested in ``tests/test_representations.py``."""

from __future__ import annotations

import numpy as np
import pytest

from motionrep.model.kinematics import global_positions
from motionrep.model.synthetic import synthetic_motion
from motionrep.testing import check_representation

from helpers import mutant, representation_alone


@pytest.fixture
def rep(monkeypatch):
    return representation_alone(monkeypatch, "motionrep_dualquat", "dual-quaternion")


def test_suite_catches_dependence_on_quaternion_signs(rep):
    def to_features(self, motion):  # dual quaternions built from the input's signs, no continuity step
        from motionrep_dualquat._rep import _global_rotations, _layout
        from motionrep_dualquat import dualquat_from_rotation_translation

        pos = global_positions(motion)[:, :motion.num_joints]
        dq = dualquat_from_rotation_translation(_global_rotations(motion), pos - pos[:, :1])
        return _layout(motion.skeleton).assemble(motion.root_translation, dq, motion.joint_translations)

    with pytest.raises(AssertionError, match="depend on quaternion signs"):
        check_representation(mutant(rep, to_features=to_features),
                             [synthetic_motion(frames=20)])


def test_dualquat_decoding_uses_only_real_parts(rep):
    from motionrep_dualquat._rep import _global_rotations

    m = synthetic_motion(frames=12)
    f = rep.to_features(m)
    names = rep.feature_names(m.skeleton)
    dual = [i for i, n in enumerate(names) if "/dual_" in n]
    g = f.copy()
    g[:, dual] += np.random.default_rng(0).normal(size=(12, len(dual)))
    np.testing.assert_allclose(global_positions(rep.from_features(g, m.skeleton, m.fps)), global_positions(m),
                               atol=1e-9)
    # a lossy real part of one joint: that joint's decoded world rotation is its normalised real part, and the
    # world rotations of every other joint are untouched (no accumulation down the chain)
    arm = m.skeleton.index("LeftArm")
    cols = [names.index(f"LeftArm/real_{c}") for c in "xyzw"]
    g = f.copy()
    g[:, cols] += 0.05
    world = _global_rotations(rep.from_features(g, m.skeleton, m.fps))
    expected = g[:, cols] / np.linalg.norm(g[:, cols], axis=-1, keepdims=True)
    np.testing.assert_allclose(np.abs(np.sum(world[:, arm] * expected, axis=-1)), 1.0, atol=1e-12)
    others = [j for j in range(m.num_joints) if j != arm]
    np.testing.assert_allclose(np.abs(np.sum(world[:, others] * _global_rotations(m)[:, others], axis=-1)), 1.0,
                               atol=1e-12)
