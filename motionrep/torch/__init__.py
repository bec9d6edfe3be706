"""motionrep in torch: forward kinematics, rotations, every representation's features, losses and errors,
differentiable, on any device and dtype (``pip install motionrep[torch]``; see ``specs/torch.md``).

``import motionrep`` never imports this package (nor torch); import it explicitly::

    import motionrep.torch as mt

    root, rot, jt = mt.decode_features("ortho6d", features, skeleton)      # (..., F, D) -> poses
    positions = mt.global_positions(skeleton, root, rot, jt)              # (..., F, J + E, 3)
    loss = mt.fk_position_loss("ortho6d", predicted, target, skeleton)
    mt.write_features("generated.bvh", "ortho6d", predicted[0], skeleton, fps=30)
"""

from __future__ import annotations

try:
    import torch as _torch  # noqa: F401
except ImportError as exc:  # pragma: no cover - exercised where torch is absent
    raise ImportError("motionrep.torch needs torch and roma: pip install torch, then pip install "
                      "'motionrep[torch]'") from exc

from . import rotations
from ._dataset import MotionDataset, WindowSampler
from ._dualquat import (dualquat_conjugate, dualquat_from_rotation_translation, dualquat_multiply,
                        dualquat_normalize, dualquat_to_rotation_translation)
from ._features import (decode_features, encode_features, features_to_motion, layout_assemble, layout_blocks,
                        layout_place, layout_split, motion_tensors, torch_path_of, write_features)
from ._kinematics import forward_kinematics, global_positions
from ._losses import (JointError, dq_mse_loss, dq_offset_loss, dq_pos_loss, dq_quat_loss, dq_reg_loss,
                      dualquats_of_features, fk_position_loss, max_joint_error)
from ._split import split_clips
from ._stats import FeatureStats


__all__ = [
    "rotations",
    "forward_kinematics",
    "global_positions",
    "encode_features",
    "decode_features",
    "features_to_motion",
    "write_features",
    "motion_tensors",
    "torch_path_of",
    "layout_split",
    "layout_blocks",
    "layout_place",
    "layout_assemble",
    "dualquat_multiply",
    "dualquat_conjugate",
    "dualquat_normalize",
    "dualquat_from_rotation_translation",
    "dualquat_to_rotation_translation",
    "dualquats_of_features",
    "dq_mse_loss",
    "dq_quat_loss",
    "dq_pos_loss",
    "dq_offset_loss",
    "dq_reg_loss",
    "fk_position_loss",
    "max_joint_error",
    "JointError",
    "MotionDataset",
    "WindowSampler",
    "FeatureStats",
    "split_clips",
]
