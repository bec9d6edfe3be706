"""The ``dual-quaternion`` representation (Andreou et al. 2022, sections 3-5) and its offset diagnostic."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep import Motion, Skeleton
from motionrep.model.kinematics import global_positions
from motionrep.model.poseplan import WORLD_IDENTITY, WORLD_QUAT
from motionrep.plugin.representation import (FeatureLayout, PosePlan, Representation, check_features, decoded_motion,
                                      feature_layout, per_skeleton)
from motionrep.model.rotations import quat_multiply

from ._algebra import (dualquat_conjugate, dualquat_from_rotation_translation, dualquat_make_continuous,
                       dualquat_multiply, dualquat_normalize, dualquat_to_rotation_translation)

__all__ = ["DualQuaternion", "OffsetError", "dual_part_offsets", "dual_part_offset_error"]

_DQ = ("real_x", "real_y", "real_z", "real_w", "dual_x", "dual_y", "dual_z", "dual_w")
_NAME = "dual-quaternion"


@per_skeleton
def _layout(skeleton: Skeleton) -> FeatureLayout:
    return feature_layout(skeleton, lambda j: _DQ)


def _levels(skeleton: Skeleton) -> list[NDArray[np.int64]]:
    """Joint indices grouped by depth 1, 2, ... (the root, depth 0, excluded)."""
    depths = skeleton.depths
    return [np.nonzero(depths == d)[0] for d in range(1, int(depths.max(initial=0)) + 1)]


def _global_rotations(motion: Motion) -> NDArray[np.float64]:
    """``(F, J, 4)`` xyzw rotation of every joint in world axes (the root's orientation included)."""
    sk = motion.skeleton
    g = np.empty_like(motion.rotations)
    g[:, 0] = motion.rotations[:, 0]
    for idx in _levels(sk):
        g[:, idx] = quat_multiply(g[:, sk.parents[idx]], motion.rotations[:, idx])
    return g


def _features_dualquats(f: NDArray[np.float64], lay: FeatureLayout) -> NDArray[np.float64]:
    """``(F, J, 8)`` dual quaternions of ``(F, D)`` features, normalised by eq. 13."""
    return dualquat_normalize(lay.rotation_block(f))


@per_skeleton
def _pose_plan(skeleton: Skeleton) -> PosePlan:
    """Every joint's real part as a rotation in world axes (the identity locally for a joint without rotation
    channels)."""
    def entry(j: int, cols: NDArray[np.int64]) -> tuple[int, NDArray[np.int64], tuple]:
        return (WORLD_QUAT, cols[:4], ()) if skeleton.rotation_orders[j] else (WORLD_IDENTITY, cols[:0], ())

    return _layout(skeleton).pose_plan(entry)


class DualQuaternion(Representation):
    """Root translation and one unit dual quaternion per joint in root-relative current coordinates.

    Columns (see :class:`~motionrep.plugin.representation.FeatureLayout`): root translation (3, file units); for every
    joint (the root included), the unit dual quaternion (8: real xyzw, dual xyzw) of its *current* transform,
    its world rotation and its position relative to the root (root orientation kept, root translation zeroed;
    the root's own dual part is therefore zero); for joints with position channels, their local translation
    (3, file units).  Frame 0 takes the sign with real ``w >= 0``, every later frame the sign closest in L2
    (8-D) to the frame before.

    Decoding normalises each dual quaternion's real part (eq. 13) and uses only the real parts: joint ``j``'s
    local rotation is ``G_parent* r_j`` with ``G_parent`` the parent's already decoded world rotation (the
    identity for joints without rotation channels), in one compiled pass (its :meth:`pose_plan`,
    ``motionrep.model.poseplan``).  The root translation comes from its 3 columns, joint offsets from
    the skeleton (and from the translation columns for joints with position channels).  The dual parts are kept
    for users who want positions without FK; :func:`dual_part_offset_error` measures how far they have drifted.
    """

    name = _NAME
    version = 1
    description = "Andreou et al. 2022: root translation, one dual quaternion per joint in current coordinates"

    def layout(self, skeleton: Skeleton) -> FeatureLayout:
        return _layout(skeleton)

    def to_features(self, motion: Motion) -> NDArray[np.float64]:
        sk = motion.skeleton
        J = sk.num_joints
        rot = _global_rotations(motion)
        pos = global_positions(motion)[:, :J]
        dq = dualquat_from_rotation_translation(rot, pos - pos[:, :1])
        dq *= np.where(dq[:1, :, 3:4] < 0, -1.0, 1.0)  # frame 0: real w >= 0
        dq = dualquat_make_continuous(dq)
        return _layout(sk).assemble(motion.root_translation, dq, motion.joint_translations)

    def from_features(self, features: ArrayLike, skeleton: Skeleton, fps: float) -> Motion:
        return decoded_motion(self, features, skeleton, fps)

    def pose_plan(self, skeleton: Skeleton) -> PosePlan:
        return _pose_plan(skeleton)

    def torch_path(self):
        """Its torch path (``_torch``, imported here: importing the plugin never imports torch)."""
        from ._torch import DualQuaternionTorch

        return DualQuaternionTorch()

    def weights(self, motion: Motion) -> NDArray[np.float64]:
        """``(D,)`` weights: 1 for translations and dual parts; for a joint's real part, its longest bone to a
        direct child (joints and end sites) in frame 0, or 0 if it has no rotation channels.

        Decoding takes each world rotation from its own real part, so an error in joint ``j``'s real part
        turns only the bones from ``j`` to its children (their subtrees move rigidly with them) and does not
        accumulate down the chain: the reach of that error is the longest such bone, not the joint's whole
        subtree as in Tojo et al. eq. 3.  A dual part is half a translation rotated (``q_d = 1/2 t q_r``), so
        weight 1 puts it on the same footing as the real parts (both weighted at half the position error they
        imply).  See ``specs/representations.md``.
        """
        sk = motion.skeleton
        lay = _layout(sk)
        local_t = motion.local_translations()[0]  # frame 0, (J, 3)
        bone = np.zeros(sk.num_joints)
        for j in range(1, sk.num_joints):
            p = int(sk.parents[j])
            bone[p] = max(bone[p], float(np.linalg.norm(local_t[j])))
        for p, off in zip(sk.end_site_parents.tolist(), sk.end_site_offsets):
            bone[p] = max(bone[p], float(np.linalg.norm(off)))
        bone[[not o for o in sk.rotation_orders]] = 0.0
        w = np.ones(lay.width)
        for j, cols in zip(lay.rotation_joints.tolist(), lay.rotation_columns):
            w[cols[:4]] = bone[j]
        return w


@dataclass(frozen=True)
class OffsetError:
    """How far the bone offsets implied by dual parts are from the skeleton's, in file units.

    Attributes:
        max_error: largest distance over all frames and non-root joints.
        mean_error: mean distance over all frames and non-root joints.
        frame: frame of the largest distance.
        joint: joint of the largest distance (None for a one-joint skeleton).
    """

    max_error: float
    mean_error: float
    frame: int
    joint: str | None


def dual_part_offsets(features: ArrayLike, skeleton: Skeleton) -> NDArray[np.float64]:
    """``(F, J, 3)`` local translation of every joint implied by the dual parts of ``dual-quaternion`` features.

    Each dual quaternion is normalised (eq. 13), made local (``parent* joint``, eq. 12) and its translation read
    with eq. 8.  For lossless features this is each joint's OFFSET (its per-frame translation for joints with
    position channels); row 0 is the root's own translation in current coordinates, zero for lossless features.

    Raises:
        ValidationError: if ``features`` is not ``(F, D)`` dual-quaternion features of ``skeleton``.
    """
    lay = _layout(skeleton)
    f = check_features(features, lay.width, _NAME)
    dq = _features_dualquats(f, lay)
    local = dq.copy()
    local[:, 1:] = dualquat_multiply(dualquat_conjugate(dq[:, skeleton.parents[1:]]), dq[:, 1:])
    return dualquat_to_rotation_translation(local)[1]


def dual_part_offset_error(features: ArrayLike, skeleton: Skeleton) -> OffsetError:
    """Distance between the bone offsets implied by the dual parts and the skeleton's, after eq. 13.

    Use it after a lossy round trip (a codec) to see whether the dual parts still describe the skeleton: the
    decoder never reads them (it takes offsets from the skeleton), so a codec can degrade them without changing
    the decoded motion.  Joints with position channels are compared with their translation columns.

    Returns:
        :class:`OffsetError` over all frames and non-root joints, in file units.
    """
    lay = _layout(skeleton)
    f = check_features(features, lay.width, _NAME)
    implied = dual_part_offsets(f, skeleton)
    F, J = implied.shape[:2]
    if J < 2:
        return OffsetError(0.0, 0.0, 0, None)
    expected = np.broadcast_to(skeleton.offsets, (F, J, 3)).copy()
    if skeleton.translated_joints.size:
        expected[:, skeleton.translated_joints] = lay.split(f)[1]
    dist = np.linalg.norm(implied[:, 1:] - expected[:, 1:], axis=-1)
    frame, joint = np.unravel_index(int(np.argmax(dist)), dist.shape)
    return OffsetError(float(dist.max()), float(dist.mean()), int(frame), skeleton.names[joint + 1])
