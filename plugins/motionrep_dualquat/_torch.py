"""The torch path of ``dual-quaternion`` (imported by ``DualQuaternion.torch_path`` only)."""

from __future__ import annotations

import numpy as np
import torch

from motionrep import Skeleton
from motionrep.plugin.representation import TorchPath
from motionrep.torch import (dualquat_from_rotation_translation, global_positions, layout_assemble, layout_blocks,
                             layout_split)
from motionrep.torch.rotations import quat_conjugate, quat_multiply, quat_normalize

from ._rep import _layout, _levels

__all__ = ["DualQuaternionTorch"]


def _sources(skeleton: Skeleton) -> tuple[np.ndarray, np.ndarray]:
    """Per joint, the joint whose real part is its world rotation (itself if it has rotation channels, else its
    nearest such ancestor; -1 for the identity), and the same for its parent."""
    src = np.full(skeleton.num_joints, -1, np.int64)
    for j in range(skeleton.num_joints):
        p = int(skeleton.parents[j])
        src[j] = j if skeleton.rotation_orders[j] else (src[p] if p >= 0 else -1)
    parent = np.array([src[int(p)] if p >= 0 else -1 for p in skeleton.parents], np.int64)
    return src, parent


def _gather(world: torch.Tensor, index: np.ndarray) -> torch.Tensor:
    """``world (..., J + 1, 4)`` (identity last) at ``index`` (``-1``: the identity)."""
    return world[..., torch.tensor(np.where(index < 0, world.shape[-2] - 1, index), device=world.device), :]


class DualQuaternionTorch(TorchPath):
    """Decoding from the real parts only, as numpy: each normalised (eq. 13) is a world rotation; the local
    rotation is ``G_parent* r_j`` (the identity for joints without rotation channels).  Encoding: world
    rotations and root-relative positions (torch FK), eq. 6, signs chosen in torch by numpy's rule (frame 0 real
    ``w >= 0``, then the real part closest to the frame before)."""

    def decode(self, features: torch.Tensor, skeleton: Skeleton):
        lay = _layout(skeleton)
        root, jt = layout_split(lay, features)
        real = quat_normalize(layout_blocks(lay, features)[..., :4])  # (..., F, J, 4)
        identity = torch.zeros_like(real[..., :1, :])
        identity[..., 3] = 1.0
        world = torch.cat([real, identity], dim=-2)
        src, parent = _sources(skeleton)
        local = quat_multiply(quat_conjugate(_gather(world, parent)), _gather(world, src))
        rotated = torch.tensor([bool(o) for o in skeleton.rotation_orders], device=features.device)[:, None]
        return root, torch.where(rotated, local, identity), jt

    def encode(self, skeleton: Skeleton, root_translation, rotations, joint_translations, reference=None):
        J = skeleton.num_joints
        g = [rotations[:, 0]] + [None] * (J - 1)  # world rotations, unnormalised products as numpy's
        for idx in _levels(skeleton):
            for j in idx.tolist():
                g[j] = quat_multiply(g[int(skeleton.parents[j])], rotations[:, j])
        rot = torch.stack(g, dim=1)
        pos = global_positions(skeleton, root_translation, rotations, joint_translations)[:, :J]
        dq = dualquat_from_rotation_translation(rot, pos - pos[:, :1])
        with torch.no_grad():
            first = torch.where(dq[:1, :, 3:4] < 0, -1.0, 1.0).to(dq.dtype)
            flips = torch.where((dq[1:, ..., :4] * dq[:-1, ..., :4]).sum(-1) < 0, -1.0, 1.0)
            signs = torch.cat([torch.ones_like(dq[:1, :, 0]), torch.cumprod(flips.to(dq.dtype), dim=0)], dim=0)
        dq = dq * first * signs[..., None]
        return layout_assemble(_layout(skeleton), root_translation, list(dq.unbind(1)), joint_translations)
