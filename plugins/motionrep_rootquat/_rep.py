"""The ``root-quat-axis-angle`` representation (Tojo et al. 2022, section 3)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep import Motion, Skeleton
from motionrep.model.poseplan import AXIS_ANGLE, QUAT
from motionrep.plugin.representation import (FeatureLayout, PosePlan, Representation, decoded_motion, feature_layout,
                                      joint_reach, per_skeleton)
from motionrep.model.rotations import axis_angle_make_continuous, quat_make_continuous, quat_to_axis_angle

__all__ = ["RootQuatAxisAngle"]

_QUAT = ("qx", "qy", "qz", "qw")
_AXIS_ANGLE = ("aa_x", "aa_y", "aa_z")


@per_skeleton
def _layout(skeleton: Skeleton) -> FeatureLayout:
    def suffixes(j: int) -> tuple[str, ...]:
        if not skeleton.rotation_orders[j]:
            return ()
        return _QUAT if j == 0 else _AXIS_ANGLE

    return feature_layout(skeleton, suffixes)


@per_skeleton
def _pose_plan(skeleton: Skeleton) -> PosePlan:
    return _layout(skeleton).pose_plan(lambda j, cols: (QUAT if j == 0 else AXIS_ANGLE, cols, ()))


class RootQuatAxisAngle(Representation):
    """Root translation, root orientation as a quaternion, every other joint as an axis-angle vector.

    Columns (see :class:`~motionrep.plugin.representation.FeatureLayout`): root translation (3, file units); if the
    root has rotation channels, its orientation as a unit quaternion (4, **xyzw**), the sign of frame 0 chosen
    with ``w >= 0`` and every later frame's sign the one closest in L2 to the frame before; for every other
    joint with rotation channels, its local rotation as a rotation vector (3, axis times angle in radians),
    continuous over frames (of the vectors ``(theta + 2 pi k) n`` of the same rotation, the one closest to the
    previous frame); for joints with position channels, their local translation (3, file units).  Joints
    without rotation channels take no rotation columns and decode to the identity.

    Decoding normalises the root quaternion and converts the rotation vectors in one compiled pass (its
    :meth:`pose_plan`, ``motionrep.model.poseplan``), straight from the feature columns, float32 or float64 features
    alike (the arithmetic is float64).
    """

    name = "root-quat-axis-angle"
    version = 1
    description = "Tojo et al. 2022: root translation, root quaternion, axis-angle per joint"

    def layout(self, skeleton: Skeleton) -> FeatureLayout:
        return _layout(skeleton)

    def to_features(self, motion: Motion) -> NDArray[np.float64]:
        sk = motion.skeleton
        lay = _layout(sk)
        blocks: list[NDArray] = []
        joints = lay.rotation_joints
        others = joints[joints > 0]
        if joints.size and joints[0] == 0:
            root = motion.rotations[:, 0]
            root = root * np.where(root[:1, 3:] < 0, -1.0, 1.0)  # frame 0: w >= 0
            blocks.append(quat_make_continuous(root))
        if others.size:
            aa = axis_angle_make_continuous(quat_to_axis_angle(motion.rotations[:, others]))
            blocks.extend(aa[:, k] for k in range(others.size))
        root_t, joint_t = motion.root_translation, motion.joint_translations
        return lay.assemble(root_t, blocks, joint_t)

    def from_features(self, features: ArrayLike, skeleton: Skeleton, fps: float) -> Motion:
        return decoded_motion(self, features, skeleton, fps)

    def pose_plan(self, skeleton: Skeleton) -> PosePlan:
        return _pose_plan(skeleton)

    def torch_path(self):
        """Its torch path (``_torch``, imported here: importing the plugin never imports torch)."""
        from ._torch import RootQuatAxisAngleTorch

        return RootQuatAxisAngleTorch()

    def weights(self, motion: Motion) -> NDArray[np.float64]:
        return _layout(motion.skeleton).weights(joint_reach(motion))
