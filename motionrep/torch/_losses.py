"""Losses and the shared error in torch.

* Andreou et al. (2022), section 5.2, eq. 14-16, on ``(..., J, 8)`` dual quaternions ``[real xyzw, dual xyzw]``
  in current coordinates (the ``dual-quaternion`` representation's blocks, :func:`dualquats_of_features`):
  :func:`dq_mse_loss` (L_mse), :func:`dq_quat_loss` (L_quat), :func:`dq_pos_loss` (L_pos),
  :func:`dq_offset_loss` (L_offset), :func:`dq_reg_loss` (L_reg).  The per-joint terms are averaged over every
  leading dimension (frames, batch) and joint; ``reduction="none"`` keeps them, ``(..., J)``.
* :func:`fk_position_loss`: the mean joint and end-site position error through FK, for any representation with
  a torch path.
* :func:`max_joint_error`: the L-infinity error of ``motionrep evaluate`` (:mod:`motionrep.pipeline.evaluate`), worst
  joint or end site over frames, in file units and percent of the reference's character height.

Distances are differentiable where they are zero (gradient 0 there, not NaN).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch

from ..model._pose import Skeleton
from ..errors import ValidationError
from ..model.kinematics import character_height
from ..plugin.representation import Representation
from ._dualquat import dualquat_conjugate, dualquat_multiply, dualquat_normalize, dualquat_to_rotation_translation
from ._features import decode_features, layout_blocks
from ._kinematics import global_positions

__all__ = ["dualquats_of_features", "dq_mse_loss", "dq_quat_loss", "dq_pos_loss", "dq_offset_loss", "dq_reg_loss",
           "fk_position_loss", "max_joint_error", "JointError"]


def _distance(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Euclidean distance over the last axis, with gradient 0 (not NaN) where it is 0."""
    sq = ((a - b) ** 2).sum(-1)
    positive = sq > 0
    return torch.where(positive, torch.sqrt(torch.where(positive, sq, torch.ones_like(sq))), torch.zeros_like(sq))


def _reduce(per_joint: torch.Tensor, reduction: str) -> torch.Tensor:
    if reduction == "mean":
        return per_joint.mean()
    if reduction == "none":
        return per_joint
    raise ValidationError(f"reduction must be 'mean' or 'none', got {reduction!r}")


def _pair(predicted: torch.Tensor, target: torch.Tensor) -> None:
    for name, t in (("predicted", predicted), ("target", target)):
        if not isinstance(t, torch.Tensor) or t.ndim < 2 or t.shape[-1] != 8:
            raise ValidationError(f"{name} must be a tensor of dual quaternions (..., J, 8), got "
                                  f"{tuple(getattr(t, 'shape', ()))}")
    if predicted.shape != target.shape:
        raise ValidationError(f"predicted {tuple(predicted.shape)} and target {tuple(target.shape)} differ in shape")


def dualquats_of_features(features: torch.Tensor, skeleton: Skeleton) -> torch.Tensor:
    """``(..., F, J, 8)`` dual quaternions of ``(..., F, D)`` ``dual-quaternion`` features (as they are, not
    normalised)."""
    from ..plugin.registry import get_representation

    return layout_blocks(get_representation("dual-quaternion").layout(skeleton), features)


def dq_mse_loss(predicted: torch.Tensor, target: torch.Tensor, reduction: str = "mean") -> torch.Tensor:
    """Eq. 14, ``L_mse = |dq - dq~|_2^2`` per joint (8-vectors as they are)."""
    _pair(predicted, target)
    return _reduce(((predicted - target) ** 2).sum(-1), reduction)


def _local(dq: torch.Tensor, skeleton: Skeleton) -> torch.Tensor:
    """Local dual quaternions ``parent* joint`` (eq. 12) of normalised current ones; the root's is its own."""
    parents = torch.tensor(skeleton.parents[1:].tolist(), device=dq.device)
    rest = dualquat_multiply(dualquat_conjugate(dq[..., parents, :]), dq[..., 1:, :])
    return torch.cat([dq[..., :1, :], rest], dim=-2)


def _joints(dq: torch.Tensor, skeleton: Skeleton) -> None:
    if dq.shape[-2] != skeleton.num_joints:
        raise ValidationError(f"dual quaternions must be (..., {skeleton.num_joints}, 8) for this skeleton, got "
                              f"{tuple(dq.shape)}")


def dq_quat_loss(predicted: torch.Tensor, target: torch.Tensor, skeleton: Skeleton,
                 reduction: str = "mean") -> torch.Tensor:
    """Eq. 15, ``L_quat = 1 - q . q~`` per joint, on the local rotations: both normalised (eq. 13), made local
    along the hierarchy (eq. 12), their real parts compared.  As in the paper the plain dot product (both in the
    hemisphere continuity gives), not its absolute value."""
    _pair(predicted, target)
    _joints(predicted, skeleton)
    p = _local(dualquat_normalize(predicted), skeleton)[..., :4]
    t = _local(dualquat_normalize(target), skeleton)[..., :4]
    return _reduce(1.0 - (p * t).sum(-1), reduction)


def dq_pos_loss(predicted: torch.Tensor, target: torch.Tensor, reduction: str = "mean") -> torch.Tensor:
    """``L_pos = |p - p~|_2`` per joint, ``p = 2 q_d q_r*`` (eq. 8) of the normalised current dual quaternions:
    the joint positions relative to the root (root orientation kept), no FK needed."""
    _pair(predicted, target)
    p = dualquat_to_rotation_translation(dualquat_normalize(predicted))[1]
    t = dualquat_to_rotation_translation(dualquat_normalize(target))[1]
    return _reduce(_distance(p, t), reduction)


def dq_offset_loss(predicted: torch.Tensor, target: torch.Tensor, skeleton: Skeleton,
                   reduction: str = "mean") -> torch.Tensor:
    """``L_offset = |o - o~|_2`` per non-root joint: the offsets, translations of the local dual quaternions
    (eq. 12, then eq. 8), of the normalised prediction against the target's (``(..., J - 1)`` with
    ``reduction="none"``)."""
    _pair(predicted, target)
    _joints(predicted, skeleton)
    p = dualquat_to_rotation_translation(_local(dualquat_normalize(predicted), skeleton)[..., 1:, :])[1]
    t = dualquat_to_rotation_translation(_local(dualquat_normalize(target), skeleton)[..., 1:, :])[1]
    return _reduce(_distance(p, t), reduction)


def dq_reg_loss(predicted: torch.Tensor, reduction: str = "mean") -> torch.Tensor:
    """Eq. 16 on the raw (not normalised) prediction: ``(|q_r|^2 - 1)^2 + <q_r, q_d>^2`` per joint, the unit
    conditions (eq. 3)."""
    if not isinstance(predicted, torch.Tensor) or predicted.ndim < 1 or predicted.shape[-1] != 8:
        raise ValidationError(f"predicted must be a tensor of dual quaternions (..., 8), got "
                              f"{tuple(getattr(predicted, 'shape', ()))}")
    r, d = predicted[..., :4], predicted[..., 4:]
    return _reduce(((r * r).sum(-1) - 1.0) ** 2 + (r * d).sum(-1) ** 2, reduction)


def fk_position_loss(representation: str | Representation, predicted_features: torch.Tensor,
                     target_features: torch.Tensor, skeleton: Skeleton, reduction: str = "mean") -> torch.Tensor:
    """Mean Euclidean distance between the FK positions of every joint and end site of two ``(..., F, D)``
    feature tensors of ``representation`` (decoded by its torch path); ``(..., F, J + E)`` with
    ``reduction="none"``.  In file units."""
    a = global_positions(skeleton, *decode_features(representation, predicted_features, skeleton))
    b = global_positions(skeleton, *decode_features(representation, target_features, skeleton))
    return _reduce(_distance(a, b), reduction)


@dataclass(frozen=True)
class JointError:
    """The shared L-infinity error, per leading batch entry.

    Attributes:
        max_error: ``(...)`` largest joint or end-site distance over frames, file units.
        max_error_percent: ``(...)`` in percent of ``height`` (``inf`` for height 0 and a non-zero error).
        mean_error: ``(...)`` mean distance over frames and points.
        frame: ``(...)`` frame of the largest distance.
        point: ``(...)`` point (joints, then end sites) of the largest distance.
        height: the reference skeleton's character height (:func:`motionrep.model.kinematics.character_height`).
    """

    max_error: torch.Tensor
    max_error_percent: torch.Tensor
    mean_error: torch.Tensor
    frame: torch.Tensor
    point: torch.Tensor
    height: float


def max_joint_error(skeleton: Skeleton, reference: tuple, candidate: tuple) -> JointError:
    """The L-infinity joint-position error of ``motionrep evaluate`` between two poses of ``skeleton``.

    Args:
        reference, candidate: ``(root_translation (..., F, 3), rotations (..., F, J, 4), joint_translations
            (..., F, P, 3) or None)``, as :func:`global_positions` takes them.

    Returns:
        :class:`JointError` (differentiable in ``max_error``; equal to
        :func:`motionrep.pipeline.evaluate.max_joint_error`'s ``max_error`` to rounding).
    """
    a = global_positions(skeleton, *reference)
    b = global_positions(skeleton, *candidate)
    if a.shape != b.shape:
        raise ValidationError(f"reference and candidate poses differ in shape: {tuple(a.shape)} vs {tuple(b.shape)}")
    dist = _distance(b, a)  # (..., F, J + E)
    flat = dist.flatten(-2)
    worst, where = flat.max(dim=-1)
    height = character_height(skeleton)
    if height > 0:
        percent = 100.0 * worst / height
    else:
        percent = torch.where(worst == 0, torch.zeros_like(worst), torch.full_like(worst, math.inf))
    mean = flat.mean(-1)
    return JointError(worst, percent, mean, where // dist.shape[-1], where % dist.shape[-1], height)
