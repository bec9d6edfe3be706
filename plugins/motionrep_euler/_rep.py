"""The ``euler`` representation: each joint's own BVH rotation channels, in degrees, continuous over frames."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep import Motion, Skeleton
from motionrep.model.poseplan import EULER_DEGREES
from motionrep.plugin.representation import (FeatureLayout, PosePlan, Representation, check_features, decoded_motion,
                                      feature_layout, joint_reach, per_skeleton)
from motionrep.model.rotations import euler_branch, euler_columns, quat_to_euler_continuous

__all__ = ["Euler"]


@per_skeleton
def _layout(skeleton: Skeleton) -> FeatureLayout:
    return feature_layout(skeleton, lambda j: tuple(f"{a}rotation" for a in skeleton.rotation_orders[j]))


@per_skeleton
def _pose_plan(skeleton: Skeleton) -> PosePlan:
    """Each joint's angles in the order its factors apply (``motionrep.model.rotations.euler_columns``), degrees."""
    def entry(j: int, cols: NDArray[np.int64]) -> tuple[int, list[int], list[int]]:
        positions, axes = euler_columns([skeleton.rotation_orders[j]])
        used = [k for k in positions[0].tolist() if k >= 0]
        return EULER_DEGREES, [int(cols[k]) for k in used], axes[0, :len(used)].tolist()

    return _layout(skeleton).pose_plan(entry)


def _by_order(skeleton: Skeleton, joints: NDArray[np.int64]) -> dict[str, list[int]]:
    """Positions in ``joints`` grouped by rotation order, so each order is converted in one call."""
    groups: dict[str, list[int]] = {}
    for k, j in enumerate(joints.tolist()):
        groups.setdefault(skeleton.rotation_orders[j], []).append(k)
    return groups


class Euler(Representation):
    """Root translation and every joint's own rotation channels.

    Columns (see :class:`~motionrep.plugin.representation.FeatureLayout`): root translation (3, file units); for every
    joint with rotation channels, one column per channel in the file's order (``"<joint>/Zrotation"``...),
    intrinsic angles in **degrees** as in BVH; for joints with position channels, their local translation
    (3, file units).  Joints without rotation channels take no rotation columns and decode to the identity.

    Angles are continuous over frames: frame 0 takes the Euler solution the source file used
    (``Motion.euler_branch``; the one with the middle angle in [-90, 90] degrees when unknown), in
    [-180, 180); each later frame takes, of the two solutions and all their full-turn shifts, the one closest
    to the frame before.  Decoding sets ``Motion.euler_branch`` from the angles, so writing BVH gives them back
    (up to full turns).
    """

    name = "euler"
    version = 1
    description = "the file's own Euler rotation channels in degrees, continuous over frames"

    def layout(self, skeleton: Skeleton) -> FeatureLayout:
        return _layout(skeleton)

    def to_features(self, motion: Motion) -> NDArray[np.float64]:
        sk = motion.skeleton
        lay = _layout(sk)
        joints = lay.rotation_joints
        blocks: list[NDArray | None] = [None] * joints.size
        for order, ks in _by_order(sk, joints).items():
            idx = joints[ks]
            angles = quat_to_euler_continuous(motion.rotations[:, idx], order, degrees=True)  # (F, k, n)
            if len(order) == 3 and motion.euler_branch is not None:
                angles = _start_on_branch(angles, motion.euler_branch[0, idx], order)
            for n, k in enumerate(ks):
                blocks[k] = angles[:, n]
        return lay.assemble(motion.root_translation, blocks, motion.joint_translations)

    def from_features(self, features: ArrayLike, skeleton: Skeleton, fps: float) -> Motion:
        lay = _layout(skeleton)
        f = check_features(features, lay.width, self.name, float32=True)
        branch = np.zeros((f.shape[0], skeleton.num_joints), bool)
        joints = lay.rotation_joints
        for order, ks in _by_order(skeleton, joints).items():
            angles = f[:, np.stack([lay.rotation_columns[k] for k in ks])]  # (F, k, n)
            branch[:, joints[ks]] = euler_branch(angles, order, degrees=True)
        return decoded_motion(self, f, skeleton, fps, euler_branch=branch)

    def pose_plan(self, skeleton: Skeleton) -> PosePlan:
        return _pose_plan(skeleton)

    def torch_path(self):
        """Its torch path (``_torch``, imported here: importing the plugin never imports torch)."""
        from ._torch import EulerTorch

        return EulerTorch()

    def weights(self, motion: Motion) -> NDArray[np.float64]:
        """``(D,)`` weights: 1 for translations; for a joint's angles (degrees), its reach times pi / 180."""
        return _layout(motion.skeleton).weights(joint_reach(motion) * (np.pi / 180.0))


def _start_on_branch(angles: NDArray[np.float64], second: NDArray[np.bool_], order: str) -> NDArray[np.float64]:
    """Move the continuous curves ``(F, k, 3)`` of the joints whose frame 0 used the second Euler solution onto
    that solution, for the whole clip, with frame 0 in [-180, 180).

    The map between the two solutions, ``(a + 180, 180 - b, c + 180)`` (``-b`` for proper orders), is affine,
    so the image of a continuous curve is continuous.
    """
    if not np.any(second):
        return angles
    out = angles.copy()
    sel = np.asarray(second, bool)
    a = angles[:, sel]
    middle = -a[..., 1] if order[0] == order[2] else 180.0 - a[..., 1]
    b = np.stack([a[..., 0] + 180.0, middle, a[..., 2] + 180.0], axis=-1)
    b -= 360.0 * np.floor((b[:1] + 180.0) / 360.0)
    out[:, sel] = b
    return out
