"""The ``.mrc`` compressed-motion container (byte layout in ``specs/container.md``).

A container holds everything needed to decode one compressed clip and to know what was promised about it: the
codec (name, payload format version, providing plugin, parameters, outcome), the representation (name,
version, plugin), the skeleton, frame rate and frame count, the shared evaluation measured when the file was
written, and the payload arrays.  Layout::

    offset  size  field
    0       8     magic b"\\x89MRC\\r\\n\\x1a\\n"
    8       2     container version, uint16 little-endian (2; 1 is still read)
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

A valid checksum says the file is intact, not that whoever wrote it meant well, so the metadata is then checked
as untrusted input: it is inflated only up to the ``max_metadata_bytes`` limit, every field must have its
documented type, array shapes must describe exactly the payload, ``num_frames`` must be within the
``max_frames`` and ``max_clip_bytes`` limits (:mod:`motionrep.limits`), and the installed codec the file names
must accept its outcome (``codec.info``: plain JSON here, the codec's own words checked by
:meth:`motionrep.plugin.codec.Codec.check_info`) before anything is decoded.

Size: one concern, the ``.mrc`` format; the writer and the reader stay together because each is the other's
specification, and a third of the length is the reader checking every metadata field of an untrusted file.
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

from ..limits import ENVIRONMENT, check_clip
from ..limits import current as current_limits
from ..model._pose import Skeleton
from ..model.bound import StoredBound
from ..errors import ContainerError, ValidationError
from ..formats import CONTAINER_SUFFIX

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
CONTAINER_VERSION = 2
#: Versions this motionrep reads (version 1 stated the bound as the text ``extra.max_error``; version 2 states it
#: structured, ``bound``; ``specs/container.md``).
READABLE_VERSIONS = (1, 2)
#: The file suffix (:data:`motionrep.formats.CONTAINER_SUFFIX`).
SUFFIX = CONTAINER_SUFFIX

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
            (:meth:`motionrep.pipeline.evaluate.ErrorReport.as_dict` plus ``"bound"``), or None.
        extra: other metadata (``motionrep_version``, ``seed``...); readers ignore keys they do not know.
        bound: the bound the clip was compressed within (the requested bound and the distance in file units it
            resolved to, or "none"), or None when the file does not say (a container written by another tool).
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
    bound: StoredBound | None = None

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
    names = _get(obj, "names", (list,), "skeleton")
    if not all(isinstance(n, str) for n in names):
        raise ValidationError("invalid skeleton in container: 'skeleton.names' must be an array of strings")
    channels = _get(obj, "channels", (list,), "skeleton")
    if not all(isinstance(c, str) for c in channels):
        raise ValidationError("invalid skeleton in container: 'skeleton.channels' must be an array of strings")
    numbers = {}
    for key, kind in (("parents", "int"), ("end_site_parents", "int"), ("offsets", "xyz"),
                      ("end_site_offsets", "xyz")):
        value = _get(obj, key, (list,), "skeleton")
        rows = value if kind == "xyz" else [value]
        if not all(isinstance(r, list) and (kind != "xyz" or len(r) == 3)
                   and all(isinstance(x, int if kind == "int" else (int, float)) and not isinstance(x, bool)
                           for x in r) for r in rows):
            want = "an array of integers" if kind == "int" else "an array of [x, y, z] numbers"
            raise ValidationError(f"invalid skeleton in container: 'skeleton.{key}' must be {want}")
        numbers[key] = value
    try:
        return Skeleton(
            names=tuple(names),
            parents=np.array(numbers["parents"], dtype=np.int64),
            offsets=np.array(numbers["offsets"], dtype=np.float64).reshape(-1, 3),
            channels=tuple(tuple(c.split()) for c in channels),
            end_site_parents=np.array(numbers["end_site_parents"], dtype=np.int64),
            end_site_offsets=np.array(numbers["end_site_offsets"], dtype=np.float64).reshape(-1, 3),
            units=_get(obj, "units", (str, type(None)), "skeleton", required=False),
        )
    except (TypeError, ValueError, OverflowError) as exc:
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
        "bound": None if container.bound is None else container.bound.as_json(),
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
    from . import atomic_path

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
    meta = _metadata(data[start:start + meta_len], path)
    try:
        return _from_meta(meta, memoryview(data)[start + meta_len: n - _CRC.size], path, n, version)
    except ContainerError:
        raise
    except (ValidationError, KeyError, TypeError, ValueError, AttributeError, OverflowError, RecursionError) as exc:
        raise ContainerError(f"invalid .mrc metadata: {type(exc).__name__}: {exc}", path) from None


def _metadata(blob: bytes, path) -> dict[str, Any]:
    """Inflate (at most ``max_metadata_bytes``) and parse the metadata JSON."""
    limit = current_limits().max_metadata_bytes
    try:
        inflater = zlib.decompressobj()
        text = inflater.decompress(blob, limit + 1)
        if len(text) > limit or (inflater.unconsumed_tail and not inflater.eof):
            raise ContainerError(f"invalid .mrc file: its metadata inflates to more than {limit} bytes, the limit "
                                 f"(raise {ENVIRONMENT['max_metadata_bytes']} to read it)", path)
        if not inflater.eof:
            raise ContainerError("invalid .mrc metadata: the zlib stream is truncated", path)
        if inflater.unused_data:
            raise ContainerError("invalid .mrc metadata: bytes after the end of the zlib stream", path)
        meta = json.loads(text.decode("utf-8"))
    except ContainerError:
        raise
    except RecursionError:
        raise ContainerError("invalid .mrc metadata: JSON nested too deeply", path) from None
    except MemoryError:
        raise ContainerError("invalid .mrc metadata: not enough memory to parse it", path) from None
    except (zlib.error, UnicodeDecodeError, ValueError) as exc:  # json.JSONDecodeError is a ValueError
        raise ContainerError(f"invalid .mrc metadata: {exc}", path) from None
    if not isinstance(meta, dict):
        raise ContainerError(f"invalid .mrc metadata: a JSON object was expected, found {type(meta).__name__}",
                             path)
    return meta


# ---- typed access to the metadata: untrusted JSON ----------------------------------------------------------------
def _get(obj: Mapping[str, Any], key: str, types: tuple[type, ...], where: str, required: bool = True) -> Any:
    if not isinstance(obj, Mapping):
        raise ValidationError(f"'{where}' must be an object, got {type(obj).__name__}")
    full = f"{where}.{key}" if where else key
    if key not in obj:
        if required:
            raise ValidationError(f"'{full}' is missing")
        return None
    value = obj[key]
    if value is None and type(None) in types:
        return None
    if isinstance(value, bool) and bool not in types:
        ok = False
    else:
        ok = isinstance(value, tuple(t for t in types if t is not type(None)))
    if not ok:
        want = " or ".join(_JSON_NAMES.get(t, t.__name__) for t in types)
        raise ValidationError(f"'{full}' must be {want}, got {_json_name(value)}")
    return value


_JSON_NAMES = {str: "a string", int: "an integer", float: "a number", dict: "an object", list: "an array",
               type(None): "null", bool: "true/false"}


def _json_name(value: Any) -> str:
    if isinstance(value, bool):
        return "true/false"
    return {str: "a string", int: "an integer", float: "a number", dict: "an object", list: "an array",
            type(None): "null"}.get(type(value), type(value).__name__)


def _number(obj: Mapping[str, Any], key: str, where: str, required: bool = True, null: bool = False) -> float | None:
    value = _get(obj, key, (int, float, type(None)) if null else (int, float), where, required)
    if value is not None and not math.isfinite(float(value)):
        raise ValidationError(f"'{f'{where}.{key}' if where else key}' must be finite")
    return None if value is None else float(value)


#: ``evaluation`` keys and whether each is a number, an integer or a string (all but ``units``/``bound`` required).
_EVALUATION = {"max_error": "number", "max_error_percent": "number", "mean_error": "number",
               "mean_error_percent": "number", "frame": "integer", "joint": "string", "height": "number",
               "units": "string?", "num_frames": "integer", "num_points": "integer", "bound": "number?"}


_MAX_DEPTH = 32  # nesting of arrays and objects inside one metadata field (motionrep writes at most 3)


def _plain(value: Any, where: str) -> None:
    """``value`` is JSON made of numbers, strings, booleans, null, arrays and objects, nested at most
    ``_MAX_DEPTH`` deep (whoever prints or copies it later may recurse)."""
    stack = [(value, where, 0)]
    while stack:
        v, w, depth = stack.pop()
        if depth > _MAX_DEPTH:
            raise ValidationError(f"'{w}' is nested more than {_MAX_DEPTH} levels deep")
        if isinstance(v, Mapping):
            stack.extend((x, f"{w}.{k}", depth + 1) for k, x in v.items())
        elif isinstance(v, list):
            stack.extend((x, w, depth + 1) for x in v)
        elif not (v is None or isinstance(v, (bool, int, float, str))):
            raise ValidationError(f"'{w}' holds {type(v).__name__}, not JSON")


def _check_outcome(codec_name: str, info: Mapping[str, Any], path) -> None:
    """The installed codec's own check of its outcome (:meth:`motionrep.plugin.codec.Codec.check_info`), its error a
    :class:`ContainerError` naming the file; nothing when no installed codec has that name (decoding then says
    so, naming the file and the plugin, and the outcome is described generically)."""
    from ..errors import MotionrepError, PluginError
    from ..plugin.registry import get_codec

    try:
        codec = get_codec(codec_name)
    except PluginError:
        return
    try:
        codec.check_info(info)
    except (MotionrepError, TypeError, ValueError, KeyError, IndexError, AttributeError, RecursionError) as exc:
        what = str(exc) if isinstance(exc, MotionrepError) else f"{type(exc).__name__}: {exc}"
        raise ContainerError(f"invalid .mrc metadata: codec {codec_name!r} refuses its outcome 'codec.info': "
                             f"{what}", path) from None


def _check_evaluation(ev: Mapping[str, Any]) -> None:
    for key, kind in _EVALUATION.items():
        optional = kind.endswith("?")
        kind = kind.rstrip("?")
        if kind == "number":
            _number(ev, key, "evaluation", required=not optional, null=optional)
        elif kind == "integer":
            _get(ev, key, (int,), "evaluation")
        else:
            _get(ev, key, (str, type(None)) if optional else (str,), "evaluation", required=not optional)


def _check_evaluation_counts(ev: Mapping[str, Any], num_frames: int, skeleton: Skeleton, path) -> None:
    """The stored evaluation was measured on this clip: its frame and point counts are the clip's and its worst
    frame one of them (a file whose metadata and evaluation disagree would decode to a motion nobody measured)."""
    points = skeleton.num_joints + skeleton.num_end_sites
    if ev["num_frames"] != num_frames:
        raise ContainerError(f"inconsistent .mrc file: metadata num_frames is {num_frames}, the stored evaluation "
                             f"was measured on {ev['num_frames']} frames", path)
    if ev["num_points"] != points:
        raise ContainerError(f"inconsistent .mrc file: the skeleton has {points} joints and end sites, the stored "
                             f"evaluation was measured on {ev['num_points']} points", path)
    if not 0 <= ev["frame"] < num_frames:
        raise ContainerError(f"inconsistent .mrc file: the stored evaluation's worst frame {ev['frame']} is not one "
                             f"of the {num_frames} frames", path)


def _stored_bound(meta: Mapping[str, Any], extra: dict[str, Any], evaluation: Mapping[str, Any] | None,
                  skeleton: Skeleton, version: int, path) -> StoredBound | None:
    """The bound the clip was compressed within: ``bound`` (version 2), or in a version-1 file the text
    ``extra.max_error`` (taken out of ``extra``: the bound has one home) with the distance the stored evaluation
    enforced.  A crafted value is refused as the file's (``'bound.kind' is 'abc'``), never reported later as an
    option nobody gave."""
    from ..model.bound import parse_max_error  # the one parse of a bound's text; here only for version-1 files
    from ..errors import ParameterError

    enforced = None if evaluation is None else evaluation.get("bound")
    if version >= 2:
        obj = meta.get("bound")
        if obj is None:
            return None
        try:
            stored = StoredBound.from_json(obj)
        except ValueError as exc:
            raise ContainerError(f"invalid .mrc metadata: 'bound': {exc}", path) from None
    else:
        if "max_error" not in extra:
            return None
        value = extra.pop("max_error")
        if value is None:
            return StoredBound(None, None)
        if isinstance(value, bool) or not isinstance(value, (str, int, float)):
            raise ContainerError(f"invalid .mrc metadata: 'extra.max_error' must be a string, a number or null, "
                                 f"got {_json_name(value)}", path)
        try:
            asked = parse_max_error(value)
        except ParameterError:
            raise ContainerError(f"invalid .mrc metadata: 'extra.max_error' is {str(value)[:80]!r}, not a bound "
                                 "('2%', '1.5' or 'none')", path) from None
        if asked is None:
            return StoredBound(None, None)
        distance = enforced
        if distance is None:  # no stored evaluation says it: resolve it as the writer did
            from ..model.kinematics import character_height

            height = character_height(skeleton)
            distance = None if asked.percent and height <= 0 else asked.bound(height)
        stored = StoredBound(asked, None if distance is None else float(distance))
    if (stored.distance is None) != (enforced is None) and evaluation is not None and "bound" in evaluation:
        raise ContainerError(f"inconsistent .mrc file: the bound is {stored.kind!r}, the stored evaluation "
                             f"enforced {enforced!r}", path)
    if stored.distance is not None and enforced is not None and stored.distance != enforced:
        raise ContainerError(f"inconsistent .mrc file: the bound resolved to {stored.distance!r} file units, the "
                             f"stored evaluation enforced {enforced!r}", path)
    return stored


def _from_meta(meta: dict[str, Any], payload: memoryview, path, file_size: int, version: int) -> Container:
    """The container described by ``meta`` (parsed, untrusted JSON) over ``payload``; every field is type-checked
    and the sizes checked against the payload and the limits before any array is made."""
    table = _get(meta, "arrays", (list,), "")
    entries = []
    seen: set[str] = set()
    offset = 0
    for i, entry in enumerate(table):
        where = f"arrays[{i}]"
        name = _get(entry, "name", (str,), where)
        kind = _get(entry, "dtype", (str,), where)
        shape = _get(entry, "shape", (list,), where)
        if kind not in _DTYPES:
            raise ContainerError(f"invalid .mrc array table: '{where}.dtype' is {kind!r}, not one of "
                                 + ", ".join(_DTYPES), path)
        if not name or name in seen:
            raise ContainerError(f"invalid .mrc array table: '{where}.name' {name[:80]!r} is empty or repeated", path)
        seen.add(name)
        if not all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in shape) or len(shape) > 32:
            raise ContainerError(f"invalid .mrc array table: '{where}.shape' must be at most 32 integers >= 0, got "
                                 f"{shape!r}"[:200], path)
        dtype = np.dtype(_DTYPES[kind]).newbyteorder("<")
        size = math.prod(shape) * dtype.itemsize  # Python integers: a huge shape cannot overflow
        if offset + size > len(payload):
            raise ContainerError(f"invalid .mrc file: array {name!r} of shape {tuple(shape)} runs past the payload "
                                 f"({len(payload)} bytes)"[:300], path)
        entries.append((name, dtype, tuple(shape), offset, size))
        offset += size
    if offset != len(payload):
        raise ContainerError(f"invalid .mrc file: {len(payload) - offset} payload bytes not described by the "
                             "array table", path)
    codec = _get(meta, "codec", (dict,), "")
    rep = _get(meta, "representation", (dict,), "")
    num_frames = _get(meta, "num_frames", (int,), "")
    fps = _number(meta, "fps", "")
    if num_frames < 1 or not fps > 0 or not math.isfinite(1.0 / fps):  # a frame time no file can hold
        raise ContainerError(f"invalid .mrc file: {num_frames} frames at {fps!r} fps (fps must be > 0 with a "
                             "finite frame time 1 / fps)", path)
    try:
        skeleton = skeleton_from_json(_get(meta, "skeleton", (dict,), ""))
    except ValidationError as exc:
        raise ContainerError(str(exc), path) from None
    too_big = check_clip(num_frames, "num_frames", joints=skeleton.num_joints,
                                translated=int(skeleton.translated_joints.shape[0]),
                                angles=skeleton.num_rotation_channels,
                                mrc_bytes=file_size)
    if too_big:
        raise ContainerError(f"invalid .mrc file: {too_big}", path)
    params = _get(codec, "params", (dict, type(None)), "codec", required=False) or {}
    info = _get(codec, "info", (dict, type(None)), "codec", required=False) or {}
    evaluation = _get(meta, "evaluation", (dict, type(None)), "", required=False)
    extra = _get(meta, "extra", (dict, type(None)), "", required=False) or {}
    for value, where in ((params, "codec.params"), (info, "codec.info"), (evaluation, "evaluation"),
                         (extra, "extra")):
        _plain(value, where)
    if evaluation is not None:
        _check_evaluation(evaluation)
        _check_evaluation_counts(evaluation, num_frames, skeleton, path)
    extra = dict(extra)
    bound = _stored_bound(meta, extra, evaluation, skeleton, version, path)
    codec_name = _get(codec, "name", (str,), "codec")
    _check_outcome(codec_name, info, path)
    arrays: dict[str, NDArray[Any]] = {}
    for name, dtype, shape, start, size in entries:
        a = np.frombuffer(payload[start:start + size], dtype=dtype).reshape(shape).astype(dtype.newbyteorder("="))
        a.flags.writeable = False
        arrays[name] = a
    return Container(
        codec=codec_name,
        codec_version=_get(codec, "version", (int,), "codec"),
        codec_plugin=_get(codec, "plugin", (str, type(None)), "codec", required=False),
        params=dict(params),
        info=dict(info),
        representation=_get(rep, "name", (str,), "representation"),
        representation_version=_get(rep, "version", (int,), "representation"),
        representation_plugin=_get(rep, "plugin", (str, type(None)), "representation", required=False),
        skeleton=skeleton,
        fps=fps,
        num_frames=num_frames,
        arrays=arrays,
        evaluation=evaluation,
        extra=extra,
        bound=bound,
    )


def read_container(path: str | os.PathLike[str]) -> Container:
    """Read and verify a ``.mrc`` file.

    Raises:
        ContainerError: naming the file if it cannot be read or fails any check (see :func:`unpack`).
    """
    from ._files import read_regular

    return unpack(read_regular(path, ContainerError), path)
