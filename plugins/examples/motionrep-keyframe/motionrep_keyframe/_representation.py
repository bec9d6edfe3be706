"""``local-quaternion``: root translation and every rotated joint's local rotation as a raw quaternion."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep import Motion, Skeleton
from motionrep.plugin.representation import (FeatureLayout, Representation, check_features, feature_layout, joint_reach,
                                      per_skeleton)
from motionrep.model.rotations import quat_make_continuous, quat_normalize

__all__ = ["LocalQuaternion"]


@per_skeleton
def _layout(skeleton: Skeleton) -> FeatureLayout:
    return feature_layout(skeleton, lambda j: ("qx", "qy", "qz", "qw") if skeleton.rotation_orders[j] else ())


class LocalQuaternion(Representation):
    """Root translation (3), then for every joint with rotation channels its local rotation as a unit
    quaternion (4, xyzw; frame 0 with ``w >= 0``, later frames sign-continuous), and the local translation (3)
    of joints with position channels.  Decoding normalises the quaternions."""

    name = "local-quaternion"
    version = 1
    description = "example plugin: raw local quaternions, sign-continuous"

    def layout(self, skeleton: Skeleton) -> FeatureLayout:
        return _layout(skeleton)

    def to_features(self, motion: Motion) -> NDArray[np.float64]:
        lay = _layout(motion.skeleton)
        q = motion.rotations[:, lay.rotation_joints]
        q = q * np.where(q[:1, :, 3:] < 0, -1.0, 1.0)
        return lay.assemble(motion.root_translation, quat_make_continuous(q), motion.joint_translations)

    def from_features(self, features: ArrayLike, skeleton: Skeleton, fps: float) -> Motion:
        lay = _layout(skeleton)
        f = check_features(features, lay.width, self.name)
        rotations = np.zeros((f.shape[0], skeleton.num_joints, 4))
        rotations[..., 3] = 1.0
        if lay.rotation_joints.size:
            rotations[:, lay.rotation_joints] = quat_normalize(lay.rotation_block(f))
        root_t, joint_t = lay.split(f)
        return Motion(skeleton, fps, root_t, rotations, joint_t)

    def weights(self, motion: Motion) -> NDArray[np.float64]:
        return _layout(motion.skeleton).weights(joint_reach(motion))
