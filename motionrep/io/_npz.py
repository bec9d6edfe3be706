"""NPZ (numpy archive) reader and writer: one clip per file, a motion or a representation's features.

The layout is ``specs/formats/npz.md``: format name ``"motionrep-npz"``, format version 3 (versions 1 and 2 are
still read), members deflated, a clip read from BVH stored as its channel values when they give back every array
bit for bit (``_compact``), otherwise quaternions ``(F, J, 4)`` **xyzw**, the complete skeleton, strings as fixed-width unicode arrays, so files
load with ``numpy.load(path, allow_pickle=False)``.  Every array round-trips bit for bit.  Problems raise
:class:`~motionrep.errors.NPZFormatError` naming the file.

Reading never trusts the archive: only a regular file is opened; each member's ``.npy`` header is read and its
shape and dtype checked against what the clip needs and against the limits of :mod:`motionrep.limits` before
any data is inflated, and exactly the declared number of bytes is read (a zip bomb is refused from its header).
"""

from __future__ import annotations

import math
import os
import zipfile
from typing import Any, BinaryIO

import numpy as np
from numpy.typing import NDArray

from ..model._pose import Motion
from ..errors import MotionrepError, NPZFormatError, ValidationError
from ._atomic import atomic_path
from ._compact import channel_arrays
from ._features import FeatureClip, motion_from_features
from ._files import open_regular
from ._stored import (
    ClipSource,
    decode_clip,
    feature_fields,
    motion_fields,
    packed_bits_length,
    skeleton_fields,
)

__all__ = ["NPZ_FORMAT", "NPZ_FORMAT_VERSION", "read_npz", "read_npz_clip", "write_npz", "write_npz_features"]

#: Value of the ``format`` key of every motionrep NPZ file.
NPZ_FORMAT = "motionrep-npz"
#: Newest NPZ format version this motionrep writes and reads (older versions stay readable).  Version 2 adds
#: the optional ``euler_angles`` key; version 3 the compact layout (``channel_*`` keys, ``motionrep.io._compact``)
#: and deflated members.
NPZ_FORMAT_VERSION = 3

#: Longest string, in characters, a stored string array may hold per element.
MAX_STRING_CHARS = 1 << 16
_MAX_HEADER = 10000  # bytes of a member's .npy header (numpy's own limit for untrusted files)
_READ_CHUNK = 1 << 24


def _text_array(values: list[str] | str) -> NDArray[np.str_]:
    """A fixed-width unicode array (never object dtype, so it loads with ``allow_pickle=False``)."""
    a = np.array(values, dtype=np.str_)
    return a if a.size else np.zeros(a.shape, dtype="<U1")


def _archive(scalars: dict[str, Any], skeleton: tuple[dict, dict], arrays: dict[str, Any]) -> dict[str, NDArray]:
    out: dict[str, NDArray] = {"format": _text_array(NPZ_FORMAT),
                               "format_version": np.array(NPZ_FORMAT_VERSION, dtype=np.int64)}
    sk_scalars, sk_arrays = skeleton
    for key, value in {**scalars, **sk_scalars}.items():
        if isinstance(value, str):
            out[key] = _text_array(value)
        elif isinstance(value, int):
            out[key] = np.array(value, dtype=np.int64)
        else:
            out[key] = np.array(value, dtype=np.float64)
    for key, value in sk_arrays.items():
        out[f"skeleton_{key}"] = _text_array(value) if isinstance(value, list) else np.asarray(value)
    for key, value in arrays.items():
        if key == "euler_branch":
            out["euler_branch_bits"] = np.packbits(np.asarray(value, dtype=bool).reshape(-1))
        elif isinstance(value, list):
            out[key] = _text_array(value)
        else:
            out[key] = np.asarray(value)
    return out


def _save(archive: dict[str, NDArray], path: str | os.PathLike[str], compress: bool) -> None:
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            (np.savez_compressed if compress else np.savez)(fh, **archive)


def write_npz(motion: Motion, path: str | os.PathLike[str], compress: bool = True) -> None:
    """Write ``motion`` to an NPZ file, atomically.

    Args:
        motion: the clip; every array comes back bit for bit.  A clip read from BVH is stored as its channel
            values (decimal integers, frame differences) when they give back every array exactly; otherwise
            rotations are stored ``(F, J, 4)`` xyzw.
        path: the target; an existing file is replaced only once the new one is complete.
        compress: deflate the archive members (``numpy.savez_compressed``, the default); ``False`` stores them
            as they are (faster to write, several times larger).  Readers handle both.

    Raises:
        ValidationError: if a joint name or the units contain a NUL character (not storable).
    """
    if not isinstance(motion, Motion):
        raise ValidationError(f"write_npz needs a Motion, got {type(motion).__name__}")
    scalars, arrays = motion_fields(motion)
    arrays = channel_arrays(motion) or arrays  # the compact layout when it gives the clip back exactly
    _save(_archive(scalars, skeleton_fields(motion.skeleton), arrays), path, compress)


def write_npz_features(clip: FeatureClip, path: str | os.PathLike[str], compress: bool = True) -> None:
    """Write a representation's features (``clip``) to an NPZ file, atomically (see :func:`write_npz`)."""
    if not isinstance(clip, FeatureClip):
        raise ValidationError(f"write_npz_features needs a FeatureClip, got {type(clip).__name__}")
    scalars, arrays = feature_fields(clip)
    _save(_archive(scalars, skeleton_fields(clip.skeleton), arrays), path, compress)


class _Member:
    """One ``.npy`` member of the archive: its header, read on its own."""

    __slots__ = ("info", "shape", "fortran", "dtype", "offset")

    def __init__(self, info: zipfile.ZipInfo, shape: tuple[int, ...], fortran: bool, dtype: np.dtype, offset: int):
        self.info, self.shape, self.fortran, self.dtype, self.offset = info, shape, fortran, dtype, offset


class _Archive:
    """A numpy archive read member by member, headers first (no data is inflated before it is asked for)."""

    def __init__(self, fh: BinaryIO, path: str | os.PathLike[str]):
        self.path = path
        self.zip = zipfile.ZipFile(fh)
        self.infos: dict[str, zipfile.ZipInfo] = {}
        for info in self.zip.infolist():
            name = info.filename
            self.infos[name[:-4] if name.endswith(".npy") else name] = info
        self.headers: dict[str, _Member] = {}

    def header(self, key: str) -> _Member:
        if key not in self.headers:
            info = self.infos[key]
            with self.zip.open(info) as fp:
                version = np.lib.format.read_magic(fp)
                if version == (1, 0):
                    shape, fortran, dtype = np.lib.format.read_array_header_1_0(fp, max_header_size=_MAX_HEADER)
                elif version == (2, 0):
                    shape, fortran, dtype = np.lib.format.read_array_header_2_0(fp, max_header_size=_MAX_HEADER)
                else:
                    raise ValueError(f".npy format version {version} (motionrep reads 1.0 and 2.0)")
                offset = fp.tell()
            if any(not isinstance(n, int) or n < 0 for n in shape):
                raise ValueError(f"invalid shape {shape!r}")
            if dtype.hasobject:
                raise ValueError("it holds Python objects (pickles are never loaded)")
            if dtype.kind not in "biufUS" or dtype.fields is not None or dtype.subdtype is not None:
                raise ValueError(f"unsupported dtype {dtype}")
            self.headers[key] = _Member(info, tuple(shape), fortran, dtype, offset)
        return self.headers[key]

    def data(self, key: str) -> NDArray[Any]:
        """The member's array: exactly the bytes its header declares (the caller checked their number)."""
        m = self.header(key)
        size = math.prod(m.shape) * m.dtype.itemsize
        if m.offset + size != m.info.file_size:
            raise ValueError(f"the member holds {m.info.file_size - m.offset} data bytes but its header declares "
                             f"{size}")
        buf = bytearray(size)
        with self.zip.open(m.info) as fp:
            fp.read(m.offset)
            view = memoryview(buf)
            done = 0
            while done < size:
                n = fp.readinto(view[done:done + _READ_CHUNK])
                if not n:
                    raise ValueError(f"the member ends after {done} of its {size} data bytes")
                done += n
            if fp.read(1):  # also makes zipfile check the member's CRC-32
                raise ValueError("the member holds more data than its header declares")
        a = np.frombuffer(buf, dtype=m.dtype).reshape(m.shape, order="F" if m.fortran else "C")
        return a if a.dtype.isnative else a.astype(a.dtype.newbyteorder("="))


class _NPZSource(ClipSource):
    def __init__(self, archive: _Archive, path: str | os.PathLike[str]):
        super().__init__(path, None, NPZFormatError)
        self.archive = archive
        self.keys = set(archive.infos)
        self.cache: dict[str, NDArray] = {}

    def _guard(self, key: str, action, *args):
        """Run one archive access; anything numpy or zipfile raises on a damaged member names the file and key."""
        try:
            return action(self.key(key), *args)
        except MotionrepError:
            raise
        except MemoryError:
            raise self.fail(f"cannot read {self.where(key)}: not enough memory") from None
        except Exception as exc:  # zipfile, zlib and numpy raise many kinds on damaged members
            raise self.fail(f"cannot read {self.where(key)}: {type(exc).__name__}: {exc}") from None

    @staticmethod
    def key(name: str) -> str:
        return name.replace("skeleton.", "skeleton_")

    def where(self, key: str) -> str:
        return f"key {self.key(key)!r}"

    def has(self, key: str) -> bool:
        return self.key(key) in self.keys

    def array(self, key: str) -> NDArray[Any]:
        k = self.key(key)
        if k not in self.cache:
            shape, dtype = self.shape_dtype(key)
            self.check_size(key, shape, dtype.itemsize)
            if dtype.kind in "US" and dtype.itemsize > MAX_STRING_CHARS * (4 if dtype.kind == "U" else 1):
                raise self.fail(f"{self.where(key)} holds strings of up to {dtype.itemsize} bytes each, more than "
                                f"the {MAX_STRING_CHARS}-character limit")
            self.cache[k] = self._guard(key, self.archive.data)
        return self.cache[k]

    def scalar(self, key: str) -> Any:
        return self.array(key)

    def shape_dtype(self, key: str) -> tuple[tuple[int, ...], np.dtype]:
        m = self._guard(key, self.archive.header)
        return m.shape, m.dtype

    def strings(self, key: str) -> list[str]:
        a = self.array(key)
        if a.dtype.kind == "U":
            # numpy keeps UCS-4 code units as stored: one above U+10FFFF makes a str CPython cannot handle
            # (SystemError on use), so the code points are checked before any str is made.
            units = np.ascontiguousarray(a).view(np.uint32) if a.size and a.dtype.itemsize else np.zeros(0, np.uint32)
            if units.size and int(units.max()) > 0x10FFFF:
                raise self.fail(f"{self.where(key)} holds a code point above U+10FFFF: not text")
            return [str(s) for s in a.tolist()]
        if a.dtype.kind == "S":
            try:
                return [bytes(s).decode("utf-8") for s in a.tolist()]
            except UnicodeDecodeError:
                raise self.fail(f"{self.where(key)} is not valid UTF-8") from None
        raise self.fail(f"{self.where(key)} must hold strings, got dtype {a.dtype}")

    def euler_branch(self, frames: int, joints: int) -> NDArray[np.bool_] | None:
        if not self.has("euler_branch_bits"):
            return None
        n = packed_bits_length(frames, joints)
        bits = self.checked_array("euler_branch_bits", (n,), "u", "packed bits (uint8)")
        if bits.dtype != np.uint8:
            raise self.fail(f"{self.where('euler_branch_bits')} must be uint8, got {bits.dtype}")
        return np.unpackbits(bits, count=frames * joints).reshape(frames, joints).astype(bool)


def _check_header(src: _NPZSource) -> None:
    if "format" not in src.keys:
        listed = ", ".join(sorted(src.keys)[:8]) or "none"
        raise src.fail(f"not a motionrep NPZ file: it has no 'format' key (keys: {listed})")
    name = src.text("format")
    if name != NPZ_FORMAT:
        raise src.fail(f"not a motionrep NPZ file: 'format' is {name!r}, expected {NPZ_FORMAT!r}")
    version = src.number("format_version", integer=True)
    if version > NPZ_FORMAT_VERSION:
        raise src.fail(f"NPZ format version {version} is newer than the newest this motionrep reads "
                       f"({NPZ_FORMAT_VERSION}); upgrade motionrep to read it")
    if version < 1:
        raise src.fail(f"invalid NPZ format version {version}")


def read_npz_clip(path: str | os.PathLike[str], body_model: str | os.PathLike[str] | None = None
                  ) -> Motion | FeatureClip:
    """Read an NPZ file as stored: a :class:`~motionrep.Motion`, or a :class:`FeatureClip` for a features file.

    An archive with AMASS's keys (``poses`` and ``trans``, no ``format``) is an AMASS clip, read through the
    SMPL-H body model ``body_model`` (default: the file ``MOTIONREP_SMPLH_MODEL`` names), see
    :func:`motionrep.io._amass.read_amass`.

    Raises:
        NPZFormatError: naming the file, if it is missing, not a motionrep NPZ file, of a newer format version,
            or lacks a key or has one of the wrong shape or dtype.
        AMASSFormatError: for an AMASS clip without a body model, or one that does not fit it.
    """
    with open_regular(path, NPZFormatError) as fh:
        try:
            magic = fh.read(6)
            fh.seek(0)
        except OSError as exc:
            raise NPZFormatError(f"cannot read file: {exc.strerror or exc}", path) from None
        if magic == b"\x93NUMPY":
            raise NPZFormatError("not an NPZ archive (a single .npy array)", path)
        if magic[:4] not in (b"PK\x03\x04", b"PK\x05\x06"):
            raise NPZFormatError("not an NPZ archive (no zip signature)", path)
        try:
            archive = _Archive(fh, path)
        except MemoryError:
            raise NPZFormatError("not an NPZ archive (its zip directory does not fit in memory)", path) from None
        except Exception as exc:  # zipfile raises several kinds on a damaged directory
            raise NPZFormatError(f"not an NPZ archive ({type(exc).__name__}: {exc})", path) from None
        with archive.zip:
            src = _NPZSource(archive, path)
            from ._amass import is_amass_keys

            amass = is_amass_keys(src.keys)
            if not amass:
                _check_header(src)
                return decode_clip(src)
    from ._amass import read_amass

    return read_amass(path, body_model)


def read_npz(path: str | os.PathLike[str], body_model: str | os.PathLike[str] | None = None) -> Motion:
    """Read the motion in an NPZ file; a features file is decoded through its registered representation.

    Raises:
        NPZFormatError: see :func:`read_npz_clip`; also if the installed representation's version differs from
            the one that wrote the features.
        UnknownPluginError: if the features' representation is not installed.
    """
    item = read_npz_clip(path, body_model)
    if isinstance(item, FeatureClip):
        return motion_from_features(item, path)
    return item

