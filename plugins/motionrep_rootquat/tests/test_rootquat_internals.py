"""The root-quaternion + axis-angle representation's internals: the conformance suite catches a mutant of it
that loses continuity (its layout is this plugin's own).  Its behaviour through the core is tested in
``tests/test_representations.py``."""

from __future__ import annotations

import numpy as np
import pytest

from motionrep.model.rotations import quat_to_axis_angle
from motionrep.model.synthetic import spinning_motion
from motionrep.testing import check_representation

from helpers import mutant, representation_alone


@pytest.fixture
def rep(monkeypatch):
    return representation_alone(monkeypatch, "motionrep_rootquat", "root-quat-axis-angle")


def test_suite_catches_root_quaternion_sign_flips(rep):
    from motionrep_rootquat._rep import _layout  # this plugin's own layout

    def to_features(self, motion):  # canonical sign per frame instead of continuity
        f = type(rep).to_features(self, motion)
        cols = _layout(motion.skeleton).rotation_columns[0]
        q = f[:, cols]
        f[:, cols] = q * np.where(q[:, 3:] < 0, -1.0, 1.0)
        return f

    with pytest.raises(AssertionError, match="Hips/q.' is not continuous"):
        check_representation(mutant(rep, to_features=to_features), [spinning_motion()])


def test_suite_catches_axis_angle_wrap_jumps(rep):
    from motionrep_rootquat._rep import _layout  # this plugin's own layout

    def to_features(self, motion):  # every rotation vector with its angle in [0, pi], frame by frame
        f = type(rep).to_features(self, motion)
        lay = _layout(motion.skeleton)
        for j, cols in zip(lay.rotation_joints.tolist(), lay.rotation_columns):
            if j:
                f[:, cols] = quat_to_axis_angle(motion.rotations[:, j])
        return f

    with pytest.raises(AssertionError, match="aa_.' is not continuous"):
        check_representation(mutant(rep, to_features=to_features), [spinning_motion()])
