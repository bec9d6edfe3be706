"""AMASS / SMPL-H parameters in: an AMASS ``.npz`` clip posed through an SMPL-H body model the user gives
(``body_model=`` or the environment variable ``MOTIONREP_SMPLH_MODEL``; these model files are licensed and never
shipped).  ``specs/formats/amass.md``.

The skeleton is the body model's: its joints regressed from the shaped template
(``J = J_regressor @ (v_template + shapedirs @ betas)``), its tree from ``kintree_table``, each OFFSET the joint
minus its parent.  The poses' axis-angle vectors are the local rotations, ``trans`` is added to the root, and the
clip runs at ``mocap_framerate``.  The FK of the motion is then the body model's posed joints (the kinematic
chain of ``kintree_table`` applied to ``J``) plus ``trans``, the same products as the body model computes.
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..model._pose import Motion, Skeleton
from ..errors import AMASSFormatError, ValidationError, naming
from ._files import check_regular

__all__ = ["read_amass", "is_amass_keys", "body_model_joints", "SMPLH_JOINT_NAMES", "BODY_MODEL_ENV"]

#: The environment variable naming the body model file when ``body_model=`` (``--body-model``) is not given.
BODY_MODEL_ENV = "MOTIONREP_SMPLH_MODEL"

_BODY = ("pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee", "spine2", "left_ankle",
         "right_ankle", "spine3", "left_foot", "right_foot", "neck", "left_collar", "right_collar", "head",
         "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist")
_FINGERS = tuple(f"{finger}{k}" for finger in ("index", "middle", "pinky", "ring", "thumb") for k in (1, 2, 3))
#: SMPL-H's 52 joints in the body model's order: 22 body joints, then 15 of the left hand and 15 of the right.
SMPLH_JOINT_NAMES: tuple[str, ...] = _BODY + tuple(f"left_{f}" for f in _FINGERS) + tuple(f"right_{f}" for f in _FINGERS)
_SMPL_NAMES = _BODY + ("left_hand", "right_hand")  # SMPL's 24
_MAX_FRAMES = 10_000_000
_MAX_MODEL_VALUES = 1 << 28


def is_amass_keys(keys: set[str] | Any) -> bool:
    """True for the keys of an AMASS clip (``poses`` and ``trans``, no motionrep ``format`` key)."""
    keys = set(keys)
    return "format" not in keys and {"poses", "trans"} <= keys


def _load(path: Path, what: str) -> Any:
    if not path.exists():
        raise AMASSFormatError(f"{what}: no such file", path)
    check_regular(path, AMASSFormatError)  # regular files only: numpy opens by name and would block on a FIFO
    try:
        return np.load(path, allow_pickle=False)
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise AMASSFormatError(f"{what}: not a numpy archive ({' '.join(str(exc).split())[:200]})", path) from None


def _array(archive: Any, key: str, path: Path, what: str) -> NDArray:
    if key not in archive.files:
        raise AMASSFormatError(f"{what} has no {key!r} (keys: {', '.join(sorted(archive.files)[:12])})", path)
    try:
        value = archive[key]
    except ValueError as exc:  # object arrays need pickle, which motionrep never loads
        raise AMASSFormatError(f"{what}: {key!r} is a pickled object, which motionrep does not load "
                               f"(store it as a numeric array): {exc}", path) from None
    except Exception as exc:  # a damaged member: zlib, zipfile, numpy errors
        raise AMASSFormatError(f"{what}: {key!r} cannot be read ({type(exc).__name__}: {exc})", path) from None
    return value


def _numeric(value: NDArray, key: str, shape: tuple[int | None, ...], path: Path, what: str) -> NDArray[np.float64]:
    if value.dtype.kind not in "fiu" or value.ndim != len(shape) or any(
            s is not None and s != n for s, n in zip(shape, value.shape)):
        want = "(" + ", ".join("?" if s is None else str(s) for s in shape) + ")"
        raise AMASSFormatError(f"{what}: {key!r} must be a numeric {want} array, got {value.dtype} {value.shape}",
                               path)
    out = value.astype(np.float64)
    if not np.all(np.isfinite(out)):
        raise AMASSFormatError(f"{what}: {key!r} holds non-finite values", path)
    return out


def body_model_joints(body_model: str | os.PathLike[str], betas: NDArray | None = None
                      ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """``(parents (J,), joints (J, 3))``: the body model's tree and its joints regressed from the template shaped
    by ``betas`` (the first ``min(len(betas), shapedirs.shape[2])`` of them, as the SMPL family's code does).

    Raises:
        AMASSFormatError: naming the body model file when it lacks a key or has one of the wrong shape.
    """
    path = Path(body_model)
    what = "body model"
    with _load(path, what) as model:
        template = _numeric(_array(model, "v_template", path, what), "v_template", (None, 3), path, what)
        V = template.shape[0]
        shapedirs = _numeric(_array(model, "shapedirs", path, what), "shapedirs", (V, 3, None), path, what)
        regressor = _numeric(_array(model, "J_regressor", path, what), "J_regressor", (None, V), path, what)
        kintree = _numeric(_array(model, "kintree_table", path, what), "kintree_table", (2, None), path, what)
    J = regressor.shape[0]
    if kintree.shape[1] != J or J == 0:
        raise AMASSFormatError(f"{what}: kintree_table has {kintree.shape[1]} joints but J_regressor {J}", path)
    if V * (J + 3 * shapedirs.shape[2]) > _MAX_MODEL_VALUES:
        raise AMASSFormatError(f"{what}: too large ({V} vertices, {J} joints)", path)
    raw = kintree[0]
    parents = np.where((raw < 0) | (raw >= 2**31), -1, raw).astype(np.int64)
    if parents[0] != -1 or np.any(parents[1:] < 0) or np.any(parents[1:] >= np.arange(1, J)):
        raise AMASSFormatError(f"{what}: kintree_table is not a tree rooted at joint 0 with every parent before "
                               "its children", path)
    shaped = template
    if betas is not None and betas.size:
        n = min(betas.size, shapedirs.shape[2])
        shaped = template + shapedirs[:, :, :n] @ betas[:n]
    return parents, regressor @ shaped


def read_amass(path: str | os.PathLike[str], body_model: str | os.PathLike[str] | None = None) -> Motion:
    """Read an AMASS ``.npz`` clip through an SMPL-H (or SMPL-family) body model.

    Args:
        path: the AMASS file: ``poses`` ``(F, 3 J)`` axis-angle per joint in radians, ``trans`` ``(F, 3)`` metres,
            ``betas`` (shape coefficients), ``gender``, ``mocap_framerate`` (or ``mocap_frame_rate``).
        body_model: the body model ``.npz`` (``v_template``, ``shapedirs``, ``J_regressor``, ``kintree_table``);
            default: the file the environment variable ``MOTIONREP_SMPLH_MODEL`` names.

    Returns:
        A Motion in metres at the capture frame rate, joints named as SMPL-H's (``pelvis``, ``left_hip``...), root
        translation ``J[0] + trans``; its FK equals the body model's posed joints plus ``trans``.

    Raises:
        AMASSFormatError: naming the file: no body model given, a key missing or of the wrong shape, a body model
            whose joint count does not fit the poses.
    """
    path = Path(path)
    if body_model is None:
        body_model = os.environ.get(BODY_MODEL_ENV) or None
    if body_model is None:
        raise naming(AMASSFormatError("is an AMASS clip: give its SMPL-H body model with body_model=MODEL.npz "
                                      f"(or the environment variable {BODY_MODEL_ENV})", path), "body_model=MODEL.npz")
    what = "AMASS clip"
    with _load(path, what) as clip:
        poses = _array(clip, "poses", path, what)
        trans = _array(clip, "trans", path, what)
        betas = _array(clip, "betas", path, what) if "betas" in clip.files else np.zeros(0)
        rate_key = "mocap_framerate" if "mocap_framerate" in clip.files else "mocap_frame_rate"
        rate = _array(clip, rate_key, path, what)
    poses = _numeric(poses, "poses", (None, None), path, what)
    F = poses.shape[0]
    if F == 0 or F > _MAX_FRAMES:
        raise AMASSFormatError(f"{what}: 'poses' has {F} frames", path)
    trans = _numeric(trans, "trans", (F, 3), path, what)
    betas = _numeric(betas.reshape(-1), "betas", (None,), path, what)
    rate = _numeric(rate.reshape(-1), rate_key, (1,), path, what)
    fps = float(rate[0])
    if not fps > 0:
        raise AMASSFormatError(f"{what}: {rate_key} is {fps!r}, not a frame rate", path)
    parents, joints = body_model_joints(body_model, betas)
    J = parents.size
    if poses.shape[1] != 3 * J:
        raise AMASSFormatError(f"{what}: 'poses' has {poses.shape[1]} values per frame but the body model "
                               f"{Path(body_model)} has {J} joints ({3 * J} values); give the body model these "
                               "poses were made for", path)
    from ..model.rotations import axis_angle_to_quat

    rotations = axis_angle_to_quat(poses.reshape(F, J, 3))
    offsets = joints.copy()
    offsets[1:] -= joints[parents[1:]]
    names = SMPLH_JOINT_NAMES if J == 52 else (_SMPL_NAMES if J == 24 else tuple(f"joint{k}" for k in range(J)))
    try:
        skeleton = Skeleton(names=names, parents=parents, offsets=offsets, units="m")
        return Motion(skeleton, fps, joints[0] + trans, rotations)
    except ValidationError as exc:
        raise AMASSFormatError(f"{what}: {exc}", path) from None
