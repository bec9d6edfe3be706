"""The torch path of ``euler`` (imported by ``Euler.torch_path`` only, so the plugin never imports torch)."""

from __future__ import annotations

import numpy as np
import torch

from motionrep import Motion, Skeleton
from motionrep.plugin.representation import TorchPath
from motionrep.torch import layout_assemble, layout_blocks, layout_place, layout_split
from motionrep.torch.rotations import euler_to_quat, quat_to_euler

from ._rep import _by_order, _layout

__all__ = ["EulerTorch"]


class EulerTorch(TorchPath):
    """Each joint's angles (degrees) in its own order, the product of the per-axis quaternions (roma).

    Encoding: the first Euler solution of each rotation in torch (roma), moved onto the solution and full turns
    of the numpy features (``reference``, which follows ``Motion.euler_branch`` and the continuity over frames);
    where the two disagree by more than 1e-6 degrees (gimbal lock, where the numpy path keeps the first angle of
    the frame before, and the gradient is undefined) the numpy angles are taken as they are.
    """

    def decode(self, features: torch.Tensor, skeleton: Skeleton):
        lay = _layout(skeleton)
        root, jt = layout_split(lay, features)
        joints = lay.rotation_joints
        parts, where = [], []
        for order, ks in _by_order(skeleton, joints).items():
            parts.append(euler_to_quat(layout_blocks(lay, features, ks), order, degrees=True))
            where.append(joints[ks])
        if not parts:
            return root, layout_place(skeleton, joints, features.new_zeros(features.shape[:-1] + (0, 4))), jt
        return root, layout_place(skeleton, np.concatenate(where), torch.cat(parts, dim=-2)), jt

    def encode(self, skeleton: Skeleton, root_translation, rotations, joint_translations, reference=None):
        from ._rep import Euler

        lay = _layout(skeleton)
        if reference is None:
            motion = Motion(skeleton, 1.0, *(t.detach().cpu().double().numpy()
                                             for t in (root_translation, rotations, joint_translations)))
            reference = Euler().to_features(motion)
        ref = torch.tensor(reference, dtype=rotations.dtype, device=rotations.device)
        joints = lay.rotation_joints
        blocks: list[torch.Tensor | None] = [None] * joints.size
        for order, ks in _by_order(skeleton, joints).items():
            q = rotations[:, torch.tensor(joints[ks].copy(), device=rotations.device)]
            angles = _onto(quat_to_euler(q, order, degrees=True), layout_blocks(lay, ref, ks), order)
            for n, k in enumerate(ks):
                blocks[k] = angles[:, n]
        return layout_assemble(lay, root_translation, blocks, joint_translations)


def _onto(e1: torch.Tensor, target: torch.Tensor, order: str) -> torch.Tensor:
    """``e1`` (first solutions, ``(F, k, n)`` degrees) moved onto the solution and full turns of ``target``."""
    def off(e: torch.Tensor) -> torch.Tensor:
        return torch.remainder(target - e.detach() + 180.0, 360.0) - 180.0

    cand = e1
    if len(order) == 3:
        middle = -e1[..., 1] if order[0].upper() == order[2].upper() else 180.0 - e1[..., 1]
        e2 = torch.stack([e1[..., 0] + 180.0, middle, e1[..., 2] + 180.0], dim=-1)
        second = off(e2).abs().sum(-1, keepdim=True) < off(e1).abs().sum(-1, keepdim=True)
        cand = torch.where(second, e2, e1)
    out = cand + 360.0 * torch.round((target - cand.detach()) / 360.0)
    agree = ((out.detach() - target).abs() <= 1e-6).all(-1, keepdim=True)
    return torch.where(agree, out, target)
