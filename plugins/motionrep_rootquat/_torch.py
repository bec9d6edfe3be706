"""The torch path of ``root-quat-axis-angle`` (imported by ``RootQuatAxisAngle.torch_path`` only)."""

from __future__ import annotations

import math

import numpy as np
import torch

from motionrep import Skeleton
from motionrep.plugin.representation import TorchPath
from motionrep.torch import layout_assemble, layout_blocks, layout_place, layout_split
from motionrep.torch.rotations import axis_angle_to_quat, quat_make_continuous, quat_normalize, quat_to_axis_angle

from ._rep import _layout

__all__ = ["RootQuatAxisAngleTorch"]


class RootQuatAxisAngleTorch(TorchPath):
    """The root quaternion normalised, the rotation vectors turned into quaternions (roma), as numpy does.

    Encoding: the root quaternion's signs (frame 0 ``w >= 0``, then closest to the frame before) chosen in
    torch by numpy's rule; each rotation vector ``(theta + 2 pi k) n`` with ``theta n`` computed in torch and the
    full turns ``k`` those of the numpy features (``reference``).
    """

    def decode(self, features: torch.Tensor, skeleton: Skeleton):
        lay = _layout(skeleton)
        root, jt = layout_split(lay, features)
        joints = lay.rotation_joints
        parts, where = [], []
        first = 0
        if joints.size and joints[0] == 0:
            parts.append(quat_normalize(layout_blocks(lay, features, [0])))
            where.append(joints[:1])
            first = 1
        if joints.size > first:
            parts.append(axis_angle_to_quat(layout_blocks(lay, features, list(range(first, joints.size)))))
            where.append(joints[first:])
        if not parts:
            return root, layout_place(skeleton, joints, features.new_zeros(features.shape[:-1] + (0, 4))), jt
        return root, layout_place(skeleton, np.concatenate(where), torch.cat(parts, dim=-2)), jt

    def encode(self, skeleton: Skeleton, root_translation, rotations, joint_translations, reference=None):
        lay = _layout(skeleton)
        joints = lay.rotation_joints
        blocks: list[torch.Tensor] = []
        others = joints[joints > 0]
        if joints.size and joints[0] == 0:
            q = rotations[:, 0]
            q = q * torch.where(q[:1, 3:] < 0, -1.0, 1.0).to(q.dtype)  # frame 0: w >= 0
            blocks.append(quat_make_continuous(q))
        if others.size:
            aa = quat_to_axis_angle(rotations[:, torch.tensor(others.copy(), device=rotations.device)])
            if reference is None:
                from motionrep.model.rotations import axis_angle_make_continuous

                target = axis_angle_make_continuous(aa.detach().cpu().double().numpy())
            else:
                target = reference[:, np.stack([lay.rotation_columns[r] for r in range(len(joints) - others.size,
                                                                                       len(joints))])]
            aa = _turns(aa, torch.tensor(target, dtype=aa.dtype, device=aa.device))
            blocks.extend(aa.unbind(1))
        return layout_assemble(lay, root_translation, blocks, joint_translations)


def _turns(aa: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """``aa`` (angles in [0, pi]) with the full turns of ``target``, the same rotations made continuous: ``theta n
    + 2 pi k n``, ``k`` and, for a zero rotation, the axis ``n`` read from ``target``."""
    theta = torch.linalg.vector_norm(aa.detach(), dim=-1, keepdim=True)
    moving = theta > 1e-12
    with torch.no_grad():
        size = torch.linalg.vector_norm(target, dim=-1, keepdim=True)
        axis = torch.where(moving, aa / torch.where(moving, theta, 1.0),
                           torch.where(size > 1e-12, target / torch.where(size > 1e-12, size, 1.0), 0.0))
        k = torch.round(((axis * target).sum(-1, keepdim=True) - theta) / (2 * math.pi))
    live = torch.sqrt(torch.where(moving, (aa * aa).sum(-1, keepdim=True), 1.0))
    turn = torch.where(moving, aa / live, axis)  # differentiable where theta > 0
    return aa + (2 * math.pi) * k * turn
