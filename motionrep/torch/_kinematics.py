"""Forward kinematics on torch tensors, with the conventions of :mod:`motionrep.model.kinematics`.

Points are joints first (``J``), then end sites (``E``).  The root is at ``root_translation`` (its OFFSET with
the axes that have position channels replaced, as ``Motion.root_translation``); every other joint is at its
parent's position plus its local translation rotated by the parent's world rotation; the local translation
is the joint's OFFSET, or, for the joints in ``skeleton.translated_joints`` (position channels), its row of
``joint_translations`` (which replaces the OFFSET, as ``Motion.joint_translations``).  End sites hang from their
joint at their OFFSET.  Local rotations are normalised first, as the compiled numpy FK does, so the result is
the pose the rotations stand for; rotating a vector is ``v + w t + u x t`` with ``t = 2 u x v``, the numpy
kernel's arithmetic.

The joints are processed one depth level at a time (every joint of a level in one batched product, its parents
gathered from the level above), so the number of torch operations grows with the depth of the skeleton, not with
its joint count.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ..model._pose import Skeleton
from ..errors import ValidationError

__all__ = ["forward_kinematics", "global_positions", "skeleton_tensors"]


@dataclass(frozen=True)
class _Levels:
    """The joints by depth (level 0 is the root), each joint's parent as a position in the level above, and
    where each joint sits in the levels concatenated."""

    joints: tuple[np.ndarray, ...]
    parent_slots: tuple[np.ndarray, ...]  # per level >= 1, positions of the parents within the level above
    inverse: np.ndarray  # position of each joint in the levels concatenated
    tensors: dict  # (dtype, device) -> the index and offset tensors of _fk, made once


_LEVELS: dict[int, tuple[Skeleton, _Levels]] = {}


def _levels(skeleton: Skeleton) -> _Levels:
    entry = _LEVELS.get(id(skeleton))
    if entry is not None and entry[0] is skeleton:
        return entry[1]
    depths = skeleton.depths
    joints = tuple(np.nonzero(depths == d)[0] for d in range(int(depths.max(initial=0)) + 1))
    slot = np.empty(skeleton.num_joints, np.int64)
    for level in joints:
        slot[level] = np.arange(level.size)
    parents = tuple(slot[skeleton.parents[level]] for level in joints[1:])
    order = np.concatenate(joints).astype(np.int64)
    inverse = np.empty_like(order)
    inverse[order] = np.arange(order.size)
    value = _Levels(joints, parents, inverse, {})
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
    lv = _levels(skeleton)
    key = (dtype, device)
    if key not in lv.tensors:
        offsets, sites = skeleton_tensors(skeleton, dtype, device)
        index = lambda a: torch.tensor(np.array(a, np.int64), device=device)  # noqa: E731
        lv.tensors[key] = (offsets.T[:, :, None], sites.T[:, :, None], index(skeleton.translated_joints),
                           [(index(s), index(j)) for j, s in zip(lv.joints[1:], lv.parent_slots)],
                           index(lv.inverse), index(skeleton.end_site_parents))
    local, sites, translated, levels, back, sp = lv.tensors[key]
    batch = rot.shape[:-2]
    J, E = skeleton.num_joints, skeleton.num_end_sites
    # Components first, joints next, every pose last ((4, J, N), N poses): each component of a level is one
    # contiguous block, which makes the elementwise products several times faster than on (..., 4) rows.
    q = rot.reshape(-1, J, 4).permute(2, 1, 0).contiguous()
    x, y, z, w = q
    q = q / torch.sqrt(x * x + y * y + z * z + w * w)  # (not vector_norm over dim 0: 10x slower on the CPU)
    n = q.shape[-1]
    if jt is not None and translated.numel():
        local = local.expand(3, J, n).clone()
        local[:, translated] = jt.to(dtype).reshape(n, -1, 3).permute(2, 1, 0)
    gs = [q[:, :1]]
    ps = [root.to(dtype).reshape(n, 3).T[:, None]]
    for at, idx in levels:
        gp = gs[-1].index_select(1, at)
        gs.append(_qmul(gp, q.index_select(1, idx)))
        ps.append(ps[-1].index_select(1, at) + _rotate(gp, local.index_select(1, idx)))
    g = torch.cat(gs, dim=1).index_select(1, back) if len(gs) > 1 else gs[0]
    p = torch.cat(ps, dim=1).index_select(1, back) if len(ps) > 1 else ps[0]
    if E:
        p = torch.cat([p, p.index_select(1, sp) + _rotate(g.index_select(1, sp), sites)], dim=1)
    return (g.permute(2, 1, 0).reshape(batch + (J, 4)), p.permute(2, 1, 0).reshape(batch + (J + E, 3)))


def _qmul(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Hamilton product of component-first quaternions ``(4, ...)`` xyzw."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return torch.stack([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                        aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz])


def _rotate(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """Component-first ``(3, ...)`` vectors rotated by unit ``(4, ...)`` quaternions: ``v + w t + u x t``,
    ``t = 2 u x v`` (the compiled numpy FK's arithmetic)."""
    x, y, z, w = q
    vx, vy, vz = v
    tx, ty, tz = 2.0 * (y * vz - z * vy), 2.0 * (z * vx - x * vz), 2.0 * (x * vy - y * vx)
    return torch.stack([vx + w * tx + (y * tz - z * ty), vy + w * ty + (z * tx - x * tz),
                        vz + w * tz + (x * ty - y * tx)])
