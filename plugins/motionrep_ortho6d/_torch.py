"""The torch path of ``ortho6d`` (imported by ``Ortho6D.torch_path`` only, so the plugin never imports torch)."""

from __future__ import annotations

import torch

from motionrep import Skeleton
from motionrep.plugin.representation import TorchPath
from motionrep.torch import layout_assemble, layout_blocks, layout_place, layout_split
from motionrep.torch.rotations import ortho6d_to_quat, quat_to_ortho6d

from ._rep import _layout

__all__ = ["Ortho6DTorch"]


class Ortho6DTorch(TorchPath):
    """Gram-Schmidt of the two columns (roma), the matrix's quaternion with ``w >= 0``, as the numpy decoder."""

    def decode(self, features: torch.Tensor, skeleton: Skeleton):
        lay = _layout(skeleton)
        root, jt = layout_split(lay, features)
        six = layout_blocks(lay, features)
        quats = ortho6d_to_quat(six) if six.shape[-1] else six.new_zeros(six.shape[:-1] + (4,))
        return root, layout_place(skeleton, lay.rotation_joints, quats), jt

    def encode(self, skeleton: Skeleton, root_translation, rotations, joint_translations, reference=None):
        lay = _layout(skeleton)
        six = quat_to_ortho6d(rotations[:, torch.tensor(lay.rotation_joints.copy(), device=rotations.device)])
        return layout_assemble(lay, root_translation, list(six.unbind(1)), joint_translations)
