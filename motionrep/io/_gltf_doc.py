"""glTF reading, part 1: the container, checked.  A :class:`Doc` holds a file's JSON (parsed by the standard
library) and gives checked access to it and to its buffers: every index, offset, stride and count is checked
against the bytes actually present before any array is made, nothing is fetched, and no file is read but the
one given or a plain-named buffer beside a ``.gltf`` file (``specs/formats/gltf.md``, *Safety*).
"""

from __future__ import annotations

import base64
import binascii
import json
import math
import os
import struct
from pathlib import Path
from typing import Any
from urllib.parse import unquote

import numpy as np
from numpy.typing import NDArray

from ..errors import GLTFFormatError

__all__ = ["Doc", "is_int", "get", "number", "short", "GLTF_FORMAT", "GLTF_FORMAT_VERSION", "Z_TO_Y", "FLOAT", "MAX_ANIMATIONS"]

#: Value of ``extras.motionrep.format`` on the armature node of every glTF file motionrep writes.
GLTF_FORMAT = "motionrep-gltf"
#: Newest version of that ``extras`` layout this motionrep writes and reads (older versions stay readable).
GLTF_FORMAT_VERSION = 1
# glTF is Y-up: a Z-up clip is turned by -90 degrees about X, (x, y, z) -> (x, z, -y).
Z_TO_Y = (-math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))

# Limits on what a file may ask the reader to build: far above any real clip, far below a memory bomb.
_MAX_FILE_BYTES = 1 << 31
_MAX_NODES = 100_000
#: Animations one file may hold (each is a clip, or part of one); far above any real file.
MAX_ANIMATIONS = 100_000
# Values of all accessors read from one file, as float64 bytes: at most this many bytes plus 16 per byte of data
# (float32 keys take 2 per byte, normalized bytes 8); accessors sharing a buffer view do not multiply memory.
_ACCESSOR_FREE_BYTES = 64 << 20

FLOAT, _BYTE, _UBYTE, _SHORT, _USHORT = 5126, 5120, 5121, 5122, 5123
_COMPONENTS = {FLOAT: ("<f4", None), _BYTE: ("<i1", 127.0), _UBYTE: ("<u1", 255.0), _SHORT: ("<i2", 32767.0),
               _USHORT: ("<u2", 65535.0)}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_TYPE_NAMES = {1: "SCALAR", 3: "VEC3", 4: "VEC4", 16: "MAT4"}
# Extensions that change only meshes, materials or textures: a file that requires them still has plain animations.
_HARMLESS_EXTENSIONS = {
    "KHR_draco_mesh_compression", "KHR_mesh_quantization", "KHR_texture_transform", "KHR_texture_basisu",
    "EXT_texture_webp", "EXT_texture_avif", "KHR_materials_unlit", "KHR_materials_emissive_strength",
    "KHR_materials_clearcoat", "KHR_materials_transmission", "KHR_materials_volume", "KHR_materials_ior",
    "KHR_materials_specular", "KHR_materials_sheen", "KHR_materials_variants", "KHR_materials_iridescence",
    "KHR_materials_anisotropy", "KHR_materials_dispersion", "KHR_materials_pbrSpecularGlossiness",
    "KHR_lights_punctual", "EXT_mesh_gpu_instancing",
}


class Doc:
    """A parsed glTF document with checked access to its JSON and its buffers."""

    def __init__(self, path: str | os.PathLike[str]):
        self.path = path
        self.fail = lambda message: GLTFFormatError(message, path)
        p = Path(path)
        try:
            size = p.stat().st_size
        except FileNotFoundError:
            raise self.fail("no such file") from None
        except OSError as exc:
            raise self.fail(f"cannot read file: {exc.strerror or exc}") from None
        if not p.is_file():
            raise self.fail("not a regular file")
        if size > _MAX_FILE_BYTES:
            raise self.fail(f"file of {size} bytes is larger than the {_MAX_FILE_BYTES} bytes motionrep reads")
        try:
            data = p.read_bytes()
        except OSError as exc:
            raise self.fail(f"cannot read file: {exc.strerror or exc}") from None
        self.bin: bytes | None = None
        if data[:4] == b"glTF":
            json_bytes = self._glb_chunks(data)
        else:
            json_bytes = data
        try:
            text = json_bytes.decode("utf-8-sig")
        except UnicodeDecodeError:
            raise self.fail("not a glTF file: neither GLB (no 'glTF' magic) nor UTF-8 JSON") from None
        try:
            raw = json.loads(text)
        except (ValueError, RecursionError) as exc:
            raise self.fail(f"not a glTF file: invalid JSON ({str(exc)[:200]})") from None
        if not isinstance(raw, dict) or not isinstance(raw.get("asset"), dict):
            raise self.fail("not a glTF file: the JSON has no 'asset' object")
        version = raw["asset"].get("version")
        if not isinstance(version, str) or not version.startswith("2."):
            raise self.fail(f"glTF version {short(version)} is not supported; motionrep reads glTF 2.x")
        required = self.list(raw, "extensionsRequired")
        if not all(isinstance(e, str) for e in required):
            raise self.fail("'extensionsRequired' must be a list of extension names (strings)")
        required = [e for e in required if e not in _HARMLESS_EXTENSIONS]
        if required:
            raise self.fail("the file requires glTF extensions motionrep does not read: "
                            + ", ".join(repr(e[:80]) for e in required[:10]))
        self.nodes = self.list(raw, "nodes")
        if len(self.nodes) > _MAX_NODES:
            raise self.fail(f"{len(self.nodes)} nodes; motionrep reads at most {_MAX_NODES}")
        self.accessors = self.list(raw, "accessors")
        self.buffer_views = self.list(raw, "bufferViews")
        self.buffers = self.list(raw, "buffers")
        self.animations = self.list(raw, "animations")
        if len(self.animations) > MAX_ANIMATIONS:
            raise self.fail(f"{len(self.animations)} animations; motionrep reads at most {MAX_ANIMATIONS}")
        self.skins = self.list(raw, "skins")
        self._buffer_cache: dict[int, bytes] = {}
        self._accessor_cache: dict[tuple, NDArray[np.float64]] = {}
        self._data_bytes = size  # the file, and the sibling buffers read for it
        self._accessor_bytes = 0

    def _glb_chunks(self, data: bytes) -> bytes:
        """Check the GLB header and chunk table; keep the BIN chunk; return the JSON chunk."""
        if len(data) < 12:
            raise self.fail("truncated GLB file (shorter than its 12-byte header)")
        _, version, length = struct.unpack_from("<4sII", data, 0)
        if version != 2:
            raise self.fail(f"GLB container version {version} is not supported; motionrep reads version 2")
        if length != len(data):
            raise self.fail(f"GLB header says {length} bytes but the file has {len(data)} (truncated or padded)")
        chunks: list[tuple[bytes, int, int]] = []
        at = 12
        while at < len(data):
            if at + 8 > len(data):
                raise self.fail(f"truncated GLB chunk header at byte {at}")
            size, kind = struct.unpack_from("<I4s", data, at)
            if at + 8 + size > len(data):
                raise self.fail(f"GLB chunk at byte {at} claims {size} bytes, past the end of the file")
            chunks.append((kind, at + 8, size))
            at += 8 + size
        if not chunks or chunks[0][0] != b"JSON":
            raise self.fail("GLB file does not start with a JSON chunk")
        bins = [c for c in chunks[1:] if c[0] == b"BIN\x00"]
        if bins:
            _, start, size = bins[0]
            self.bin = data[start:start + size]
        _, start, size = chunks[0]
        return data[start:start + size]

    def list(self, obj: Any, key: str) -> list:
        value = get(obj, key, [])
        if not isinstance(value, list):
            raise self.fail(f"'{key}' must be a list, got {type(value).__name__}")
        return value

    # ---- checked access ------------------------------------------------------------------------------------
    def item(self, items: list, index: Any, what: str) -> Any:
        if not is_int(index) or not 0 <= index < len(items):
            raise self.fail(f"{what} {short(index)} does not exist ({len(items)} defined)")
        obj = items[index]
        if not isinstance(obj, dict):
            raise self.fail(f"{what} {index} is not a JSON object")
        return obj

    def integer(self, obj: Any, key: str, what: str, default: int | None = None, low: int = 0) -> int:
        value = get(obj, key, default)
        if not is_int(value) or value < low:
            raise self.fail(f"{what}: '{key}' must be an integer >= {low}, got {short(value)}")
        return int(value)

    def floats(self, obj: Any, key: str, n: int, what: str) -> NDArray[np.float64] | None:
        value = get(obj, key)
        if value is None:
            return None
        if not isinstance(value, list) or len(value) != n:
            raise self.fail(f"{what}: '{key}' must be a list of {n} numbers")
        out = [number(v) for v in value]
        if any(v is None for v in out):
            bad = next(v for v, f in zip(value, out) if f is None)
            raise self.fail(f"{what}: '{key}' must be a list of {n} numbers, all finite, not {short(bad)}")
        return np.array(out, dtype=np.float64)

    def buffer(self, index: int) -> bytes:
        if index in self._buffer_cache:
            return self._buffer_cache[index]
        buf = self.item(self.buffers, index, "buffer")
        length = self.integer(buf, "byteLength", f"buffer {index}", low=1)
        if length > _MAX_FILE_BYTES:
            raise self.fail(f"buffer {index} declares {length} bytes; no buffer motionrep reads holds more than "
                            f"{_MAX_FILE_BYTES}")
        uri = get(buf, "uri")
        if uri is None:
            if index != 0 or self.bin is None:
                raise self.fail(f"buffer {index} has no uri and the file has no GLB binary chunk")
            data = self.bin
        elif not isinstance(uri, str):
            raise self.fail(f"buffer {index}: 'uri' must be a string")
        elif uri.startswith("data:"):
            head, sep, body = uri.partition(",")
            if not sep or not head.endswith(";base64"):
                raise self.fail(f"buffer {index}: only base64 data URIs are read")
            try:
                data = base64.b64decode("".join(body.split()), validate=True)
            except (binascii.Error, ValueError):
                raise self.fail(f"buffer {index}: invalid base64 in its data URI") from None
        else:
            data = self._sibling(index, uri, length)
        if len(data) < length:
            raise self.fail(f"buffer {index} declares {length} bytes but holds {len(data)}")
        self._buffer_cache[index] = data
        return data

    def _sibling(self, index: int, uri: str, length: int) -> bytes:
        """A buffer in a file beside a ``.gltf`` file, named by a plain relative file name; nothing else."""
        name = unquote(uri)
        if (":" in name or "/" in name or "\\" in name or name in ("", ".", "..") or name.startswith(".")
                or "\x00" in name):
            raise self.fail(f"buffer {index} points to {uri[:80]!r}: motionrep reads only buffers inside the "
                            "file or in a file beside it named by a plain file name, and never fetches a URI")
        folder = Path(self.path).resolve().parent
        target = folder / name
        try:
            resolved = target.resolve(strict=True)
        except (OSError, RuntimeError):
            raise self.fail(f"buffer {index}: file {name!r} beside the glTF file is missing") from None
        if resolved.parent != folder or not resolved.is_file():
            raise self.fail(f"buffer {index}: {name!r} is not a regular file beside the glTF file")
        try:
            with open(resolved, "rb") as fh:
                have = os.fstat(fh.fileno()).st_size
                if have < length:  # checked before reading: read(length) would allocate all of it
                    raise self.fail(f"buffer {index} declares {length} bytes but {name!r} holds {have}")
                data = fh.read(length)  # never more than the buffer declares
                self._data_bytes += len(data)
                return data
        except OSError as exc:
            raise self.fail(f"buffer {index}: cannot read {name!r}: {exc.strerror or exc}") from None

    def accessor(self, index: Any, what: str, widths: tuple[int, ...], normalized_ok: bool = False
                 ) -> NDArray[np.float64]:
        """``(count, width)`` float64 values of an accessor, every offset and length checked first."""
        acc = self.item(self.accessors, index, f"{what}: accessor")
        key = (index, widths, normalized_ok)
        if key in self._accessor_cache:  # channels sharing a sampler or an accessor share its values
            return self._accessor_cache[key]
        where = f"accessor {index} ({what})"
        kind = get(acc, "type")
        width = _WIDTH.get(kind) if isinstance(kind, str) else None
        if width not in widths:
            raise self.fail(f"{where} has type {short(kind)}; expected "
                            + " or ".join(_TYPE_NAMES[w] for w in widths))
        ctype = get(acc, "componentType")
        if not is_int(ctype) or ctype not in _COMPONENTS or (ctype != FLOAT and not (normalized_ok and get(acc, "normalized") is True)):
            raise self.fail(f"{where} has component type {short(ctype)}; expected FLOAT (5126)"
                            + (" or normalized integers" if normalized_ok else ""))
        if get(acc, "sparse") is not None:
            raise self.fail(f"{where} is sparse; motionrep does not read sparse accessors")
        count = self.integer(acc, "count", where, low=1)
        view_index = get(acc, "bufferView")
        if view_index is None:
            raise self.fail(f"{where} has no bufferView (no data)")
        view = self.item(self.buffer_views, view_index, f"{where}: bufferView")
        dtype, norm = _COMPONENTS[ctype]
        size = np.dtype(dtype).itemsize
        element = size * width
        stride = self.integer(view, "byteStride", f"bufferView {view_index}", default=element, low=1)
        if stride < element:
            raise self.fail(f"bufferView {view_index}: byteStride {stride} is smaller than an element "
                            f"({element} bytes)")
        start = self.integer(acc, "byteOffset", where, default=0)
        view_start = self.integer(view, "byteOffset", f"bufferView {view_index}", default=0)
        view_length = self.integer(view, "byteLength", f"bufferView {view_index}", low=1)
        data = self.buffer(self.integer(view, "buffer", f"bufferView {view_index}"))
        if view_start + view_length > len(data):
            raise self.fail(f"bufferView {view_index} ends at byte {view_start + view_length}, past the end of "
                            f"its buffer ({len(data)} bytes)")
        end = start + stride * (count - 1) + element
        if end > view_length:
            raise self.fail(f"{where}: {count} elements need {end} bytes of bufferView {view_index}, which has "
                            f"{view_length}")
        if (view_start + start) % size or stride % size:
            raise self.fail(f"{where} is not aligned to its {size}-byte components")
        self._accessor_bytes += 8 * count * width
        budget = _ACCESSOR_FREE_BYTES + 16 * self._data_bytes
        if self._accessor_bytes > budget:
            raise self.fail(f"{where}: its accessors add up to {self._accessor_bytes} bytes of values, more than "
                            f"{budget} for a file of {self._data_bytes} bytes (accessors overlapping one another)")
        values = np.ndarray((count, width), dtype=dtype, buffer=data, offset=view_start + start,
                            strides=(stride, size)).astype(np.float64)
        if norm is not None:
            values = np.maximum(values / norm, -1.0)
        if not np.all(np.isfinite(values)):
            raise self.fail(f"{where} holds values that are not finite")
        values.flags.writeable = False  # shared by the channels that use it
        self._accessor_cache[key] = values
        return values


def is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def number(value: Any) -> float | None:
    """``value`` as a finite float, or None when it is not a JSON number (a bool, string, list, object...), not
    finite (NaN, infinity) or beyond float64 (an integer of 400 digits)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        f = float(value)
    except OverflowError:
        return None
    return f if math.isfinite(f) else None


def short(value: Any) -> str:
    """A JSON value for a message: its repr cut to 60 characters."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def get(obj: Any, key: str, default: Any = None) -> Any:
    """A field of a JSON object, ``default`` when absent or null (or when ``obj`` is not an object)."""
    value = obj.get(key) if isinstance(obj, dict) else None
    return default if value is None else value
