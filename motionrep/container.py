"""The ``.mrc`` compressed-motion container (byte layout in ``specs/container.md``).

A container holds everything needed to decode one compressed clip and to know what was promised about it: the
codec (name, payload format version, providing plugin, parameters, outcome), the representation (name,
version, plugin), the skeleton, frame rate and frame count, the shared evaluation measured when the file was
written, and the payload arrays.  Layout::

    offset  size  field
    0       8     magic b"\\x89MRC\\r\\n\\x1a\\n"
    8       2     container version, uint16 little-endian (1)
    10      2     flags, uint16 little-endian (0; any other value is refused)
    12      4     total file length in bytes, uint32 little-endian
    16      4     metadata length M, uint32 little-endian
    20      M     metadata: zlib-compressed UTF-8 JSON (sorted keys)
    20+M    ...   payload: the arrays' raw little-endian C-order bytes, concatenated in metadata order
    L-4     4     CRC-32 (zlib.crc32) of bytes [0, L-4), uint32 little-endian

Reading checks, in order: length at least 24 bytes, magic, the stored length against the real length
(truncation or extension), the CRC-32 (every single-byte change; CRC-32 detects every error burst of up to 32
bits), then the container version, the metadata and the array table.  A check that fails raises
:class:`~motionrep.errors.ContainerError` naming the file; garbage is never decoded.
"""

from __future__ import annotations

import json
import math
import os
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np
from numpy.typing import NDArray

from ._model import Skeleton
from .errors import ContainerError, ValidationError

__all__ = [
    "MAGIC",
    "CONTAINER_VERSION",
    "SUFFIX",
    "Container",
    "pack",
    "unpack",
    "read_container",
    "write_container",
    "skeleton_to_json",
    "skeleton_from_json",
]

#: First 8 bytes of every ``.mrc`` file (a non-ASCII byte, the name, CR LF, ^Z, LF, as PNG does, so that text-mode
#: transfers and truncated downloads are caught early).
MAGIC = b"\x89MRC\r\n\x1a\n"
#: Container layout version written by this motionrep.  Versions are never reused.
CONTAINER_VERSION = 1
#: Versions this motionrep reads.
READABLE_VERSIONS = (1,)
#: The file suffix.
SUFFIX = ".mrc"

_PREAMBLE = struct.Struct("<8sHHII")  # magic, version, flags, total length, metadata length
_CRC = struct.Struct("<I")
_MIN_SIZE = _PREAMBLE.size + _CRC.size
#: dtypes a payload array may have (stored little-endian).
_DTYPES = {"f2": np.float16, "f4": np.float32, "f8": np.float64, "i1": np.int8, "i2": np.int16, "i4": np.int32,
           "i8": np.int64, "u1": np.uint8, "u2": np.uint16, "u4": np.uint32, "u8": np.uint64}
_DTYPE_NAMES = {np.dtype(v): k for k, v in _DTYPES.items()}


@dataclass(frozen=True, eq=False)
class Container:
    """The decoded contents of a ``.mrc`` file.

    Attributes:
        codec: codec name (``"adaptive-fourier"``).
        codec_version: the codec's payload format version.
        codec_plugin: plugin (or distribution) that provided the codec, quoted when it is missing; may be None.
        params: the codec parameters used (JSON values).
        info: the codec's outcome (``{"K": 5, "omega": [...]}``, ``{"rank": 9}``); never needed to decode.
        representation: representation name.
        representation_version: its version.
        representation_plugin: plugin that provided it; may be None.
        skeleton: the skeleton.
        fps: frames per second of the source.
        num_frames: frames of the source.
        arrays: payload arrays by name, in storage order.
        evaluation: the shared evaluation measured on this very payload when the file was written
            (:meth:`motionrep.evaluate.ErrorReport.as_dict` plus ``"bound"``), or None.
        extra: other metadata (``motionrep_version``, ``seed``...); readers ignore keys they do not know.
    """

    codec: str
    codec_version: int
    codec_plugin: str | None
    params: Mapping[str, Any]
    info: Mapping[str, Any]
    representation: str
    representation_version: int
    representation_plugin: str | None
    skeleton: Skeleton
    fps: float
    num_frames: int
    arrays: Mapping[str, NDArray[Any]]
    evaluation: Mapping[str, Any] | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)

    @property
    def num_parameters(self) -> int:
        """Every stored number (all array elements)."""
        return int(sum(int(a.size) for a in self.arrays.values()))

    @property
    def payload_bytes(self) -> int:
        """Bytes of the codec's arrays, without the skeleton, metadata and checksum every container has."""
        return int(sum(int(a.nbytes) for a in self.arrays.values()))


# ---------------------------------------------------------------------------------------------------------------
# skeleton <-> JSON
# ---------------------------------------------------------------------------------------------------------------
def skeleton_to_json(skeleton: Skeleton) -> dict[str, Any]:
    """A JSON object for ``skeleton`` (floats are written exactly: JSON uses the shortest round-trip repr)."""
    return {
        "names": list(skeleton.names),
        "parents": [int(p) for p in skeleton.parents],
        "offsets": [[float(v) for v in row] for row in skeleton.offsets],
        "channels": [" ".join(ch) for ch in skeleton.channels],
        "end_site_parents": [int(p) for p in skeleton.end_site_parents],
        "end_site_offsets": [[float(v) for v in row] for row in skeleton.end_site_offsets],
        "units": skeleton.units,
    }


def skeleton_from_json(obj: Mapping[str, Any]) -> Skeleton:
    """The :class:`Skeleton` written by :func:`skeleton_to_json`.

    Raises:
        ValidationError: if the object does not describe a valid skeleton.
    """
    try:
        return Skeleton(
            names=tuple(obj["names"]),
            parents=np.array(obj["parents"], dtype=np.int64),
            offsets=np.array(obj["offsets"], dtype=np.float64).reshape(-1, 3),
            channels=tuple(tuple(c.split()) for c in obj["channels"]),
            end_site_parents=np.array(obj["end_site_parents"], dtype=np.int64),
            end_site_offsets=np.array(obj["end_site_offsets"], dtype=np.float64).reshape(-1, 3),
            units=obj.get("units"),
        )
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        if isinstance(exc, ValidationError):
            raise
        raise ValidationError(f"invalid skeleton in container: {type(exc).__name__}: {exc}") from None


# ---------------------------------------------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------------------------------------------
def _json_safe(value: Any, where: str) -> Any:
    """Check that ``value`` is plain JSON with finite numbers (numpy scalars converted)."""
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        f = float(value)
        if not math.isfinite(f):
            raise ValidationError(f"{where} must be finite, got {f}")
        return f
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, Mapping):
        return {str(k): _json_safe(v, f"{where}.{k}") for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_json_safe(v, where) for v in (value.tolist() if isinstance(value, np.ndarray) else value)]
    raise ValidationError(f"{where} must be JSON data, got {type(value).__name__}")


def pack(container: Container) -> bytes:
    """Serialise ``container`` to the bytes of a ``.mrc`` file (deterministic: same input, same bytes).

    Raises:
        ValidationError: if an array has an unsupported dtype, or metadata is not plain finite JSON.
    """
    table = []
    blobs = []
    for name, array in container.arrays.items():
        a = np.asarray(array)
        if not isinstance(name, str) or not name:
            raise ValidationError(f"payload array names must be non-empty strings, got {name!r}")
        kind = _DTYPE_NAMES.get(np.dtype(a.dtype.type))
        if kind is None:
            raise ValidationError(f"payload array {name!r} has unsupported dtype {a.dtype}; use one of "
                                  + ", ".join(np.dtype(v).name for v in _DTYPES.values()))
        data = np.ascontiguousarray(a, dtype=np.dtype(_DTYPES[kind]).newbyteorder("<")).tobytes()
        table.append({"name": name, "dtype": kind, "shape": [int(s) for s in a.shape]})
        blobs.append(data)
    meta = {
        "codec": {"name": container.codec, "version": int(container.codec_version),
                  "plugin": container.codec_plugin, "params": dict(container.params), "info": dict(container.info)},
        "representation": {"name": container.representation, "version": int(container.representation_version),
                           "plugin": container.representation_plugin},
        "skeleton": skeleton_to_json(container.skeleton),
        "fps": float(container.fps),
        "num_frames": int(container.num_frames),
        "evaluation": None if container.evaluation is None else dict(container.evaluation),
        "arrays": table,
        "extra": dict(container.extra),
    }
    text = json.dumps(_json_safe(meta, "metadata"), sort_keys=True, separators=(",", ":"), allow_nan=False)
    metadata = zlib.compress(text.encode("utf-8"), 9)
    payload = b"".join(blobs)
    total = _PREAMBLE.size + len(metadata) + len(payload) + _CRC.size
    if total >= 2 ** 32:
        raise ValidationError(f"container would be {total} bytes; the .mrc format is limited to 4 GiB")
    head = _PREAMBLE.pack(MAGIC, CONTAINER_VERSION, 0, total, len(metadata))
    body = head + metadata + payload
    return body + _CRC.pack(zlib.crc32(body))


def write_container(container: Container | bytes, path: str | os.PathLike[str]) -> int:
    """Write a container (or its packed bytes) to ``path`` atomically; return the number of bytes written."""
    from .io import atomic_path

    data = container if isinstance(container, (bytes, bytearray)) else pack(container)
    with atomic_path(path) as tmp:
        Path(tmp).write_bytes(data)
    return len(data)


# ---------------------------------------------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------------------------------------------
def unpack(data: bytes, path: str | os.PathLike[str] | None = None) -> Container:
    """Parse and verify the bytes of a ``.mrc`` file.

    Args:
        data: the whole file.
        path: the file name, quoted in errors.

    Raises:
        ContainerError: naming the file, if it is not a ``.mrc`` file, is truncated or extended, fails its
            checksum, has an unknown container version or flags, or its metadata or array table is invalid.
    """
    data = bytes(data)
    n = len(data)
    if n < _MIN_SIZE:
        if MAGIC.startswith(data[:len(MAGIC)]) and n:
            raise ContainerError(f"truncated .mrc file: {n} bytes, shorter than the {_MIN_SIZE}-byte minimum", path)
        raise ContainerError(f"not a motionrep .mrc file ({n} bytes)", path)
    magic, version, flags, total, meta_len = _PREAMBLE.unpack_from(data)
    if magic != MAGIC:
        raise ContainerError("not a motionrep .mrc file (bad magic bytes)", path)
    if total != n:
        what = "truncated" if n < total else "has extra bytes or a damaged length field"
        raise ContainerError(f".mrc file {what}: header says {total} bytes, file has {n}", path)
    (crc,) = _CRC.unpack_from(data, n - _CRC.size)
    if zlib.crc32(memoryview(data)[: n - _CRC.size]) != crc:
        raise ContainerError(".mrc file is corrupted: checksum mismatch (the file was altered or damaged)", path)
    if version not in READABLE_VERSIONS:
        raise ContainerError(f"unsupported .mrc container version {version} (this motionrep reads "
                             f"{', '.join(map(str, READABLE_VERSIONS))}); upgrade motionrep", path)
    if flags != 0:
        raise ContainerError(f"unsupported .mrc flags {flags:#06x}", path)
    start = _PREAMBLE.size
    if start + meta_len > n - _CRC.size:
        raise ContainerError("invalid .mrc file: metadata length exceeds the file", path)
    try:
        meta = json.loads(zlib.decompress(data[start:start + meta_len]).decode("utf-8"))
    except (zlib.error, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ContainerError(f"invalid .mrc metadata: {exc}", path) from None
    try:
        return _from_meta(meta, memoryview(data)[start + meta_len: n - _CRC.size], path)
    except ContainerError:
        raise
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise ContainerError(f"invalid .mrc metadata: {type(exc).__name__}: {exc}", path) from None


def _from_meta(meta: dict[str, Any], payload: memoryview, path) -> Container:
    arrays: dict[str, NDArray[Any]] = {}
    offset = 0
    for entry in meta["arrays"]:
        name, kind, shape = entry["name"], entry["dtype"], tuple(int(s) for s in entry["shape"])
        if kind not in _DTYPES or any(s < 0 for s in shape) or name in arrays:
            raise ContainerError(f"invalid .mrc array table entry {entry!r}", path)
        dtype = np.dtype(_DTYPES[kind]).newbyteorder("<")
        size = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
        if offset + size > len(payload):
            raise ContainerError(f"invalid .mrc file: array {name!r} runs past the payload", path)
        a = np.frombuffer(payload[offset:offset + size], dtype=dtype).reshape(shape).astype(dtype.newbyteorder("="))
        a.flags.writeable = False
        arrays[name] = a
        offset += size
    if offset != len(payload):
        raise ContainerError(f"invalid .mrc file: {len(payload) - offset} payload bytes not described by the "
                             "array table", path)
    codec, rep = meta["codec"], meta["representation"]
    num_frames = int(meta["num_frames"])
    fps = float(meta["fps"])
    if num_frames < 1 or not (math.isfinite(fps) and fps > 0):
        raise ContainerError(f"invalid .mrc file: {num_frames} frames at {fps} fps", path)
    try:
        skeleton = skeleton_from_json(meta["skeleton"])
    except ValidationError as exc:
        raise ContainerError(str(exc), path) from None
    return Container(
        codec=str(codec["name"]),
        codec_version=int(codec["version"]),
        codec_plugin=codec.get("plugin"),
        params=dict(codec.get("params") or {}),
        info=dict(codec.get("info") or {}),
        representation=str(rep["name"]),
        representation_version=int(rep["version"]),
        representation_plugin=rep.get("plugin"),
        skeleton=skeleton,
        fps=fps,
        num_frames=num_frames,
        arrays=arrays,
        evaluation=meta.get("evaluation"),
        extra=dict(meta.get("extra") or {}),
    )


def read_container(path: str | os.PathLike[str]) -> Container:
    """Read and verify a ``.mrc`` file.

    Raises:
        ContainerError: naming the file if it cannot be read or fails any check (see :func:`unpack`).
    """
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise ContainerError(f"cannot read file: {exc.strerror or exc}", path) from None
    return unpack(data, path)
