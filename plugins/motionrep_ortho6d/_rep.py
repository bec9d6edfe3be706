"""The ``ortho6d`` representation: the 6D rotation encoding of Zhou et al. (2019) per joint."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep import Motion, Skeleton
from motionrep.model.poseplan import ORTHO6D
from motionrep.plugin.representation import (FeatureLayout, PosePlan, Representation, decoded_motion, feature_layout,
                                      joint_reach, per_skeleton)
from motionrep.model.rotations import quat_to_ortho6d

__all__ = ["Ortho6D"]

# The first two columns of the local rotation matrix, column by column.
_SIX = ("m00", "m10", "m20", "m01", "m11", "m21")


@per_skeleton
def _layout(skeleton: Skeleton) -> FeatureLayout:
    return feature_layout(skeleton, lambda j: _SIX if skeleton.rotation_orders[j] else ())


@per_skeleton
def _pose_plan(skeleton: Skeleton) -> PosePlan:
    return _layout(skeleton).pose_plan(lambda j, cols: (ORTHO6D, cols, ()))


class Ortho6D(Representation):
    """Root translation and the 6D encoding of every joint's local rotation.

    Columns (see :class:`~motionrep.plugin.representation.FeatureLayout`): root translation (3, file units); for every
    joint with rotation channels (the root included), the first two columns of its local rotation matrix
    (6, ``[R00, R10, R20, R01, R11, R21]``, dimensionless); for joints with position channels, their local
    translation (3, file units).  The encoding is continuous by construction (no sign or wrap choice).

    Decoding orthonormalises the two columns by Gram-Schmidt and takes their cross product as the third.
    """

    name = "ortho6d"
    version = 1
    description = "Zhou et al. 2019 (NeMF): root translation, 6D rotation per joint"

    def layout(self, skeleton: Skeleton) -> FeatureLayout:
        return _layout(skeleton)

    def to_features(self, motion: Motion) -> NDArray[np.float64]:
        lay = _layout(motion.skeleton)
        six = quat_to_ortho6d(motion.rotations[:, lay.rotation_joints])
        return lay.assemble(motion.root_translation, six, motion.joint_translations)

    def from_features(self, features: ArrayLike, skeleton: Skeleton, fps: float) -> Motion:
        return decoded_motion(self, features, skeleton, fps)

    def pose_plan(self, skeleton: Skeleton) -> PosePlan:
        return _pose_plan(skeleton)

    def torch_path(self):
        """Its torch path (``_torch``, imported here: importing the plugin never imports torch)."""
        from ._torch import Ortho6DTorch

        return Ortho6DTorch()

    def weights(self, motion: Motion) -> NDArray[np.float64]:
        return _layout(motion.skeleton).weights(joint_reach(motion))
