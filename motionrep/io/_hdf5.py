"""HDF5 reader and writer: one clip, or a database of named clips, each a motion or a representation's features.

The layout is ``specs/formats/hdf5.md``: root attributes ``format = "motionrep-hdf5"`` and ``format_version``
(3; versions 1 and 2 are still read), one group per clip under ``/clips``, metadata as attributes, per-frame data as
chunked gzip-compressed datasets, strings as fixed-length UTF-8, a Fletcher-32 checksum on every dataset and the
HDF5 1.10 object formats, whose metadata carries checksums too.  Quaternions are ``(F, J, 4)`` **xyzw**.  Reading
a named clip opens only that clip's group.  Every array round-trips bit for bit.  Problems raise
:class:`~motionrep.errors.HDF5FormatError` naming the file (and the clip).

Files are read through :mod:`motionrep.io._h5read`: in a worker process under a watchdog (the ``read_timeout``
limit), never following links or external storage, with every declared shape checked against the limits of
:mod:`motionrep.limits` before its data is read.

A file written by :func:`write_hdf5` is a database with one clip, named after the file's stem by default.
:class:`HDF5Database` is a file open for reading, any number of clips read from it one at a time.

Size: one concern, the HDF5 format; the writer and the reader are kept together because each is the other's
specification, and most of the length is the reader naming the file, clip and field of every malformed case.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..limits import current as current_limits
from ..model._pose import Motion
from ..errors import FormatError, HDF5FormatError, ValidationError, naming
from ._atomic import atomic_path
from ._compact import CHANNEL_KEYS, channel_arrays

if TYPE_CHECKING:  # h5py is imported by the writer only: reading runs h5py in a worker process (_h5read)
    import h5py
from ._features import FeatureClip, motion_from_features
from ._files import check_regular, open_regular
from ._h5read import H5Error, H5Reader
from ._stored import (
    KIND_FEATURES,
    KIND_MOTION,
    QUAT_ORDER,
    ClipSource,
    check_clip_name,
    decode_clip,
    feature_fields,
    motion_fields,
    skeleton_fields,
)

__all__ = [
    "HDF5_FORMAT",
    "HDF5_FORMAT_VERSION",
    "CLIPS_GROUP",
    "read_hdf5",
    "read_hdf5_clip",
    "write_hdf5",
    "write_hdf5_features",
    "write_database",
    "list_hdf5_clips",
    "iter_hdf5_clips",
    "clip_summaries",
    "default_clip_name",
    "HDF5Database",
    "open_hdf5_file",
    "root_format",
]

#: Value of the root ``format`` attribute of every motionrep HDF5 file.
HDF5_FORMAT = "motionrep-hdf5"
#: Newest HDF5 format version this motionrep writes and reads (older versions stay readable).  Version 2: a
#: Fletcher-32 checksum on every non-empty dataset, fixed-length UTF-8 strings (variable-length strings cannot
#: carry a checksum), HDF5 1.10 object formats (checksummed metadata and chunk indexes), the optional
#: ``euler_angles`` dataset.  Version 3: a clip read from BVH is stored as its channel values (decimal integers,
#: frame differences, deflated: ``motionrep.io._compact``) when they give back every array bit for bit.
HDF5_FORMAT_VERSION = 3
#: The group holding one subgroup per clip.
CLIPS_GROUP = "clips"

_GZIP_LEVEL = 4
# HDF5 1.10 object formats: the superblock, object headers (attributes), link storage and chunk indexes all carry
# checksums (1.8's version-1 B-trees of chunks do not: a damaged one silently reads zeros)
LIBVER = ("v110", "v110")
_CHUNK_BYTES = 1 << 18  # aim for chunks of about 256 KiB (h5py advises 10 KiB - 1 MiB)
_MAX_LISTED = 20


def default_clip_name(path: str | os.PathLike[str]) -> str:
    """The clip name :func:`write_hdf5` uses when none is given: the file name without its suffix."""
    return Path(path).stem


def _listing(names: list[str]) -> str:
    shown = ", ".join(names[:_MAX_LISTED])
    return shown + (f", ... ({len(names) - _MAX_LISTED} more)" if len(names) > _MAX_LISTED else "")


# ---------------------------------------------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------------------------------------------
def _attr(value: Any) -> Any:
    if isinstance(value, str):
        return value  # h5py stores str as a variable-length UTF-8 string
    if isinstance(value, (int, np.integer)):
        return np.int64(value)
    return np.float64(value)


def _dataset(group: h5py.Group, name: str, value: Any, compress: bool) -> None:
    """A dataset with a Fletcher-32 checksum (empty ones have no data to check: HDF5 cannot chunk them)."""
    import h5py

    if isinstance(value, list):  # strings: fixed-length UTF-8, NUL-padded (names never hold NUL)
        encoded = [v.encode("utf-8") for v in value]
        length = max([1, *map(len, encoded)])
        dtype = h5py.string_dtype("utf-8", length)
        a = np.array(encoded, dtype=dtype).reshape(-1)
        if a.size == 0:
            group.create_dataset(name, shape=(0,), dtype=dtype)
        else:
            group.create_dataset(name, data=a, dtype=dtype, fletcher32=True)
        return
    a = np.asarray(value)
    if a.dtype == np.bool_:
        a = a.astype(np.uint8)
    if a.size == 0:  # h5py cannot chunk empty datasets
        group.create_dataset(name, data=a)
        return
    if not compress:
        group.create_dataset(name, data=a, fletcher32=True)
        return
    row = max(1, a[0].nbytes)
    rows = int(min(a.shape[0], max(1, _CHUNK_BYTES // row)))
    group.create_dataset(name, data=a, chunks=(rows,) + a.shape[1:], compression="gzip",
                         compression_opts=_GZIP_LEVEL, shuffle=True, fletcher32=True)


def _write_clip(clips: h5py.Group, name: str, item: Motion | FeatureClip) -> None:
    if isinstance(item, Motion):
        scalars, arrays = motion_fields(item)
        arrays = channel_arrays(item) or arrays  # the compact layout when it gives the clip back exactly
    elif isinstance(item, FeatureClip):
        scalars, arrays = feature_fields(item)
    else:
        raise ValidationError(f"clip {name!r} must be a Motion or a FeatureClip, got {type(item).__name__}")
    sk_scalars, sk_arrays = skeleton_fields(item.skeleton)
    group = clips.create_group(name)
    for key, value in {**scalars, **sk_scalars}.items():
        group.attrs[key] = _attr(value)
    skeleton = group.create_group("skeleton")
    for key, value in sk_arrays.items():
        _dataset(skeleton, key, value, compress=False)
    for key, value in arrays.items():
        _dataset(group, key, value, compress=True)


def write_database(clips: Iterable[tuple[str, Motion | FeatureClip]] | Mapping[str, Motion | FeatureClip],
                   path: str | os.PathLike[str]) -> list[str]:
    """Write named clips to one HDF5 database, atomically, consuming ``clips`` one at a time.

    Args:
        clips: ``(name, clip)`` pairs or a mapping; each clip a :class:`~motionrep.Motion` or a
            :class:`FeatureClip`.  Names must be unique, non-empty, without ``/`` or NUL, and not ``.``/``..``.
            Clips are stored in the order given.
        path: the target file; an existing file is replaced only once the new one is complete, and nothing is
            left behind if writing fails (or ``clips`` raises) midway.

    Returns:
        The clip names written, in order.

    Raises:
        HDF5FormatError: naming the file, for an invalid or duplicate clip name or an empty ``clips``.
        ValidationError: for a value that is neither a Motion nor a FeatureClip, or a string with NUL.
    """
    import h5py

    pairs = clips.items() if isinstance(clips, Mapping) else clips
    written: list[str] = []
    seen: set[str] = set()
    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w", libver=LIBVER) as f:
            f.attrs["format"] = HDF5_FORMAT
            f.attrs["format_version"] = np.int64(HDF5_FORMAT_VERSION)
            f.attrs["quat_order"] = QUAT_ORDER
            group = f.create_group(CLIPS_GROUP, track_order=True)
            for pair in pairs:
                try:
                    name, item = pair
                except (TypeError, ValueError):
                    raise ValidationError(f"write_database needs (name, clip) pairs, got {pair!r}") from None
                check_clip_name(name, path, HDF5FormatError)
                if name in seen:
                    raise HDF5FormatError(f"clip name {name!r} is given twice; clip names must be unique", path)
                seen.add(name)
                _write_clip(group, name, item)
                written.append(name)
            if not written:
                raise HDF5FormatError("no clips to write: a database needs at least one clip", path)
    return written


def write_hdf5(motion: Motion, path: str | os.PathLike[str], clip: str | None = None) -> None:
    """Write ``motion`` as a one-clip HDF5 file, atomically.

    Args:
        motion: the clip; rotations are stored ``(F, J, 4)`` xyzw, every array bit for bit.
        path: the target file.
        clip: the clip's name (default: the file name without suffix, :func:`default_clip_name`).
    """
    if not isinstance(motion, Motion):
        raise ValidationError(f"write_hdf5 needs a Motion, got {type(motion).__name__}")
    write_database([(default_clip_name(path) if clip is None else clip, motion)], path)


def write_hdf5_features(features: FeatureClip, path: str | os.PathLike[str], clip: str | None = None) -> None:
    """Write a representation's features as a one-clip HDF5 file, atomically (see :func:`write_hdf5`)."""
    if not isinstance(features, FeatureClip):
        raise ValidationError(f"write_hdf5_features needs a FeatureClip, got {type(features).__name__}")
    write_database([(default_clip_name(path) if clip is None else clip, features)], path)


# ---------------------------------------------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------------------------------------------
def open_hdf5_file(path: str | os.PathLike[str], error: type[FormatError] = HDF5FormatError) -> H5Reader:
    """``path`` opened for reading through the watchdog (:class:`~motionrep.io._h5read.H5Reader`); a missing,
    unreadable, non-regular or non-HDF5 file raises ``error`` naming it."""
    check_regular(path, error)
    try:
        return H5Reader(path)
    except H5Error as exc:
        try:
            with open_regular(path, error) as fh:
                magic = fh.read(8)
        except (FormatError, OSError):
            magic = b""
        if magic != b"\x89HDF\r\n\x1a\n":
            raise error("not an HDF5 file (no HDF5 signature)", path) from None
        raise error(f"cannot open HDF5 file: {exc}", path) from None


def root_format(f: H5Reader, error: type[FormatError] = HDF5FormatError) -> str | None:
    """The root ``format`` attribute of an open HDF5 file (``"motionrep-hdf5"``, ``"motionrep-mrc-archive"``), or
    None when it has none or it is not text.

    Raises:
        FormatError: (``error``) naming the file when its root attributes cannot be read (a damaged file).
    """
    try:
        attrs = f.attrs("")
    except H5Error as exc:
        raise error(f"cannot read the root attributes: {exc}", f.path) from None
    return _decode_text(attrs["format"]) if "format" in attrs else None


def _a(kind: str) -> str:
    return ("an " if kind[0] in "aeiou" else "a ") + kind


def _decode_text(value: Any) -> str | None:
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if isinstance(value, (bytes, np.bytes_)):
        try:
            return bytes(value).decode("utf-8")
        except UnicodeDecodeError:
            return None
    return str(value) if isinstance(value, str) else None


def _check_header(f: H5Reader, path: str | os.PathLike[str]) -> tuple[int, list[str]]:
    """The format version and the clip names of an open motionrep HDF5 file, after checking its header and that
    ``/clips`` holds only groups (links are refused)."""
    try:
        attrs = f.attrs("")
    except H5Error as exc:
        raise HDF5FormatError(f"cannot read the root attributes: {exc}", path) from None
    if "format" not in attrs:
        raise HDF5FormatError("not a motionrep HDF5 file: the root group has no 'format' attribute", path)
    name = _decode_text(attrs["format"])
    if name != HDF5_FORMAT:
        shown = name if name is not None else "not a string"
        raise HDF5FormatError(f"not a motionrep HDF5 file: root attribute 'format' is {shown!r}, expected "
                              f"{HDF5_FORMAT!r}", path)
    version = attrs.get("format_version", -1)
    version = np.asarray(-1 if version is Ellipsis else version)
    if version.ndim != 0 or version.dtype.kind not in "iu" or int(version) < 1:
        raise HDF5FormatError(f"missing or invalid root attribute 'format_version' ({version!r})", path)
    if int(version) > HDF5_FORMAT_VERSION:
        raise HDF5FormatError(f"HDF5 format version {int(version)} is newer than the newest this motionrep "
                              f"reads ({HDF5_FORMAT_VERSION}); upgrade motionrep to read it", path)
    try:
        kinds = dict(f.members(""))
        if kinds.get(CLIPS_GROUP) != "group":
            raise HDF5FormatError(f"missing group '/{CLIPS_GROUP}'" + (
                f" ('/{CLIPS_GROUP}' is {_a(kinds[CLIPS_GROUP])})" if CLIPS_GROUP in kinds else ""), path)
        members = f.members(CLIPS_GROUP)
    except H5Error as exc:
        raise HDF5FormatError(f"cannot list the clips: {exc}", path) from None
    for clip, kind in members:
        if kind != "group":
            raise HDF5FormatError(f"clip {clip!r}: '/{CLIPS_GROUP}/{clip}' is {_a(kind)}, not a group"
                                  + ("; motionrep follows no links in a file" if "link" in kind else ""), path)
    return int(version), [c for c, _ in members]


class _HDF5Source(ClipSource):
    _ARRAY_KEYS = ("root_translation", "rotations", "joint_translations", "features", "feature_names",
                   "euler_branch", "euler_angles") + CHANNEL_KEYS

    def __init__(self, reader: H5Reader, path: str | os.PathLike[str], clip: str):
        super().__init__(path, clip, HDF5FormatError)
        self.reader = reader
        self.base = f"{CLIPS_GROUP}/{clip}"
        self._attrs: dict[str, Any] | None = None
        self._members: dict[str, dict[str, str]] = {}
        self._described: dict[str, dict[str, Any]] = {}

    def _dataset_path(self, key: str) -> str | None:
        if key.startswith("skeleton."):
            return "skeleton/" + key[len("skeleton."):]
        return key if key in self._ARRAY_KEYS else None

    def where(self, key: str) -> str:
        p = self._dataset_path(key)
        return f"dataset {p!r}" if p is not None else f"attribute {key!r}"

    def _ask(self, what: str, method, *args) -> Any:
        try:
            return method(*args)
        except H5Error as exc:
            raise self.fail(f"cannot read {what}: {exc}") from None

    def _group_members(self, group: str) -> dict[str, str]:
        if group not in self._members:
            full = f"{self.base}/{group}" if group else self.base
            self._members[group] = dict(self._ask(f"'/{full}'", self.reader.members, full))
        return self._members[group]

    def has(self, key: str) -> bool:
        p = self._dataset_path(key)
        if p is None:
            return key in self._all_attrs()
        group, _, name = p.rpartition("/")
        if group and self._group_members("").get(group) != "group":
            return False
        kind = self._group_members(group).get(name)
        if kind is not None and kind != "dataset":
            raise self.fail(f"{self.where(key)} is {_a(kind)}, not a dataset"
                            + ("; motionrep follows no links in a file" if "link" in kind else ""))
        return kind is not None

    def _all_attrs(self) -> dict[str, Any]:
        if self._attrs is None:
            self._attrs = self._ask("the clip's attributes", self.reader.attrs, self.base)
        return self._attrs

    def _describe(self, key: str) -> dict[str, Any]:
        if key not in self._described:
            self.require(key)
            desc = self._ask(self.where(key), self.reader.describe, f"{self.base}/{self._dataset_path(key)}")
            if desc["shape"] is None:
                raise self.fail(f"{self.where(key)} has no data space")
            self._described[key] = desc
        return self._described[key]

    def scalar(self, key: str) -> Any:
        attrs = self._all_attrs()
        if key not in attrs:
            raise self.fail(f"missing {self.where(key)}")
        if attrs[key] is Ellipsis:
            raise self.fail(f"{self.where(key)} has an unsupported datatype")
        return attrs[key]

    def shape_dtype(self, key: str) -> tuple[tuple[int, ...], np.dtype]:
        desc = self._describe(key)
        return desc["shape"], np.dtype(object) if desc["dtype"] == "string" else desc["dtype"]

    def array(self, key: str) -> NDArray[Any]:
        desc = self._describe(key)
        if desc["dtype"] == "string":
            raise self.fail(f"{self.where(key)} must hold numbers, got strings")
        self.check_size(key, desc["shape"], desc["itemsize"])
        return self._ask(self.where(key), self.reader.read, f"{self.base}/{self._dataset_path(key)}",
                         current_limits().max_clip_bytes)

    def strings(self, key: str) -> list[str]:
        desc = self._describe(key)
        if desc["dtype"] != "string":
            raise self.fail(f"{self.where(key)} must hold strings, got dtype {desc['dtype']}")
        self.check_size(key, desc["shape"], desc["itemsize"] or 1)
        values = self._ask(self.where(key), self.reader.read, f"{self.base}/{self._dataset_path(key)}",
                           current_limits().max_clip_bytes)
        if not all(isinstance(v, str) for v in values):
            raise self.fail(f"{self.where(key)} is not valid UTF-8")
        return [v.rstrip("\x00") for v in values]

    def euler_branch(self, frames: int, joints: int) -> NDArray[np.bool_] | None:
        if not self.has("euler_branch"):
            return None
        a = self.checked_array("euler_branch", (frames, joints), "biu", "0/1 flags")
        if a.size and (a.min() < 0 or a.max() > 1):
            raise self.fail(f"{self.where('euler_branch')} must hold only 0 and 1")
        return a.astype(bool)


class HDF5Database:
    """A motionrep HDF5 file open for reading: its clip names, and any clip read on demand, one at a time, with
    the file opened once for all of them (``with HDF5Database(path) as db: ...``).

    The file is read through the watchdog of :mod:`motionrep.io._h5read` (the ``read_timeout`` limit); links,
    external storage and virtual datasets are refused, and declared shapes are checked against the limits of
    :mod:`motionrep.limits` before any data is read.

    Args:
        path: the file (named in errors).
        file: the file already open (:func:`open_hdf5_file`); it is then owned, and closed, by this object.

    Raises:
        HDF5FormatError: naming the file if it is missing, not a motionrep HDF5 file or of a newer format version.
    """

    def __init__(self, path: str | os.PathLike[str], file: H5Reader | None = None):
        self.path = path
        self._file = open_hdf5_file(path) if file is None else file
        try:
            self.version, self._names = _check_header(self._file, path)
        except BaseException:
            self._file.close()
            raise

    @property
    def names(self) -> list[str]:
        """The clip names, in stored order (no clip data is read)."""
        return list(self._names)

    def _clip(self, clip: str | None) -> str:
        names = self._names
        if clip is None:
            if len(names) == 1:
                return names[0]
            if not names:
                raise HDF5FormatError("the database holds no clips", self.path)
            raise naming(HDF5FormatError(f"the database holds {len(names)} clips; choose one with clip=NAME: "
                                         f"{_listing(names)}", self.path), "clip=NAME")
        if not isinstance(clip, str) or clip not in names:
            raise HDF5FormatError(f"no clip named {clip!r}; clips in this file: {_listing(names)}", self.path)
        return clip

    def read_stored(self, clip: str | None = None) -> tuple[str, Motion | FeatureClip]:
        """One clip as stored: its name and a :class:`~motionrep.Motion` or a :class:`FeatureClip`; ``clip`` may be
        omitted when the file holds exactly one clip.  Only that clip's group is read.

        Raises:
            HDF5FormatError: naming the file and the clip, if it holds several clips and none was named (the
                message lists them), has no such clip, the clip lacks a field or has one of the wrong shape or
                type, exceeds a limit, or the file is damaged (a checksum mismatch, or the HDF5 library failing or
                taking longer than the limit).
        """
        name = self._clip(clip)
        return name, decode_clip(_HDF5Source(self._file, self.path, name))

    def read(self, clip: str | None = None) -> Motion:
        """One clip's motion; a features clip is decoded through its registered representation.

        Raises:
            HDF5FormatError: see :meth:`read_stored`; also if the installed representation's version differs
                from the one that wrote the features.
            UnknownPluginError: if the features' representation is not installed.
        """
        name, item = self.read_stored(clip)
        return _decoded(item, self.path, name)

    def summaries(self) -> list[dict[str, Any]]:
        """One summary per clip from attributes and dataset shapes only (see :func:`clip_summaries`)."""
        out = []
        for name in self.names:
            src = _HDF5Source(self._file, self.path, name)
            kind = src.text("kind")
            fps = src.number("fps", integer=False)
            joints = src.shape_dtype("skeleton.names")[0]
            key = "features" if kind == KIND_FEATURES else next(
                (k for k in ("rotations", "channel_deltas", "channel_values") if src.has(k)), "rotations")
            shape = src.shape_dtype(key)[0]
            if kind not in (KIND_MOTION, KIND_FEATURES) or len(shape) < 2 or len(joints) != 1 or not fps > 0:
                raise src.fail("malformed clip (kind, fps, skeleton/names or frame data)")
            entry: dict[str, Any] = {"name": name, "kind": kind, "frames": int(shape[0]), "fps": fps,
                                     "duration": shape[0] / fps, "joints": int(joints[0])}
            if kind == KIND_FEATURES:
                entry["representation"] = src.text("representation")
                entry["representation_version"] = src.number("representation_version", integer=True)
                entry["width"] = int(shape[1])
            out.append(entry)
        return out

    def close(self) -> None:
        """Close the file."""
        self._file.close()

    def __enter__(self) -> "HDF5Database":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def read_hdf5_clip(path: str | os.PathLike[str], clip: str | None = None) -> tuple[str, Motion | FeatureClip]:
    """Read one clip as stored: its name and a :class:`~motionrep.Motion` or a :class:`FeatureClip`.

    Only the named clip's group is opened; other clips are not read.  See :class:`HDF5Database` for the checks
    made on the way.

    Args:
        path: the file.
        clip: the clip's name; may be omitted when the file holds exactly one clip.

    Raises:
        HDF5FormatError: naming the file and the clip, if the file is missing, not a motionrep HDF5 file, of a
            newer format version, holds several clips and none was named (the message lists them), has no
            such clip, the clip lacks a field or has one of the wrong shape or type, exceeds a limit, or the file
            is damaged.
    """
    with HDF5Database(path) as db:
        return db.read_stored(clip)


def _decoded(item: Motion | FeatureClip, path, name: str) -> Motion:
    if isinstance(item, FeatureClip):
        return motion_from_features(item, path, clip_name=name)
    return item


def read_hdf5(path: str | os.PathLike[str], clip: str | None = None) -> Motion:
    """Read one clip's motion; a features clip is decoded through its registered representation.

    Raises:
        HDF5FormatError: see :func:`read_hdf5_clip`; also if the installed representation's version differs from
            the one that wrote the features.
        UnknownPluginError: if the features' representation is not installed.
    """
    with HDF5Database(path) as db:
        return db.read(clip)


def list_hdf5_clips(path: str | os.PathLike[str]) -> list[str]:
    """Names of the clips in an HDF5 file, in stored order (no clip data is read).

    Raises:
        HDF5FormatError: if the file is missing or not a motionrep HDF5 file.
    """
    with HDF5Database(path) as db:
        return db.names


def iter_hdf5_clips(path: str | os.PathLike[str], decode: bool = True
                    ) -> Iterator[tuple[str, Motion | FeatureClip]]:
    """Yield ``(name, clip)`` for every clip, reading one clip at a time (the file stays open meanwhile).

    Args:
        path: the file.
        decode: decode features clips to motions through their representation (otherwise yield
            :class:`FeatureClip` as stored).

    Raises:
        HDF5FormatError: when the file, or the clip being read, is invalid (raised lazily, as iteration reaches
            it).
    """
    with HDF5Database(path) as db:
        for name in db.names:
            yield name, (db.read(name) if decode else db.read_stored(name)[1])


def clip_summaries(path: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """One summary per clip from attributes and dataset shapes only (no frame data is read).

    Each summary has ``name``, ``kind`` (``"motion"`` or ``"features"``), ``frames``, ``fps``, ``duration``,
    ``joints``, and for features ``representation``, ``representation_version`` and ``width``.

    Raises:
        HDF5FormatError: naming the file and the clip, when a clip lacks what the summary needs.
    """
    with HDF5Database(path) as db:
        return db.summaries()
