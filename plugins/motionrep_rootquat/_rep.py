"""The ``root-quat-axis-angle`` representation (Tojo et al. 2022, section 3)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep import Motion, Skeleton
from motionrep.representation import (FeatureLayout, Representation, check_features, feature_layout, joint_reach,
                                      per_skeleton)
from motionrep.rotations import (axis_angle_make_continuous, axis_angle_to_quat, quat_make_continuous,
                                 quat_normalize, quat_to_axis_angle)

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


@dataclass(frozen=True)
class _DecodePlan:
    """Where ``from_features`` reads and writes, worked out once per skeleton."""

    identity_fill: bool  # some joints have no rotation channels
    root_columns: NDArray[np.int64] | None  # the root quaternion's 4 columns
    joints: slice | NDArray[np.int64] | None  # the non-root joints with axis-angle columns
    columns: slice | NDArray[np.int64] | None  # their columns: a slice when contiguous, else (R, 3) indices


@per_skeleton
def _decode_plan(skeleton: Skeleton) -> _DecodePlan:
    lay = _layout(skeleton)
    joints = lay.rotation_joints
    root = lay.rotation_columns[0] if joints.size and joints[0] == 0 else None
    others = [(j, cols) for j, cols in zip(joints.tolist(), lay.rotation_columns) if j > 0]
    if not others:
        return _DecodePlan(joints.size < skeleton.num_joints, root, None, None)
    idx = np.array([j for j, _ in others])
    cols = np.stack([c for _, c in others])
    first = int(cols[0, 0])
    columns = (slice(first, first + cols.size) if np.array_equal(cols.ravel(), np.arange(first, first + cols.size))
               else cols)
    target = (slice(int(idx[0]), int(idx[0]) + idx.size) if np.array_equal(idx, np.arange(idx[0], idx[0] + idx.size))
              else idx)
    return _DecodePlan(joints.size < skeleton.num_joints, root, target, columns)


class RootQuatAxisAngle(Representation):
    """Root translation, root orientation as a quaternion, every other joint as an axis-angle vector.

    Columns (see :class:`~motionrep.representation.FeatureLayout`): root translation (3, file units); if the
    root has rotation channels, its orientation as a unit quaternion (4, **xyzw**), the sign of frame 0 chosen
    with ``w >= 0`` and every later frame's sign the one closest in L2 to the frame before; for every other
    joint with rotation channels, its local rotation as a rotation vector (3, axis times angle in radians),
    continuous over frames (of the vectors ``(theta + 2 pi k) n`` of the same rotation, the one closest to the
    previous frame); for joints with position channels, their local translation (3, file units).  Joints
    without rotation channels take no rotation columns and decode to the identity.

    Decoding normalises the root quaternion.
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
        lay = _layout(skeleton)
        f = check_features(features, lay.width, self.name)
        F = f.shape[0]
        rotations = np.empty((F, skeleton.num_joints, 4))
        plan = _decode_plan(skeleton)
        if plan.identity_fill:  # joints without rotation channels: identity
            rotations[...] = (0.0, 0.0, 0.0, 1.0)
        if plan.root_columns is not None:
            rotations[:, 0] = quat_normalize(f[:, plan.root_columns])
        if plan.joints is not None:
            if isinstance(plan.columns, slice):
                vectors = f[:, plan.columns].reshape(F, -1, 3)  # a view, no gather
            else:
                vectors = f[:, plan.columns]
            rotations[:, plan.joints] = axis_angle_to_quat(vectors)
        root_t, joint_t = lay.split(f)
        rotations.flags.writeable = False  # handed to the Motion without a copy
        return Motion(skeleton, fps, root_t, rotations, joint_t)

    def weights(self, motion: Motion) -> NDArray[np.float64]:
        return _layout(motion.skeleton).weights(joint_reach(motion))
