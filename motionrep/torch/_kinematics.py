"""Forward kinematics on torch tensors, with the conventions of :mod:`motionrep.kinematics`.

Points are joints first (``J``), then end sites (``E``).  The root is at ``root_translation`` (its OFFSET with
the axes that have position channels replaced, as ``Motion.root_translation``); every other joint is at its
parent's position plus its local translation rotated by the parent's world rotation; the local translation
is the joint's OFFSET, or, for the joints in ``skeleton.translated_joints`` (position channels), its row of
``joint_translations`` (which replaces the OFFSET, as ``Motion.joint_translations``).  End sites hang from their
joint at their OFFSET.  Local rotations are normalised first, as the compiled numpy FK does, so the result is
the pose the rotations stand for; rotating a vector is ``v + w t + u x t`` with ``t = 2 u x v``, the numpy
kernel's arithmetic.

The joints are processed one depth level at a time (every joint of a level in one batched product), so the
number of torch operations grows with the depth of the skeleton, not with its joint count.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from .._model import Skeleton
from ..errors import ValidationError
from .rotations import quat_apply, quat_multiply

__all__ = ["forward_kinematics", "global_positions", "skeleton_tensors"]


@dataclass(frozen=True)
class _Levels:
    """Per depth level >= 1: the joints of the level and their parents, as index tensors."""

    joints: tuple[np.ndarray, ...]
    parents: tuple[np.ndarray, ...]
    order: np.ndarray  # joints in level order (root first)
    inverse: np.ndarray  # position of each joint in ``order``


_LEVELS: dict[int, tuple[Skeleton, _Levels]] = {}


def _levels(skeleton: Skeleton) -> _Levels:
    entry = _LEVELS.get(id(skeleton))
    if entry is not None and entry[0] is skeleton:
        return entry[1]
    depths = skeleton.depths
    joints = tuple(np.nonzero(depths == d)[0] for d in range(1, int(depths.max(initial=0)) + 1))
    order = np.concatenate([np.zeros(1, np.int64)] + list(joints)).astype(np.int64)
    inverse = np.empty_like(order)
    inverse[order] = np.arange(order.size)
    value = _Levels(joints, tuple(np.array(skeleton.parents[j]) for j in joints), order, inverse)
    if len(_LEVELS) > 64:
        _LEVELS.clear()
    _LEVELS[id(skeleton)] = (skeleton, value)
    return value


def skeleton_tensors(skeleton: Skeleton, dtype: torch.dtype, device: torch.device | str | None
                     ) -> tuple[torch.Tensor, torch.Tensor]:
    """``(J, 3)`` OFFSETs and ``(E, 3)`` end-site OFFSETs of ``skeleton`` as tensors of ``dtype`` on ``device``."""
    return (torch.tensor(np.array(skeleton.offsets), dtype=dtype, device=device),
            torch.tensor(np.array(skeleton.end_site_offsets), dtype=dtype, device=device))


def _check(skeleton: Skeleton, root: torch.Tensor, rot: torch.Tensor, jt: torch.Tensor | None) -> None:
    if not isinstance(skeleton, Skeleton):
        raise ValidationError(f"skeleton must be a motionrep Skeleton, got {type(skeleton).__name__}")
    J, P = skeleton.num_joints, skeleton.translated_joints.shape[0]
    for name, t in (("root_translation", root), ("rotations", rot)):
        if not isinstance(t, torch.Tensor):
            raise ValidationError(f"{name} must be a torch tensor, got {type(t).__name__}")
    if rot.ndim < 3 or rot.shape[-2:] != (J, 4):
        raise ValidationError(f"rotations must have shape (..., F, {J}, 4) for this skeleton, got {tuple(rot.shape)}")
    if root.shape[-1:] != (3,) or root.ndim != rot.ndim - 1:
        raise ValidationError(f"root_translation must have shape (..., F, 3) beside rotations {tuple(rot.shape)}, "
                              f"got {tuple(root.shape)}")
    if jt is not None and (not isinstance(jt, torch.Tensor) or jt.shape[-2:] != (P, 3) or jt.ndim != rot.ndim):
        raise ValidationError(f"joint_translations must be a tensor of shape (..., F, {P}, 3) (the joints with "
                              f"position channels), got {tuple(getattr(jt, 'shape', ()))}")


def forward_kinematics(skeleton: Skeleton, root_translation: torch.Tensor, rotations: torch.Tensor,
                       joint_translations: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """World rotations and positions of every joint and end site (differentiable).

    Args:
        skeleton: the skeleton.
        root_translation: ``(..., F, 3)``.
        rotations: ``(..., F, J, 4)`` local rotations, xyzw (normalised here).
        joint_translations: ``(..., F, P, 3)`` local translations of ``skeleton.translated_joints``, or None for
            their OFFSETs.

    Returns:
        ``(..., F, J, 4)`` world rotations of the joints (unit, ``w >= 0`` as ``FKResult.rotations``; an end
        site has its joint's) and ``(..., F, J + E, 3)`` world positions, in the dtype and on the device of
        ``rotations``.
    """
    g, pos = _fk(skeleton, root_translation, rotations, joint_translations)
    return torch.where(g[..., 3:] < 0, -g, g), pos


def global_positions(skeleton: Skeleton, root_translation: torch.Tensor, rotations: torch.Tensor,
                     joint_translations: torch.Tensor | None = None) -> torch.Tensor:
    """``(..., F, J + E, 3)`` world positions of every joint, then every end site (see
    :func:`forward_kinematics`)."""
    return _fk(skeleton, root_translation, rotations, joint_translations)[1]


def _fk(skeleton: Skeleton, root: torch.Tensor, rot: torch.Tensor, jt: torch.Tensor | None
        ) -> tuple[torch.Tensor, torch.Tensor]:
    _check(skeleton, root, rot, jt)
    dtype, device = rot.dtype, rot.device
    root = root.to(dtype)
    lv = _levels(skeleton)
    offsets, sites = skeleton_tensors(skeleton, dtype, device)
    q = rot / torch.linalg.vector_norm(rot, dim=-1, keepdim=True)
    batch = rot.shape[:-2]
    J = skeleton.num_joints
    local = offsets.expand(batch + (J, 3))
    if jt is not None and skeleton.translated_joints.size:
        local = local.clone()
        local[..., torch.tensor(np.array(skeleton.translated_joints), device=device), :] = jt.to(dtype)
    # World rotations and positions, level by level, in level order (root first).
    g = q[..., :1, :]
    p = root[..., None, :]
    for joints, parents in zip(lv.joints, lv.parents):
        at = torch.as_tensor(lv.inverse[parents], device=device)
        gp = g.index_select(-2, at)
        pp = p.index_select(-2, at)
        idx = torch.as_tensor(joints, device=device)
        g = torch.cat([g, quat_multiply(gp, q.index_select(-2, idx))], dim=-2)
        p = torch.cat([p, pp + quat_apply(gp, local.index_select(-2, idx))], dim=-2)
    back = torch.as_tensor(lv.inverse, device=device)
    g = g.index_select(-2, back)
    p = p.index_select(-2, back)
    if skeleton.num_end_sites:
        sp = torch.tensor(np.array(skeleton.end_site_parents), device=device)
        p = torch.cat([p, p.index_select(-2, sp) + quat_apply(g.index_select(-2, sp), sites)], dim=-2)
    return g, p
