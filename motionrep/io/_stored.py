"""What the NPZ and HDF5 formats share: the logical fields of a stored clip, how they are encoded, and the
validating decoder both readers run.

A stored clip is a set of named scalars (NPZ: 0-d arrays; HDF5: attributes) and named arrays (NPZ: archive
members; HDF5: datasets).  The formats differ only in where each field lives and in how ``euler_branch`` is
packed; each supplies a :class:`ClipSource` and this module does the validation, so both refuse the same
mistakes with the same messages.  Field names and meanings are documented in ``specs/formats/npz.md`` and
``specs/formats/hdf5.md``.
"""

from __future__ import annotations

import math
import os
from abc import ABC, abstractmethod
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..limits import ENVIRONMENT, check_clip
from ..limits import current as current_limits
from ..model._pose import Motion, Skeleton
from ..errors import FormatError, ValidationError
from ._features import FeatureClip

__all__ = [
    "QUAT_ORDER",
    "KIND_MOTION",
    "KIND_FEATURES",
    "ClipSource",
    "decode_clip",
    "skeleton_fields",
    "motion_fields",
    "feature_fields",
    "check_clip_name",
    "check_text",
    "encode_channels",
    "packed_bits_length",
]

#: Quaternion component order written into every file.
QUAT_ORDER = "xyzw"
#: ``kind`` of a clip that stores a :class:`~motionrep.Motion`.
KIND_MOTION = "motion"
#: ``kind`` of a clip that stores a representation's features (:class:`~motionrep.io.FeatureClip`).
KIND_FEATURES = "features"

def check_text(value: str, what: str) -> str:
    """Refuse strings that fixed-width numpy unicode and HDF5 C strings cannot keep (NUL characters)."""
    if "\x00" in value:
        raise ValidationError(f"{what} {value!r} contains a NUL character, which NPZ and HDF5 files cannot store")
    return value


def check_clip_name(name: Any, path: str | os.PathLike[str] | None, error: type[FormatError]) -> str:
    """Validate a clip name: a non-empty string without ``/`` or NUL, and not ``.`` or ``..``."""
    if not isinstance(name, str) or not name:
        raise error(f"invalid clip name {name!r}: clip names must be non-empty strings", path)
    if "/" in name or "\x00" in name or name in (".", ".."):
        raise error(f"invalid clip name {name!r}: clip names may not contain '/' or NUL, nor be '.' or '..'",
                    path)
    return name


def encode_channels(channels: tuple[tuple[str, ...], ...]) -> list[str]:
    """Per joint, its BVH channel names in file order joined by single spaces (``""`` for none)."""
    return [" ".join(ch) for ch in channels]


def skeleton_fields(sk: Skeleton) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(scalars, arrays)`` of a skeleton: ``units`` (when known) and the six skeleton arrays.

    String arrays are returned as lists of ``str``; each format chooses its string encoding.
    """
    for n in sk.names:
        check_text(n, "joint name")
    if sk.units is not None:
        check_text(sk.units, "units")
    scalars: dict[str, Any] = {} if sk.units is None else {"units": sk.units}
    arrays = {
        "names": list(sk.names),
        "parents": np.asarray(sk.parents, dtype=np.int64),
        "offsets": np.asarray(sk.offsets, dtype=np.float64),
        "channels": encode_channels(sk.channels),
        "end_site_parents": np.asarray(sk.end_site_parents, dtype=np.int64),
        "end_site_offsets": np.asarray(sk.end_site_offsets, dtype=np.float64).reshape(-1, 3),
    }
    return scalars, arrays


def motion_fields(motion: Motion) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(scalars, arrays)`` of a motion clip (skeleton arrays are separate, see :func:`skeleton_fields`).

    ``euler_branch`` is returned as an ``(F, J)`` bool array (or absent); each format packs it its own way.
    """
    scalars = {"kind": KIND_MOTION, "quat_order": QUAT_ORDER, "fps": float(motion.fps)}
    arrays: dict[str, Any] = {
        "root_translation": motion.root_translation,
        "rotations": motion.rotations,
        "joint_translations": motion.joint_translations,
    }
    if motion.euler_branch is not None:
        arrays["euler_branch"] = motion.euler_branch
    if motion.euler_angles is not None:
        arrays["euler_angles"] = motion.euler_angles
    return scalars, arrays


def feature_fields(clip: FeatureClip) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(scalars, arrays)`` of a feature clip (skeleton arrays are separate)."""
    check_text(clip.representation, "representation name")
    for n in clip.feature_names:
        check_text(n, "feature name")
    scalars = {"kind": KIND_FEATURES, "quat_order": QUAT_ORDER, "fps": float(clip.fps),
               "representation": clip.representation,
               "representation_version": int(clip.representation_version)}
    arrays = {"features": clip.features, "feature_names": list(clip.feature_names)}
    return scalars, arrays


# ---------------------------------------------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------------------------------------------
class ClipSource(ABC):
    """Access to one stored clip's fields, by logical name, for :func:`decode_clip`.

    Logical names: the scalars ``kind``, ``quat_order``, ``fps``, ``units``, ``representation``,
    ``representation_version``; the skeleton arrays ``skeleton.names``, ``skeleton.parents``, ``skeleton.offsets``,
    ``skeleton.channels``, ``skeleton.end_site_parents``, ``skeleton.end_site_offsets``; the arrays
    ``root_translation``, ``rotations``, ``joint_translations``, ``euler_angles``, ``features``, ``feature_names``.
    ``euler_branch`` is read through :meth:`euler_branch` because the formats pack it differently.
    """

    def __init__(self, path: str | os.PathLike[str], clip: str | None, error: type[FormatError]):
        self.path = path
        self.clip = clip
        self.error = error

    def fail(self, message: str) -> FormatError:
        """The error to raise: names the file (and the clip, for databases)."""
        prefix = f"clip {self.clip!r}: " if self.clip is not None else ""
        return self.error(prefix + message, self.path)

    @abstractmethod
    def where(self, key: str) -> str:
        """How the field is named in messages (``"key 'rotations'"``, ``"dataset 'rotations'"``)."""

    @abstractmethod
    def has(self, key: str) -> bool:
        """Whether the field is stored."""

    @abstractmethod
    def scalar(self, key: str) -> Any:
        """The stored scalar (a Python or numpy scalar, a str, bytes, or a 0-d array)."""

    @abstractmethod
    def shape_dtype(self, key: str) -> tuple[tuple[int, ...], np.dtype]:
        """Shape and dtype of a stored array, without reading its data."""

    @abstractmethod
    def array(self, key: str) -> NDArray[Any]:
        """The stored array's data.  Implementations refuse an array larger than the ``max_clip_bytes`` limit
        (see :meth:`check_size`) before reading it."""

    @abstractmethod
    def strings(self, key: str) -> list[str]:
        """A stored 1-d array of strings, decoded to ``str``."""

    @abstractmethod
    def euler_branch(self, frames: int, joints: int) -> NDArray[np.bool_] | None:
        """The ``(F, J)`` Euler-branch hint, or None when absent."""

    # ---- typed access --------------------------------------------------------------------------------------
    def check_size(self, key: str, shape: tuple[int, ...], itemsize: int) -> None:
        """Refuse an array whose data would take more than the ``max_clip_bytes`` limit (before reading it)."""
        size = math.prod(int(s) for s in shape) * int(itemsize)
        lim = current_limits()
        if size > lim.max_clip_bytes:
            raise self.fail(f"{self.where(key)} declares shape {tuple(shape)}: {size} bytes, more than the limit of "
                            f"{lim.max_clip_bytes} (raise {ENVIRONMENT['max_clip_bytes']} to read it)")

    def require(self, key: str) -> None:
        if not self.has(key):
            raise self.fail(f"missing {self.where(key)}")

    def text(self, key: str, required: bool = True) -> str | None:
        if not self.has(key):
            if required:
                raise self.fail(f"missing {self.where(key)}")
            return None
        value = self.scalar(key)
        if isinstance(value, np.ndarray):
            if value.ndim != 0:
                raise self.fail(f"{self.where(key)} must be a single string, got an array of shape {value.shape}")
            value = value[()]
        if isinstance(value, (bytes, np.bytes_)):
            try:
                value = bytes(value).decode("utf-8")
            except UnicodeDecodeError:
                raise self.fail(f"{self.where(key)} is not valid UTF-8") from None
        if not isinstance(value, str):
            raise self.fail(f"{self.where(key)} must be a string, got {type(value).__name__}")
        return str(value)

    def number(self, key: str, integer: bool) -> float | int:
        self.require(key)
        value = self.scalar(key)
        a = np.asarray(value)
        kinds = "iu" if integer else "iuf"
        if a.ndim != 0 or a.dtype.kind not in kinds:
            want = "an integer" if integer else "a number"
            raise self.fail(f"{self.where(key)} must be {want}, got {value!r}")
        return int(a) if integer else float(a)

    def checked_array(self, key: str, shape: tuple[int | None, ...], kinds: str, what: str) -> NDArray[Any]:
        """Read ``key`` after checking its dtype kind and shape (``None`` matches any length)."""
        self.require(key)
        got_shape, dtype = self.shape_dtype(key)
        if dtype.kind not in kinds:
            raise self.fail(f"{self.where(key)} must hold {what}, got dtype {dtype}")
        if len(got_shape) != len(shape) or any(s is not None and s != g for s, g in zip(shape, got_shape)):
            want = "(" + ", ".join("?" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
            raise self.fail(f"{self.where(key)} has shape {tuple(got_shape)}, expected {want}")
        return self.array(key)

    def checked_strings(self, key: str, length: int | None) -> list[str]:
        self.require(key)
        got_shape, _ = self.shape_dtype(key)
        if len(got_shape) != 1 or (length is not None and got_shape[0] != length):
            want = "(?,)" if length is None else f"({length},)"
            raise self.fail(f"{self.where(key)} has shape {tuple(got_shape)}, expected {want}")
        return self.strings(key)


_FLOAT = "fiu"
_INT = "iu"


def _skeleton(src: ClipSource) -> Skeleton:
    names = src.checked_strings("skeleton.names", None)
    J = len(names)
    if J == 0:
        raise src.fail(f"{src.where('skeleton.names')} is empty: a skeleton needs at least one joint")
    parents = src.checked_array("skeleton.parents", (J,), _INT, "integers")
    offsets = src.checked_array("skeleton.offsets", (J, 3), _FLOAT, "numbers")
    channels = src.checked_strings("skeleton.channels", J)
    esp = src.checked_array("skeleton.end_site_parents", (None,), _INT, "integers")
    eso = src.checked_array("skeleton.end_site_offsets", (esp.shape[0], 3), _FLOAT, "numbers")
    units = src.text("units", required=False)
    try:
        return Skeleton(names=tuple(names), parents=parents, offsets=np.asarray(offsets, dtype=np.float64),
                        channels=tuple(tuple(c.split()) for c in channels), end_site_parents=esp,
                        end_site_offsets=np.asarray(eso, dtype=np.float64), units=units)
    except ValidationError as exc:
        raise src.fail(f"invalid skeleton: {exc}") from None


def decode_clip(src: ClipSource) -> Motion | FeatureClip:
    """Validate and decode one stored clip.

    Raises:
        FormatError: (the source's subclass) naming the file, the clip and the field, for a missing field, a
            wrong shape or dtype, or values the pose model refuses.
    """
    kind = src.text("kind")
    if kind not in (KIND_MOTION, KIND_FEATURES):
        raise src.fail(f"{src.where('kind')} is {kind!r}, expected {KIND_MOTION!r} or {KIND_FEATURES!r}")
    order = src.text("quat_order")
    if order != QUAT_ORDER:
        raise src.fail(f"{src.where('quat_order')} is {order!r}; motionrep files store quaternions as "
                       f"{QUAT_ORDER!r}")
    fps = src.number("fps", integer=False)
    _check_clip_size(src, kind)
    skeleton = _skeleton(src)
    J = skeleton.num_joints
    try:
        if kind == KIND_FEATURES:
            rep = src.text("representation")
            version = src.number("representation_version", integer=True)
            features = src.checked_array("features", (None, None), _FLOAT, "numbers")
            names = src.checked_strings("feature_names", features.shape[1])
            return FeatureClip(skeleton, fps, rep, version, np.asarray(features, dtype=np.float64), tuple(names))
        if not src.has("rotations") and any(src.has(k) for k in ("channel_deltas", "channel_values")):
            return _decode_channels(src, skeleton, fps)
        rotations = src.checked_array("rotations", (None, J, 4), _FLOAT, "numbers")
        F = rotations.shape[0]
        if F == 0:
            raise src.fail(f"{src.where('rotations')} has no frames")
        root = src.checked_array("root_translation", (F, 3), _FLOAT, "numbers")
        P = skeleton.translated_joints.shape[0]
        jt = src.checked_array("joint_translations", (F, P, 3), _FLOAT, "numbers")
        branch = src.euler_branch(F, J)
        angles = None
        if src.has("euler_angles"):
            angles = src.checked_array("euler_angles", (F, skeleton.num_rotation_channels), _FLOAT, "numbers")
            angles = np.asarray(angles, dtype=np.float64)
        return Motion(skeleton, fps, np.asarray(root, dtype=np.float64), np.asarray(rotations, dtype=np.float64),
                      np.asarray(jt, dtype=np.float64), euler_branch=branch, euler_angles=angles)
    except ValidationError as exc:
        raise src.fail(str(exc)) from None


def _decode_channels(src: ClipSource, skeleton: Skeleton, fps: float) -> Motion:
    """A motion stored as its channel values (the compact layout of format version 3, ``_compact``)."""
    from ._compact import MAX_DIGITS, channel_matrix, motion_from_channel_arrays

    C = skeleton.num_channels
    key = "channel_deltas" if src.has("channel_deltas") else "channel_values"
    shape, _ = src.shape_dtype(key)
    if len(shape) != 2 or int(shape[1]) != C:
        raise src.fail(f"{src.where(key)} has shape {tuple(shape)}, expected (?, {C})")
    F = int(shape[0])
    if F == 0:
        raise src.fail(f"{src.where(key)} has no frames")
    reason = check_clip(F, src.where(key), joints=skeleton.num_joints,
                        translated=int(skeleton.translated_joints.shape[0]), angles=skeleton.num_rotation_channels)
    if reason:
        raise src.fail(reason)
    if key == "channel_values":
        values = np.asarray(src.checked_array(key, (F, C), _FLOAT, "numbers"), dtype=np.float64)
    else:
        deltas = src.checked_array(key, (F, C), _INT, "integers")
        digits = src.checked_array("channel_digits", (C,), _INT, "integers")
        if np.any(digits < 0) or np.any(digits > MAX_DIGITS):
            raise src.fail(f"{src.where('channel_digits')} must hold digit counts from 0 to {MAX_DIGITS}")
        patches = src.checked_array("channel_patches", (None,), _INT, "integers")
        if patches.size > F * C or np.any(patches < 0) or np.any(patches >= F * C):
            raise src.fail(f"{src.where('channel_patches')} must hold indices of values, below {F * C}")
        patch_values = src.checked_array("channel_patch_values", (patches.size,), _FLOAT, "numbers")
        if deltas.dtype.kind == "u" and deltas.dtype.itemsize == 8:
            raise src.fail(f"{src.where(key)} must hold signed integers, got dtype {deltas.dtype}")
        with np.errstate(all="ignore"):  # float64 sums cannot wrap round as int64 ones do
            reach = np.abs(np.cumsum(deltas, axis=0, dtype=np.float64)).max(initial=0.0)
        if not reach < 2.0 ** 53:
            raise src.fail(f"{src.where(key)} adds up to integers beyond 2**53 (no decimal motionrep writes)")
        values = channel_matrix(digits, deltas, patches, np.asarray(patch_values, dtype=np.float64))
    if not np.all(np.isfinite(values)):
        raise src.fail(f"{src.where(key)} holds values that are not finite")
    return motion_from_channel_arrays(skeleton, fps, values)


def _check_clip_size(src: ClipSource, kind: str) -> None:
    """Refuse a clip whose declared frame data exceeds the limits, from shapes alone (nothing is read yet)."""
    if kind == KIND_MOTION and not src.has("rotations") and any(
            src.has(k) for k in ("channel_deltas", "channel_values")):
        return  # the compact layout: checked by _decode_channels once the skeleton is known
    key = "features" if kind == KIND_FEATURES else "rotations"
    src.require(key)
    shape, _ = src.shape_dtype(key)
    if len(shape) < 2:
        return  # the shape check that follows names the problem
    frames, width = int(shape[0]), int(shape[1])
    if kind == KIND_FEATURES:
        reason = check_clip(frames, src.where(key), features=width)
    else:
        reason = check_clip(frames, src.where(key), joints=width, angles=3 * width)
    if reason:
        raise src.fail(reason)


def packed_bits_length(frames: int, joints: int) -> int:
    """Bytes of an ``(F, J)`` bool array packed with :func:`numpy.packbits`."""
    return math.ceil(frames * joints / 8)

