"""glTF 2.0 (``.gltf`` / ``.glb``) writer and reader: a motion as a skeleton of nodes with animation channels.

The layout is ``specs/formats/gltf.md``.  Files are built and serialised (JSON, GLB chunks, alignment) by
`pygltflib`.  Reading takes the JSON with the standard library and checks every value here: pygltflib's decoder
checks no bounds and spends about 5 ms per glTF object (4 s for a 212-joint clip), so only the GLB framing (20
lines, every length checked) is written here.  The reader decodes what other tools (Blender, three.js, Maya,
Unity, Godot exporters) write: skins, node hierarchies, ``translation`` / ``rotation`` / ``scale`` channels with
STEP, LINEAR or CUBICSPLINE interpolation, resampled onto a uniform frame grid.

Writing: one node per joint and per end site (every parent before its children), all of them the joints of one
skin, under one *armature* node that carries the unit scale to metres and the turn from a Z-up clip to glTF's
Y-up.  One animation: a rotation channel per rotating joint and a translation channel for the root and every
joint with position channels, sampled at the clip's frame times (LINEAR).  Accessors are float32 (glTF has no
float64 animation data); rest offsets are JSON numbers, written exactly.  The armature node's ``extras`` hold
what glTF cannot say (the BVH channel layout, the file's units, which nodes are end sites), so motionrep reads
its own files back in the clip's own units, channel layout and end sites: BVH -> glTF -> BVH agrees within
float32 rounding (about 2e-7 of the character height on the real clips, under the promised 1e-6).

Reading never fetches a URI and never reads a file other than the one given, except a buffer named by a plain
file name beside a ``.gltf`` file (the *glTF separate* layout); every count, offset and length is checked against
the bytes actually present before anything is allocated.  Problems raise
:class:`~motionrep.errors.GLTFFormatError` naming the file.
"""

from __future__ import annotations

import base64
import binascii
import json
import math
import os
import struct
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator
from urllib.parse import unquote

import numpy as np
from numpy.typing import NDArray

from .._model import DEFAULT_JOINT_CHANNELS, DEFAULT_ROOT_CHANNELS, Motion, Skeleton
from ..errors import GLTFFormatError, MotionrepError, ValidationError
from ._atomic import atomic_path

__all__ = [
    "GLTF_FORMAT",
    "GLTF_FORMAT_VERSION",
    "UNIT_METRES",
    "GLTFFile",
    "gltf_bytes",
    "write_gltf",
    "read_gltf",
    "read_gltf_clip",
    "list_gltf_clips",
    "iter_gltf_clips",
]

#: Value of ``extras.motionrep.format`` on the armature node of every glTF file motionrep writes.
GLTF_FORMAT = "motionrep-gltf"
#: Newest version of that ``extras`` layout this motionrep writes and reads (older versions stay readable).
GLTF_FORMAT_VERSION = 1

#: Length units motionrep knows, in metres; a clip in one of these units is written scaled to metres.
UNIT_METRES: dict[str, float] = {"m": 1.0, "cm": 0.01, "mm": 0.001, "dm": 0.1, "km": 1000.0, "in": 0.0254,
                                 "ft": 0.3048}

# Limits on what a file may ask the reader to build: far above any real clip, far below a memory bomb.
_MAX_FILE_BYTES = 1 << 31
_MAX_NODES = 100_000
_MAX_FRAMES = 10_000_000
_MAX_POSE_VALUES = 1 << 28  # frames x joints x 4 float64 values, about 2 GiB
_MAX_DEPTH = 10_000
# Scales that differ by at most this fraction (between axes, or over the frames) are exporters' rounding noise
# (Blender writes 1.0000156): they are read as one uniform, constant scale, their mean.
_SCALE_TOLERANCE = 1e-3
_KEYFRAME_RATES = (24.0, 25.0, 30.0, 48.0, 50.0, 60.0, 100.0, 120.0)

_FLOAT, _BYTE, _UBYTE, _SHORT, _USHORT = 5126, 5120, 5121, 5122, 5123
_COMPONENTS = {_FLOAT: ("<f4", None), _BYTE: ("<i1", 127.0), _UBYTE: ("<u1", 255.0), _SHORT: ("<i2", 32767.0),
               _USHORT: ("<u2", 65535.0)}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_TYPE_NAMES = {1: "SCALAR", 3: "VEC3", 4: "VEC4", 16: "MAT4"}
_PATHS = {"translation": 3, "rotation": 4, "scale": 3}
# Extensions that change only meshes, materials or textures: a file that requires them still has plain animations.
_HARMLESS_EXTENSIONS = {
    "KHR_draco_mesh_compression", "KHR_mesh_quantization", "KHR_texture_transform", "KHR_texture_basisu",
    "EXT_texture_webp", "EXT_texture_avif", "KHR_materials_unlit", "KHR_materials_emissive_strength",
    "KHR_materials_clearcoat", "KHR_materials_transmission", "KHR_materials_volume", "KHR_materials_ior",
    "KHR_materials_specular", "KHR_materials_sheen", "KHR_materials_variants", "KHR_materials_iridescence",
    "KHR_materials_anisotropy", "KHR_materials_dispersion", "KHR_materials_pbrSpecularGlossiness",
    "KHR_lights_punctual", "EXT_mesh_gpu_instancing",
}
# glTF is Y-up: a Z-up clip is turned by -90 degrees about X, (x, y, z) -> (x, z, -y).
_Z_TO_Y = (-math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))


# ---------------------------------------------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------------------------------------------

def _unique(name: str, taken: set[str]) -> str:
    out, k = name, 1
    while out in taken:
        out = f"{name}.{k:03d}"
        k += 1
    taken.add(out)
    return out


def _check_write_options(motion: Motion, scale: float | None, up: str) -> tuple[float, str]:
    if not isinstance(motion, Motion):
        raise ValidationError(f"write_gltf needs a Motion, got {type(motion).__name__}")
    if scale is None:
        scale = UNIT_METRES.get((motion.skeleton.units or "").strip().lower(), 1.0)
    try:
        scale = float(scale)
    except (TypeError, ValueError):
        raise ValidationError(f"scale must be a positive number, got {scale!r}") from None
    if not (math.isfinite(scale) and scale > 0):
        raise ValidationError(f"scale must be a positive number, got {scale!r}")
    if up not in ("auto", "y", "z"):
        raise ValidationError(f"up must be 'auto', 'y' or 'z', got {up!r}")
    if up == "auto":
        from ..kinematics import global_positions
        from ..render import detect_up_axis

        step = max(1, motion.num_frames // 500)  # a few hundred frames decide as well as all of them
        up = detect_up_axis(global_positions(motion.frames(slice(None, None, step))))
    return scale, up


def _build(motion: Motion, name: str, scale: float, up: str) -> tuple[Any, bytes]:
    """The pygltflib document and its binary buffer for ``motion``."""
    import pygltflib as g

    from .. import __version__
    from ..rotations import quat_make_continuous

    sk = motion.skeleton
    J, E, F = sk.num_joints, sk.num_end_sites, motion.num_frames
    taken: set[str] = set(sk.names)
    site_names: list[str] = []
    per_joint: dict[int, int] = {}
    for p in sk.end_site_parents.tolist():
        per_joint[p] = per_joint.get(p, 0) + 1
    seen: dict[int, int] = {}
    for p in sk.end_site_parents.tolist():
        seen[p] = seen.get(p, 0) + 1
        base = f"{sk.names[p]}_end" + (f"{seen[p]}" if per_joint[p] > 1 else "")
        site_names.append(_unique(base, taken))
    armature_name = _unique("Armature", taken)

    # node 0 is the armature; joints are nodes 1..J, end sites J+1..J+E
    children: list[list[int]] = [[] for _ in range(J)]
    for j in range(1, J):
        children[int(sk.parents[j])].append(1 + j)
    for e, p in enumerate(sk.end_site_parents.tolist()):
        children[p].append(1 + J + e)

    chunks: list[bytes] = []
    offset = 0

    def add(data: NDArray) -> tuple[int, int]:
        nonlocal offset
        raw = np.ascontiguousarray(data, dtype="<f4").tobytes()
        start = offset
        chunks.append(raw)
        offset += len(raw)
        return start, len(raw)

    accessors: list[Any] = []
    times = np.arange(F, dtype=np.float64) / motion.fps
    t_off, t_len = add(times)
    t32 = times.astype(np.float32)
    accessors.append(g.Accessor(bufferView=0, byteOffset=0, componentType=_FLOAT, count=F, type="SCALAR",
                                min=[float(t32[0])], max=[float(t32[-1])]))
    outputs: list[tuple[int, NDArray]] = []  # (target node, values) in channel order
    paths: list[str] = []

    rotations = quat_make_continuous(motion.rotations)  # the short way between frames, for interpolating viewers
    for j in range(J):
        q = rotations[:, j]
        if sk.rotation_orders[j] or np.any(np.abs(np.abs(q[:, 3]) - 1.0) > 0):
            outputs.append((1 + j, q))
            paths.append("rotation")
    translations = motion.local_translations()
    for j in [0, *sk.translated_joints.tolist()]:
        if j == 0 and not sk.position_axes[0] and np.all(translations[:, 0] == sk.offsets[0]):
            continue  # a root without position channels stays at its OFFSET: the node's translation says so
        outputs.append((1 + j, translations[:, j]))
        paths.append("translation")

    out_start = offset
    channels, samplers = [], []
    for k, ((node, values), path) in enumerate(zip(outputs, paths)):
        start, _ = add(values)
        accessors.append(g.Accessor(bufferView=1, byteOffset=start - out_start, componentType=_FLOAT, count=F,
                                    type="VEC4" if path == "rotation" else "VEC3"))
        samplers.append(g.AnimationSampler(input=0, output=len(accessors) - 1, interpolation="LINEAR"))
        channels.append(g.AnimationChannel(sampler=k, target=g.AnimationChannelTarget(node=node, path=path)))
    blob = b"".join(chunks)
    buffer_views = [g.BufferView(buffer=0, byteOffset=t_off, byteLength=t_len)]
    if offset > out_start:
        buffer_views.append(g.BufferView(buffer=0, byteOffset=out_start, byteLength=offset - out_start))

    # rest pose: identity rotations, every joint at its OFFSET; the skin binds it (inverse bind = -rest position,
    # in the armature's space, which is the skin's model space)
    from ..kinematics import rest_positions

    rest = rest_positions(sk)
    arm = np.eye(4)
    if up == "z":
        arm[:3, :3] = [[1, 0, 0], [0, 0, 1], [0, -1, 0]]
    arm[:3, :3] *= scale
    ibm = np.zeros((J + E, 4, 4))
    for i in range(J + E):
        m = arm @ np.block([[np.eye(3), rest[i][:, None]], [np.zeros((1, 3)), np.ones((1, 1))]])
        ibm[i] = np.linalg.inv(m)
    ibm_start = len(blob)
    ibm_bytes = ibm.transpose(0, 2, 1).astype("<f4").tobytes()  # glTF matrices are column-major
    blob += ibm_bytes
    buffer_views.append(g.BufferView(buffer=0, byteOffset=ibm_start, byteLength=len(ibm_bytes)))
    accessors.append(g.Accessor(bufferView=len(buffer_views) - 1, byteOffset=0, componentType=_FLOAT,
                                count=J + E, type="MAT4"))

    nodes = [g.Node(name=armature_name, children=[1],
                    rotation=list(_Z_TO_Y) if up == "z" else None,
                    scale=[scale, scale, scale] if scale != 1.0 else None,
                    extras={"motionrep": {
                        "format": GLTF_FORMAT, "version": GLTF_FORMAT_VERSION, "units": sk.units, "scale": scale,
                        "up": up, "channels": [" ".join(c) for c in sk.channels],
                        "end_sites": list(range(1 + J, 1 + J + E)),
                    }})]
    for j in range(J):
        off = sk.offsets[j]
        nodes.append(g.Node(name=sk.names[j], children=children[j] or [],
                            translation=[float(v) for v in off] if np.any(off != 0) else None))
    for e in range(E):
        off = sk.end_site_offsets[e]
        nodes.append(g.Node(name=site_names[e], translation=[float(v) for v in off] if np.any(off != 0) else None))

    doc = g.GLTF2(
        asset=g.Asset(version="2.0", generator=f"motionrep {__version__}"),
        scene=0,
        scenes=[g.Scene(name=name, nodes=[0])],
        nodes=nodes,
        skins=[g.Skin(name=name, joints=list(range(1, 1 + J + E)), skeleton=1,
                      inverseBindMatrices=len(accessors) - 1)],
        animations=[g.Animation(name=name, channels=channels, samplers=samplers,
                                extras={"motionrep": {"fps": motion.fps, "frames": F}})],
        accessors=accessors,
        bufferViews=buffer_views,
        buffers=[g.Buffer(byteLength=len(blob))],
    )
    return doc, blob


def gltf_bytes(motion: Motion, *, binary: bool = True, clip: str = "motion", scale: float | None = None,
               up: str = "auto") -> bytes:
    """``motion`` as the bytes of a ``.glb`` file (``binary=True``) or a self-contained ``.gltf`` JSON file.

    Args and layout as :func:`write_gltf`.
    """
    scale, up = _check_write_options(motion, scale, up)
    doc, blob = _build(motion, str(clip), scale, up)
    if binary:
        doc.set_binary_blob(blob)
        return b"".join(doc.save_to_bytes())
    doc.buffers[0].uri = "data:application/octet-stream;base64," + base64.b64encode(blob).decode("ascii")
    return doc.gltf_to_json().encode("utf-8")


def write_gltf(motion: Motion, path: str | os.PathLike[str], clip: str | None = None, scale: float | None = None,
               up: str = "auto") -> None:
    """Write ``motion`` to a ``.glb`` (binary) or ``.gltf`` (JSON, buffer embedded) file, atomically.

    Args:
        motion: the clip.
        path: the target file; the suffix chooses GLB or JSON.
        clip: the animation's name (default: the file's stem).
        scale: metres per file unit, applied by the armature node (the joints keep the clip's own numbers).
            Default: from ``motion.skeleton.units`` when it is one of :data:`UNIT_METRES`, else 1 (BVH does not
            state its units: give ``scale=0.01`` for a clip in centimetres).
        up: the clip's up axis, ``"y"``, ``"z"`` or ``"auto"`` (:func:`motionrep.render.detect_up_axis`); a
            Z-up clip is turned to glTF's Y-up by the armature node.

    Raises:
        ValidationError: ``motion`` is not a Motion, or a bad ``scale`` or ``up``.
    """
    data = gltf_bytes(motion, binary=Path(path).suffix.lower() == ".glb",
                      clip=Path(path).stem if clip is None else clip, scale=scale, up=up)
    with atomic_path(path) as tmp:
        Path(tmp).write_bytes(data)


# ---------------------------------------------------------------------------------------------------------------
# reading: the container
# ---------------------------------------------------------------------------------------------------------------

class _Doc:
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
            raise self.fail(f"glTF version {version!r} is not supported; motionrep reads glTF 2.x")
        required = [e for e in self.list(raw, "extensionsRequired") if e not in _HARMLESS_EXTENSIONS]
        if required:
            raise self.fail("the file requires glTF extensions motionrep does not read: "
                            + ", ".join(str(e) for e in required[:10]))
        self.nodes = self.list(raw, "nodes")
        if len(self.nodes) > _MAX_NODES:
            raise self.fail(f"{len(self.nodes)} nodes; motionrep reads at most {_MAX_NODES}")
        self.accessors = self.list(raw, "accessors")
        self.buffer_views = self.list(raw, "bufferViews")
        self.buffers = self.list(raw, "buffers")
        self.animations = self.list(raw, "animations")
        self.skins = self.list(raw, "skins")
        self._buffer_cache: dict[int, bytes] = {}

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
        value = _get(obj, key, [])
        if not isinstance(value, list):
            raise self.fail(f"'{key}' must be a list, got {type(value).__name__}")
        return value

    # ---- checked access ------------------------------------------------------------------------------------
    def item(self, items: list, index: Any, what: str) -> Any:
        if not _is_int(index) or not 0 <= index < len(items):
            raise self.fail(f"{what} {index!r} does not exist ({len(items)} defined)")
        obj = items[index]
        if not isinstance(obj, dict):
            raise self.fail(f"{what} {index} is not a JSON object")
        return obj

    def integer(self, obj: Any, key: str, what: str, default: int | None = None, low: int = 0) -> int:
        value = _get(obj, key, default)
        if not _is_int(value) or value < low:
            raise self.fail(f"{what}: '{key}' must be an integer >= {low}, got {value!r}")
        return int(value)

    def floats(self, obj: Any, key: str, n: int, what: str) -> NDArray[np.float64] | None:
        value = _get(obj, key)
        if value is None:
            return None
        if (not isinstance(value, list) or len(value) != n
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
            raise self.fail(f"{what}: '{key}' must be a list of {n} numbers")
        a = np.array(value, dtype=np.float64)
        if not np.all(np.isfinite(a)):
            raise self.fail(f"{what}: '{key}' holds a value that is not finite")
        return a

    def buffer(self, index: int) -> bytes:
        if index in self._buffer_cache:
            return self._buffer_cache[index]
        buf = self.item(self.buffers, index, "buffer")
        length = self.integer(buf, "byteLength", f"buffer {index}", low=1)
        uri = _get(buf, "uri")
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
                return fh.read(length)  # never more than the buffer declares
        except OSError as exc:
            raise self.fail(f"buffer {index}: cannot read {name!r}: {exc.strerror or exc}") from None

    def accessor(self, index: Any, what: str, widths: tuple[int, ...], normalized_ok: bool = False
                 ) -> NDArray[np.float64]:
        """``(count, width)`` float64 values of an accessor, every offset and length checked first."""
        acc = self.item(self.accessors, index, f"{what}: accessor")
        where = f"accessor {index} ({what})"
        kind = _get(acc, "type")
        width = _WIDTH.get(kind) if isinstance(kind, str) else None
        if width not in widths:
            raise self.fail(f"{where} has type {kind!r}; expected "
                            + " or ".join(_TYPE_NAMES[w] for w in widths))
        ctype = _get(acc, "componentType")
        if ctype not in _COMPONENTS or (ctype != _FLOAT and not (normalized_ok and _get(acc, "normalized") is True)):
            raise self.fail(f"{where} has component type {ctype!r}; expected FLOAT (5126)"
                            + (" or normalized integers" if normalized_ok else ""))
        if _get(acc, "sparse") is not None:
            raise self.fail(f"{where} is sparse; motionrep does not read sparse accessors")
        count = self.integer(acc, "count", where, low=1)
        view_index = _get(acc, "bufferView")
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
        values = np.ndarray((count, width), dtype=dtype, buffer=data, offset=view_start + start,
                            strides=(stride, size)).astype(np.float64)
        if norm is not None:
            values = np.maximum(values / norm, -1.0)
        if not np.all(np.isfinite(values)):
            raise self.fail(f"{where} holds values that are not finite")
        return values


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _get(obj: Any, key: str, default: Any = None) -> Any:
    """A field of a JSON object, ``default`` when absent or null (or when ``obj`` is not an object)."""
    value = obj.get(key) if isinstance(obj, dict) else None
    return default if value is None else value


# ---------------------------------------------------------------------------------------------------------------
# reading: nodes, animations, sampling
# ---------------------------------------------------------------------------------------------------------------

@dataclass
class _Rest:
    """A node's own transform: translation, xyzw rotation, uniform scale."""

    t: NDArray[np.float64]
    r: NDArray[np.float64]
    s: float


@dataclass
class _Track:
    """One animation channel: key times, values, interpolation."""

    times: NDArray[np.float64]
    values: NDArray[np.float64]  # (K, width), or (3K, width) for CUBICSPLINE
    interpolation: str


def _node_rest(doc: _Doc, i: int) -> _Rest:
    node = doc.nodes[i]
    what = f"node {i} ({_raw_name(node, i)!r})"
    m = doc.floats(node, "matrix", 16, what)
    if m is not None:
        mat = m.reshape(4, 4).T  # column-major
        t = mat[:3, 3].copy()
        lin = mat[:3, :3]
        col = np.linalg.norm(lin, axis=0)
        if np.linalg.det(lin) <= 0 or np.ptp(col) > _SCALE_TOLERANCE * col.max():
            raise doc.fail(f"{what}: its matrix is not a rotation with a uniform scale; motionrep's pose model "
                           "cannot hold it")
        from ..rotations import matrix_to_quat

        return _Rest(t, matrix_to_quat(lin / col), float(col.mean()))
    t = doc.floats(node, "translation", 3, what)
    r = doc.floats(node, "rotation", 4, what)
    s = doc.floats(node, "scale", 3, what)
    if r is not None:
        n = float(np.linalg.norm(r))
        if not n > 0.5:
            raise doc.fail(f"{what}: 'rotation' {r.tolist()} is not a unit quaternion")
        r = r / n
    return _Rest(np.zeros(3) if t is None else t, np.array([0.0, 0.0, 0.0, 1.0]) if r is None else r,
                 _uniform(doc, s, what))


def _uniform(doc: _Doc, s: NDArray | None, what: str) -> float:
    if s is None:
        return 1.0
    if np.any(s <= 0) or np.ptp(s) > _SCALE_TOLERANCE * float(np.max(s)):
        raise doc.fail(f"{what}: scale {s.tolist()} is not a positive uniform scale; motionrep's pose model "
                       "cannot hold it")
    return float(np.mean(s))


def _raw_name(node: Any, i: int) -> str:
    name = _get(node, "name")
    return name if isinstance(name, str) and name.strip() else f"node{i}"


def _parents(doc: _Doc) -> list[int]:
    """Parent of every node (-1 for none); refuses a node with two parents and cycles."""
    parents = [-1] * len(doc.nodes)
    for i, node in enumerate(doc.nodes):
        doc.item(doc.nodes, i, "node")
        kids = _get(node, "children", [])
        if not isinstance(kids, list):
            raise doc.fail(f"node {i}: 'children' must be a list")
        for c in kids:
            if not _is_int(c) or not 0 <= c < len(doc.nodes) or c == i:
                raise doc.fail(f"node {i} lists child {c!r}, which is not another node")
            if parents[c] != -1:
                raise doc.fail(f"node {c} has two parents (nodes {parents[c]} and {i})")
            parents[c] = i
    for i in range(len(parents)):  # a cycle: walking up never reaches a root
        seen, p = 0, i
        while p != -1:
            p = parents[p]
            seen += 1
            if seen > min(len(parents), _MAX_DEPTH):
                raise doc.fail(f"node {i} is inside a cycle of children, or nested deeper than {_MAX_DEPTH}")
    return parents


def _clips(doc: _Doc) -> list[tuple[str, list[int]]]:
    """The clips of a file: ``(name, animation indices)``.

    Each named animation is a clip (unnamed ones are ``animation0``, ``animation1``...), except that unnamed
    animations that animate different nodes are parts of one clip, ``animation`` (COLLADA2GLTF and other
    converters write one animation per joint).
    """
    unnamed: list[int] = []
    for k, anim in enumerate(doc.animations):
        doc.item(doc.animations, k, "animation")
        raw = _get(anim, "name")
        if not (isinstance(raw, str) and raw.strip()):
            unnamed.append(k)
    if len(unnamed) > 1 and len(unnamed) == len(doc.animations):
        targets: list[int] = []
        for k in unnamed:
            for channel in doc.list(doc.animations[k], "channels"):
                node = _get(_get(channel, "target"), "node")
                targets.append(node if _is_int(node) else -1 - len(targets))
        if len(set(targets)) == len(targets):
            return [("animation", unnamed)]
    names: list[tuple[str, list[int]]] = []
    taken: set[str] = set()
    for k, anim in enumerate(doc.animations):
        raw = _get(anim, "name")
        base = raw.strip() if isinstance(raw, str) and raw.strip() else f"animation{k}"
        names.append((_unique(base, taken), [k]))
    return names


def _channels(doc: _Doc, indices: list[int]) -> Iterator[tuple[int, int, Any, list]]:
    for index in indices:
        anim = doc.item(doc.animations, index, "animation")
        samplers = doc.list(anim, "samplers")
        for c, channel in enumerate(doc.list(anim, "channels")):
            yield index, c, channel, samplers


def _tracks(doc: _Doc, indices: list[int]) -> dict[tuple[int, str], _Track]:
    """The translation, rotation and scale channels of the animations ``indices``, by (node, path)."""
    out: dict[tuple[int, str], _Track] = {}
    for index, c, channel, samplers in _channels(doc, indices):
        what = f"animation {index}, channel {c}"
        target = _get(channel, "target")
        if not isinstance(target, dict):
            raise doc.fail(f"{what} has no target")
        path, node = _get(target, "path"), _get(target, "node")
        if path not in _PATHS or node is None:
            continue  # morph weights, KHR_animation_pointer: not skeleton motion
        if not _is_int(node) or not 0 <= node < len(doc.nodes):
            raise doc.fail(f"{what} targets node {node!r}, which does not exist")
        sampler = doc.item(samplers, _get(channel, "sampler"), f"{what}: sampler")
        interpolation = _get(sampler, "interpolation", "LINEAR")
        if interpolation not in ("LINEAR", "STEP", "CUBICSPLINE"):
            raise doc.fail(f"{what}: unknown interpolation {interpolation!r}")
        times = doc.accessor(_get(sampler, "input"), f"{what} input", (1,))[:, 0]
        if np.any(np.diff(times) < 0):
            raise doc.fail(f"{what}: key times decrease (they must increase)")
        width = _PATHS[path]
        values = doc.accessor(_get(sampler, "output"), f"{what} output", (width,),
                              normalized_ok=path == "rotation")
        need = times.size * (3 if interpolation == "CUBICSPLINE" else 1)
        if values.shape[0] != need:
            raise doc.fail(f"{what}: {times.size} key times but {values.shape[0]} values (expected {need})")
        out[(int(node), path)] = _Track(times, values, interpolation)
    return out


def _sample(track: _Track, times: NDArray[np.float64], rotation: bool, snap: float) -> NDArray[np.float64]:
    """The track's values at ``times`` (held before the first and after the last key)."""
    from ..rotations import quat_slerp

    keys, cubic = track.times, track.interpolation == "CUBICSPLINE"
    values = track.values[1::3] if cubic else track.values
    K = keys.size
    k = np.clip(np.searchsorted(keys, times, side="right") - 1, 0, K - 1)
    nxt = np.minimum(k + 1, K - 1)
    span = keys[nxt] - keys[k]
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.where(span > 0, (times - keys[k]) / np.where(span > 0, span, 1.0), 0.0)
    s = np.clip(s, 0.0, 1.0)
    s = np.where(np.abs(times - keys[k]) <= snap, 0.0, s)  # a frame time on a key takes the key exactly
    s = np.where(np.abs(times - keys[nxt]) <= snap, 1.0, s)
    on_keys = bool(np.all((s == 0.0) | (s == 1.0)))  # baked files: every frame is a key, nothing to interpolate
    if track.interpolation == "STEP" or on_keys:
        out = values[np.where(s >= 1.0, nxt, k)]
    elif cubic:
        a, b = track.values[0::3], track.values[2::3]  # in- and out-tangents
        s2, s3 = s * s, s * s * s
        w = [2 * s3 - 3 * s2 + 1, (s3 - 2 * s2 + s) * span, -2 * s3 + 3 * s2, (s3 - s2) * span]
        out = (w[0][:, None] * values[k] + w[1][:, None] * b[k] + w[2][:, None] * values[nxt]
               + w[3][:, None] * a[nxt])
    elif rotation:
        out = quat_slerp(values[k], values[nxt], s)
    else:
        out = (1 - s)[:, None] * values[k] + s[:, None] * values[nxt]
    if rotation:
        norm = np.linalg.norm(out, axis=-1, keepdims=True)
        if np.any(norm < 1e-6):
            raise MotionrepError("zero quaternion")
        out = out / norm
    return out


def _frame_times(doc: _Doc, tracks: list[_Track], fps_hint: Any, where: str) -> tuple[float, NDArray[np.float64]]:
    """The clip's frame rate and frame times.

    motionrep's own files say their rate.  Otherwise the densest channel's median key step gives it (exporters
    bake one key per frame), rounded to a whole rate within 0.1 %; keys sparser than 24 per second are an
    animator's keyframes, sampled at the first of 24, 25, 30, 48, 50, 60, 100, 120 fps on whose frames every key
    falls (30 fps if none).
    """
    t0 = float(min(t.times[0] for t in tracks))
    t1 = float(max(t.times[-1] for t in tracks))
    if isinstance(fps_hint, (int, float)) and not isinstance(fps_hint, bool) and math.isfinite(fps_hint) \
            and fps_hint > 0:
        fps = float(fps_hint)
    else:
        densest = max(tracks, key=lambda t: t.times.size).times
        steps = np.diff(densest)
        steps = steps[steps > 0]
        fps = 30.0
        if steps.size:
            fps = 1.0 / float(np.median(steps))
            near = round(fps)
            fps = float(near) if near > 0 and abs(fps - near) <= 1e-3 * fps else float(f"{fps:.6g}")
            if fps < 24.0:
                keys = np.concatenate([t.times for t in tracks]) - t0
                fps = next((r for r in _KEYFRAME_RATES if np.all(np.abs(keys * r - np.rint(keys * r)) <= 1e-3)),
                           30.0)
    frames = int(round((t1 - t0) * fps)) + 1
    keys = sum(t.times.size for t in tracks)
    if frames > _MAX_FRAMES or frames > 256 * keys + 16:
        raise doc.fail(f"{where}: {t1 - t0:.6g} s at {fps:g} fps would be {frames} frames from {keys} keys; the "
                       "key times are too sparse or uneven to sample")
    return fps, t0 + np.arange(frames) / fps


# ---------------------------------------------------------------------------------------------------------------
# reading: the skeleton and the motion
# ---------------------------------------------------------------------------------------------------------------

def _joints(doc: _Doc, parents: list[int], tracks: dict[tuple[int, str], _Track], where: str) -> tuple[int, list[int]]:
    """The skeleton's root node and its nodes in depth-first order (parents first)."""
    animated = {node for node, _ in tracks}
    members: set[int] | None = None
    best = 0
    for s, skin in enumerate(doc.skins):
        doc.item(doc.skins, s, "skin")
        joints = doc.list(skin, "joints")
        for j in joints:
            if not _is_int(j) or not 0 <= j < len(doc.nodes):
                raise doc.fail(f"skin {s} lists joint {j!r}, which is not a node")
        hit = len(animated.intersection(joints))
        if joints and (members is None or hit > best):
            members, best = set(joints), hit
    if members is None or best == 0:
        # no skin drives this animation: its animated nodes and the plain transform nodes under them
        members = set(animated)
        stack = list(animated)
        while stack:
            for c in _get(doc.nodes[stack.pop()], "children", []):
                if c not in members and all(_get(doc.nodes[c], k) is None for k in ("mesh", "camera", "skin")):
                    members.add(c)
                    stack.append(c)
    if not members:
        raise doc.fail(f"{where} animates no node")

    def chain(i: int) -> list[int]:
        out = [i]
        while parents[out[-1]] != -1:
            out.append(parents[out[-1]])
        return out[::-1]  # from the top

    chains = [chain(i) for i in sorted(members)]
    root = None
    for level in zip(*chains):
        if len(set(level)) != 1:
            break
        root = level[0]
    if root is None:
        raise doc.fail(f"{where}: the skeleton's joints are not under one root node")
    keep = {root}
    for c in chains:
        keep.update(c[c.index(root):])
    order: list[int] = []
    stack = [root]
    while stack:
        i = stack.pop()
        order.append(i)
        kids = [c for c in _get(doc.nodes[i], "children", []) if c in keep]
        stack.extend(reversed(kids))
    return root, order


def _names(doc: _Doc, nodes: list[int]) -> list[str]:
    taken: set[str] = set()
    out = []
    for i in nodes:
        raw = _raw_name(doc.nodes[i], i)
        clean = " ".join(raw.replace("{", "_").replace("}", "_").split()) or f"node{i}"
        out.append(_unique(clean, taken))
    return out


def _motionrep_extras(doc: _Doc, root: int, parents: list[int]) -> dict | None:
    """motionrep's own description on the armature node above ``root``, if it is there and still true."""
    arm = parents[root]
    if arm == -1:
        return None
    extras = _get(doc.nodes[arm], "extras")
    info = extras.get("motionrep") if isinstance(extras, dict) else None
    if not isinstance(info, dict) or info.get("format") != GLTF_FORMAT:
        return None
    version = info.get("version")
    if not _is_int(version) or version > GLTF_FORMAT_VERSION:
        raise doc.fail(f"motionrep glTF layout version {version!r} is newer than this motionrep reads "
                       f"({GLTF_FORMAT_VERSION}); upgrade motionrep")
    scale, up = info.get("scale"), info.get("up")
    rest = _node_rest(doc, arm)
    want_r = np.array(_Z_TO_Y if up == "z" else (0.0, 0.0, 0.0, 1.0))
    if (not isinstance(scale, (int, float)) or not np.allclose(rest.s, scale, rtol=1e-12, atol=0)
            or not np.allclose(rest.t, 0.0) or not np.allclose(rest.r, want_r, atol=1e-12)):
        return None  # the armature was moved since motionrep wrote it: read it as any other file
    return info


def _read_animation(doc: _Doc, indices: list[int], name: str) -> Motion:
    where = f"animation {name!r}"
    parents = _parents(doc)
    tracks = _tracks(doc, indices)
    if not tracks:
        raise doc.fail(f"{where} has no translation, rotation or scale channels")
    root, order = _joints(doc, parents, tracks, where)
    ours = _motionrep_extras(doc, root, parents)
    ancestors: list[int] = []
    if ours is None:
        p = parents[root]
        while p != -1:
            ancestors.append(p)
            p = parents[p]
        ancestors.reverse()  # from the top
    involved = set(order) | set(ancestors)
    used = [t for (node, _), t in tracks.items() if node in involved]
    if not used:
        raise doc.fail(f"{where} animates none of the skeleton's nodes")
    extras = _get(doc.animations[indices[0]], "extras")
    hint = None
    if ours is not None and isinstance(extras, dict) and isinstance(extras.get("motionrep"), dict):
        hint = extras["motionrep"].get("fps")
    fps, times = _frame_times(doc, used, hint, where)
    F = times.size
    if F * (len(order) + 1) * 4 > _MAX_POSE_VALUES:
        raise doc.fail(f"{where}: {F} frames of {len(order)} joints is more than motionrep holds in memory")
    snap = 0.01 / fps

    def channel(node: int, path: str, rest: NDArray, what: str) -> NDArray[np.float64]:
        track = tracks.get((node, path))
        if track is None:
            return np.broadcast_to(rest, (F, rest.size))
        try:
            return _sample(track, times, path == "rotation", snap)
        except MotionrepError:
            raise doc.fail(f"{where}: {what} has a zero rotation quaternion") from None

    def scale_of(node: int, rest: _Rest, what: str) -> float:
        track = tracks.get((node, "scale"))
        if track is None:
            return rest.s
        values = track.values
        s = float(values[0, 0])
        if not (s > 0 and np.all(np.abs(values - s) <= _SCALE_TOLERANCE * s)):
            raise doc.fail(f"{where}: {what} has an animated or non-uniform scale; motionrep's pose model holds "
                           "rotations and translations only")
        return s

    # what is above the skeleton (a foreign file's armature or scene nodes) is folded into the root
    from ..rotations import quat_apply, quat_multiply

    top_r = np.broadcast_to(np.array([0.0, 0.0, 0.0, 1.0]), (F, 4))
    top_t = np.zeros((F, 3))
    top_s = 1.0
    rest_r, rest_t = np.array([0.0, 0.0, 0.0, 1.0]), np.zeros(3)  # the same, in the rest pose
    for a in ancestors:
        rest = _node_rest(doc, a)
        what = f"node {_raw_name(doc.nodes[a], a)!r}"
        t = channel(a, "translation", rest.t, what)
        r = channel(a, "rotation", rest.r, what)
        top_t = top_t + top_s * quat_apply(top_r, t)
        top_r = quat_multiply(top_r, r)
        rest_t = rest_t + top_s * quat_apply(rest_r, rest.t)
        rest_r = quat_multiply(rest_r, rest.r)
        top_s *= scale_of(a, rest, what)

    names = _names(doc, order)
    index_of = {node: k for k, node in enumerate(order)}
    J = len(order)
    rests = [_node_rest(doc, i) for i in order]
    cum = np.ones(J)  # the scale of each joint's frame, folded into its children's translations
    parent_idx = np.full(J, -1, dtype=np.int64)
    for k, i in enumerate(order):
        cum[k] = (top_s if k == 0 else cum[index_of[parents[i]]]) * scale_of(i, rests[k], f"node {names[k]!r}")
        if k:
            parent_idx[k] = index_of[parents[i]]
    above = np.array([top_s if k == 0 else cum[parent_idx[k]] for k in range(J)])
    offsets = np.array([r.t for r in rests]) * above[:, None]
    rotations = np.empty((F, J, 4))
    translations = np.empty((F, J, 3))
    for k, i in enumerate(order):
        what = f"joint {names[k]!r}"
        rotations[:, k] = channel(i, "rotation", rests[k].r, what)
        translations[:, k] = channel(i, "translation", rests[k].t, what) * above[k]
    rotations[:, 0] = quat_multiply(top_r, rotations[:, 0])
    translations[:, 0] = top_t + quat_apply(top_r, translations[:, 0])
    if ancestors:  # the root's OFFSET: where the rest pose puts it
        offsets[0] = rest_t + quat_apply(rest_r, offsets[0])
    if ours is None:
        _rest_to_identity(parent_idx, rest_r, [r.r for r in rests], offsets, rotations, translations)

    sites: list[int] = []
    channels: list[tuple[str, ...]] | None = None
    units = "m"
    if ours is not None:
        units = ours.get("units") if isinstance(ours.get("units"), str) else None
        flagged = ours.get("end_sites")
        flagged = set(flagged) if isinstance(flagged, list) else set()
        sites = [k for k, i in enumerate(order) if k and i in flagged and not _get(doc.nodes[i], "children")]
        layout = ours.get("channels")
        if isinstance(layout, list) and len(layout) == J - len(sites) and all(isinstance(c, str) for c in layout):
            channels = [tuple(c.split()) for c in layout]
    return _assemble(doc, where, names, parent_idx, offsets, rotations, translations, sites, channels, units, fps)


def _rest_to_identity(parents: NDArray, top: NDArray, rest: list[NDArray], offsets: NDArray, rotations: NDArray,
                      translations: NDArray) -> None:
    """Re-express a skeleton so that zero rotations give the file's rest pose, as in BVH (in place).

    glTF joints have rest rotations; motionrep's rest pose is every rotation zero, every joint at its OFFSET.
    With ``G`` the rest pose's global rotations, the new OFFSETs and translations are ``G[parent] @ t`` and the
    new local rotations ``G[parent] * q * G[joint]^-1``: every world position is unchanged and the character
    height measures the rest pose the file describes.
    """
    from ..rotations import quat_apply, quat_conjugate, quat_multiply

    J = len(rest)
    G = np.empty((J, 4))
    for k in range(J):
        G[k] = quat_multiply(top if k == 0 else G[parents[k]], rest[k])
    inverse = quat_conjugate(G)
    rotations[:, 0] = quat_multiply(rotations[:, 0], inverse[0])
    if J > 1:
        above = G[parents[1:]]
        offsets[1:] = quat_apply(above, offsets[1:])
        translations[:, 1:] = quat_apply(above, translations[:, 1:])
        rotations[:, 1:] = quat_multiply(quat_multiply(above, rotations[:, 1:]), inverse[1:])


def _assemble(doc: _Doc, where: str, names: list[str], parents: NDArray, offsets: NDArray, rotations: NDArray,
              translations: NDArray, sites: list[int], channels: list[tuple[str, ...]] | None, units: str | None,
              fps: float) -> Motion:
    """The Motion: end sites split off, translated joints found, the channel layout chosen."""
    from ..kinematics import character_height
    from ..rotations import euler_to_quat, quat_to_euler

    J = len(names)
    is_site = np.zeros(J, bool)
    is_site[sites] = True
    joints = [k for k in range(J) if not is_site[k]]
    new = {k: n for n, k in enumerate(joints)}
    site_parents = [new[int(parents[k])] for k in sites if not is_site[parents[k]]]
    if len(site_parents) != len(sites):
        raise doc.fail(f"{where}: an end site hangs from another end site")
    try:
        skeleton = Skeleton(names=[names[k] for k in joints],
                            parents=[-1 if k == 0 else new[int(parents[k])] for k in joints],
                            offsets=offsets[joints], channels=channels,
                            end_site_parents=site_parents, end_site_offsets=offsets[sites].reshape(-1, 3),
                            units=units)
    except ValidationError as exc:
        if channels is None:
            raise doc.fail(f"{where}: {exc}") from None
        return _assemble(doc, where, names, parents, offsets, rotations, translations, sites, None, units, fps)
    rot = rotations[:, joints]
    trans = translations[:, joints]
    if channels is None:
        size = max(character_height(skeleton), float(np.abs(offsets).max(initial=0.0)), 1e-12)
        moved = [k for k in range(1, len(joints)) if np.any(np.abs(trans[:, k] - skeleton.offsets[k]) > 1e-6 * size)]
        layout = [DEFAULT_ROOT_CHANNELS] + [
            (("Xposition", "Yposition", "Zposition") if k in moved else ()) + DEFAULT_JOINT_CHANNELS
            for k in range(1, len(joints))]
        skeleton = skeleton.replace(channels=layout)
    else:
        # the clip's own layout: float32 storage must not invent motion its channels cannot hold, so values
        # within float32 rounding of an axis without a channel are put back exactly
        size = max(character_height(skeleton), float(np.abs(offsets).max(initial=0.0)), 1e-12)
        for k, axes in enumerate(skeleton.position_axes):
            for a in "XYZ":
                if a not in axes:
                    c = "XYZ".index(a)
                    near = np.abs(trans[:, k, c] - skeleton.offsets[k, c]) <= 1e-6 * size
                    trans[near, k, c] = skeleton.offsets[k, c]
        for k, order in enumerate(skeleton.rotation_orders):
            if len(order) == 3:
                continue
            if not order:
                near = np.abs(rot[:, k, :3]).max(axis=-1) <= 1e-6
                rot[near, k] = (0.0, 0.0, 0.0, 1.0)
                continue
            full = order + "".join(a for a in "XYZ" if a not in order)
            angles = quat_to_euler(rot[:, k], full)
            near = np.abs(angles[:, len(order):]).max(axis=-1) <= 1e-5
            rot[near, k] = euler_to_quat(angles[near, :len(order)], order)
    translated = skeleton.translated_joints
    try:
        return Motion(skeleton, fps, trans[:, 0], rot, trans[:, translated] if translated.size else None)
    except ValidationError as exc:
        raise doc.fail(f"{where}: {exc}") from None


# ---------------------------------------------------------------------------------------------------------------
# public reading API
# ---------------------------------------------------------------------------------------------------------------

class GLTFFile:
    """A glTF file, parsed once: the names of its clips, each clip read when asked for.

    Each named animation is a clip; unnamed ones are ``animation0``, ``animation1``..., except that unnamed
    animations of different nodes are read together as one clip, ``animation`` (converters such as COLLADA2GLTF
    write one animation per joint).

    Raises:
        GLTFFormatError: naming the file, when it is missing, malformed or unsafe (see ``specs/formats/gltf.md``).
    """

    def __init__(self, path: str | os.PathLike[str]):
        self.path = path
        self._doc = _Doc(path)
        self._clips = _clips(self._doc)

    @property
    def names(self) -> list[str]:
        """The clips' names, in the file's order."""
        return [name for name, _ in self._clips]

    def read_clip(self, clip: str | None = None) -> tuple[str, Motion]:
        """``(name, motion)`` of clip ``clip`` (may be omitted when the file holds exactly one).

        Raises:
            GLTFFormatError: naming the file: no animation, several and none chosen, no such clip, or an
                animation motionrep's pose model cannot hold (non-uniform or animated scale...).
        """
        names = self.names
        if not names:
            raise self._doc.fail("the file holds no animation (motionrep reads animated skeletons)")
        if clip is None:
            if len(names) > 1:
                raise self._doc.fail(f"the file holds {len(names)} animations; choose one with clip=NAME (--clip "
                                     "NAME): " + ", ".join(names[:20]) + (" ..." if len(names) > 20 else ""))
            index = 0
        elif clip in names:
            index = names.index(clip)
        else:
            raise self._doc.fail(f"no animation named {clip!r}; animations in this file: " + ", ".join(names[:20]))
        name, indices = self._clips[index]
        return name, _read_animation(self._doc, indices, name)

    def read(self, clip: str | None = None) -> Motion:
        """Clip ``clip`` as a :class:`~motionrep.Motion` (see :meth:`read_clip`)."""
        return self.read_clip(clip)[1]

    def summaries(self) -> list[dict[str, Any]]:
        """Per clip: ``name``, ``kind`` (``"motion"``), ``frames``, ``fps``, ``duration``, ``joints``."""
        out = []
        for name in self.names:
            m = self.read(name)
            out.append({"name": name, "kind": "motion", "frames": m.num_frames, "fps": m.fps,
                        "duration": m.duration, "joints": m.num_joints})
        return out


def list_gltf_clips(path: str | os.PathLike[str]) -> list[str]:
    """Names of the clips (animations) in a glTF file; see :class:`GLTFFile`."""
    return GLTFFile(path).names


def read_gltf_clip(path: str | os.PathLike[str], clip: str | None = None) -> tuple[str, Motion]:
    """Read one animation of a ``.gltf`` / ``.glb`` file as ``(name, motion)`` (see :class:`GLTFFile`).

    Raises:
        GLTFFormatError: naming the file: malformed or unsafe content, an animation that cannot be held by
            motionrep's pose model (non-uniform or animated scale), no animation, or several and none chosen.
    """
    return GLTFFile(path).read_clip(clip)


def read_gltf(path: str | os.PathLike[str], clip: str | None = None) -> Motion:
    """Read one animation of a glTF file as a :class:`~motionrep.Motion` (see :class:`GLTFFile`)."""
    return read_gltf_clip(path, clip)[1]


def iter_gltf_clips(path: str | os.PathLike[str]) -> Iterator[tuple[str, Motion]]:
    """Yield ``(name, motion)`` for every clip of a glTF file, one at a time."""
    f = GLTFFile(path)
    for name in f.names:
        yield f.read_clip(name)
