"""Features in torch: encoding, decoding (through a representation's torch path), the way back to a Motion and
to files, and the helpers the shipped representations' torch paths share (the column layout on tensors)."""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import torch

from ..model._pose import Motion, Skeleton
from ..errors import ValidationError
from ..plugin.representation import FeatureLayout, Representation, TorchPath

__all__ = ["encode_features", "decode_features", "features_to_motion", "write_features", "torch_path_of",
           "layout_split", "layout_blocks", "layout_place", "layout_assemble", "motion_tensors"]


def _representation(representation: str | Representation) -> Representation:
    if isinstance(representation, Representation):
        return representation
    from ..plugin.registry import get_representation

    return get_representation(representation)


def torch_path_of(representation: str | Representation) -> TorchPath:
    """The :class:`~motionrep.plugin.representation.TorchPath` of a representation (a registered name or an instance).

    Raises:
        ValidationError: if the representation has no torch path (its numpy path still works everywhere).
        UnknownPluginError: if no plugin provides the name.
    """
    rep = _representation(representation)
    path = rep.torch_path()
    if path is None:
        raise ValidationError(f"representation {rep.name!r} has no torch path (Representation.torch_path); "
                              "use its numpy to_features / from_features")
    return path


def motion_tensors(motion: Motion, dtype: torch.dtype = torch.float64, device: torch.device | str | None = None
                   ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """``(root_translation (F, 3), rotations (F, J, 4), joint_translations (F, P, 3))`` of ``motion`` as tensors."""
    return tuple(torch.tensor(np.array(a), dtype=dtype, device=device)  # type: ignore[return-value]
                 for a in (motion.root_translation, motion.rotations, motion.joint_translations))


def encode_features(representation: str | Representation, motion: Motion, *, dtype: torch.dtype = torch.float64,
                    device: torch.device | str | None = None) -> torch.Tensor:
    """``(F, D)`` features of ``motion`` as a tensor of ``dtype`` on ``device``.

    Through the representation's torch path when it has one (the arithmetic in torch, in float64, then cast;
    the discrete choices from its numpy features), else its numpy ``to_features``.
    """
    rep = _representation(representation)
    reference = rep.to_features(motion)
    path = rep.torch_path()
    if path is None:
        return torch.tensor(reference, dtype=dtype, device=device)
    root, rot, jt = motion_tensors(motion, torch.float64, device)
    return path.encode(motion.skeleton, root, rot, jt, reference=reference).to(dtype)


def decode_features(representation: str | Representation, features: torch.Tensor, skeleton: Skeleton
                    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """``(..., F, D)`` features to ``(root_translation (..., F, 3), rotations (..., F, J, 4) xyzw,
    joint_translations (..., F, P, 3))``, differentiable in ``features``.

    Raises:
        ValidationError: for features of the wrong width, or a representation without a torch path.
    """
    rep = _representation(representation)
    path = torch_path_of(rep)
    if not isinstance(features, torch.Tensor) or features.ndim < 2 or features.shape[-1] != rep.width(skeleton):
        raise ValidationError(f"representation {rep.name!r} expects a tensor of features of shape (..., frames, "
                              f"{rep.width(skeleton)}) for this skeleton, got "
                              f"{tuple(getattr(features, 'shape', ()))}")
    return path.decode(features, skeleton)


def features_to_motion(representation: str | Representation, features: Any, skeleton: Skeleton,
                       fps: float) -> Motion:
    """A network's ``(F, D)`` output features (a tensor, detached and copied here, or an array) as a
    :class:`~motionrep.Motion`, through the representation's numpy decoder (its ``from_features``: the very
    Motion ``motionrep`` would decode, Euler branch hints included), with the translation axes that have no
    position channel set back to their OFFSET as ``motionrep decompress`` does (:func:`motionrep.model.ops.fixed_axes_restored`),
    so that it can be written to BVH.  Rotations about axes a joint has no channel for are not projected away: a
    skeleton with 1- or 2-axis joints is written to BVH from ``euler`` features (or from float64 features of the
    other representations, whose round trip is exact there).

    Raises:
        ValidationError: for features that are not ``(F, D)`` for ``skeleton`` or not finite.
    """
    from ..model.ops import fixed_axes_restored

    rep = _representation(representation)
    if isinstance(features, torch.Tensor):
        features = features.detach().to("cpu", torch.float64).numpy()
    return fixed_axes_restored(rep.from_features(np.asarray(features, dtype=np.float64), skeleton, fps))


def write_features(path: str | os.PathLike[str], representation: str | Representation, features: Any,
                   skeleton: Skeleton, fps: float, **options) -> Motion:
    """Decode ``(F, D)`` features (:func:`features_to_motion`) and write the Motion to ``path`` in any format
    motionrep writes (``.bvh``, ``.gltf`` / ``.glb``, ``.h5``, ``.npz``; :func:`motionrep.io.write`, atomic,
    ``options`` as there).  Returns the Motion written."""
    from ..io import write

    motion = features_to_motion(representation, features, skeleton, fps)
    write(motion, path, **options)
    return motion


# --- the column layout of motionrep.plugin.representation.FeatureLayout, on tensors --------------------------------
def _index(a: np.ndarray, device: torch.device) -> torch.Tensor:
    return torch.tensor(np.array(a, np.int64), device=device)


def layout_split(layout: FeatureLayout, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """``(..., F, 3)`` root translation and ``(..., F, P, 3)`` joint translations of ``(..., F, D)`` features."""
    cols = layout.translation_columns
    jt = features[..., _index(cols.reshape(-1), features.device)].reshape(features.shape[:-1] + cols.shape)
    return features[..., :3], jt


def layout_blocks(layout: FeatureLayout, features: torch.Tensor, which: list[int] | None = None) -> torch.Tensor:
    """``(..., F, R, k)`` rotation blocks of ``(..., F, D)`` features (the entries ``which`` of
    ``layout.rotation_joints``, default all), when those blocks all have ``k`` columns."""
    cols = [layout.rotation_columns[r] for r in (range(len(layout.rotation_columns)) if which is None else which)]
    if not cols:
        return features[..., :0].reshape(features.shape[:-1] + (0, 0))
    index = np.stack(cols)
    flat = features[..., _index(index.reshape(-1), features.device)]
    return flat.reshape(features.shape[:-1] + index.shape)


def layout_place(skeleton: Skeleton, joints: np.ndarray, quats: torch.Tensor) -> torch.Tensor:
    """``(..., F, J, 4)`` local rotations: ``quats (..., F, R, 4)`` at ``joints (R,)``, the identity elsewhere."""
    J = skeleton.num_joints
    if len(joints) == J and np.array_equal(joints, np.arange(J)):
        return quats
    out = torch.zeros(quats.shape[:-2] + (J, 4), dtype=quats.dtype, device=quats.device)
    out[..., 3] = 1.0
    out[..., _index(joints, quats.device), :] = quats
    return out


def layout_assemble(layout: FeatureLayout, root: torch.Tensor, blocks: list[torch.Tensor],
                    joint_translations: torch.Tensor) -> torch.Tensor:
    """``(F, D)`` features of ``root (F, 3)``, ``blocks`` (``(F, k_j)`` per entry of ``layout.rotation_joints``)
    and ``joint_translations (F, P, 3)``, in the layout's column order."""
    columns = [np.arange(3)] + list(layout.rotation_columns) + list(layout.translation_columns)
    values = [root] + list(blocks) + [joint_translations[:, k] for k in range(joint_translations.shape[1])]
    order = np.argsort(np.array([c[0] for c in columns]), kind="stable")
    parts = [values[i] for i in order]
    return torch.cat(parts, dim=-1)
