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

This module writes and holds the public API; reading is split in three: ``_gltf_doc`` (the container, checked),
``_gltf_anim`` (animations, channels, frame times, sampling) and ``_gltf_read`` (the skeleton and the motion).
"""

from __future__ import annotations

import base64
import math
import os
from pathlib import Path
from typing import Any, Iterator

import numpy as np
from numpy.typing import NDArray

from ..model._pose import Motion
from ..errors import Note, ValidationError, naming
from ..formats import BY_NAME
from ._atomic import atomic_path
from ._clipfile import ClipFile
from ._gltf_anim import Unique, clips
from ._gltf_doc import FLOAT, GLTF_FORMAT, GLTF_FORMAT_VERSION, Z_TO_Y, Doc
from ._gltf_read import read_animation

__all__ = [
    "GLTF_FORMAT",
    "GLTF_FORMAT_VERSION",
    "UNIT_METRES",
    "GLTF_UNITS",
    "HUMAN_HEIGHT",
    "gltf_scale",
    "GLTFFile",
    "gltf_bytes",
    "write_gltf",
    "read_gltf",
    "read_gltf_clip",
    "list_gltf_clips",
    "iter_gltf_clips",
]

#: Length units motionrep knows, in metres; a clip in one of these units is written scaled to metres.
UNIT_METRES: dict[str, float] = {"m": 1.0, "cm": 0.01, "mm": 0.001, "dm": 0.1, "km": 1000.0, "in": 0.0254,
                                 "ft": 0.3048}


#: The units ``--units`` takes, and the order :func:`gltf_scale` tries them in when guessing.
GLTF_UNITS: tuple[str, ...] = ("m", "cm", "in", "mm")

#: A human character's size in metres that the guess aims for: ``[low, high]``, and the size of the fallback.
HUMAN_HEIGHT: tuple[float, float, float] = (1.0, 2.5, 1.8)


def gltf_scale(motion: Motion, scale: float | None = None, units: str | None = None) -> tuple[float, str | None]:
    """Metres per file unit for writing ``motion`` as glTF, and a line saying what was assumed (None when
    nothing was: ``scale`` or ``units`` given, or units the file states).

    * ``scale`` given: that number; ``units`` given (one of :data:`GLTF_UNITS`): its size in metres;
    * else the skeleton's units when they are one of :data:`UNIT_METRES` (an NPZ, HDF5 or glTF file states them);
    * else (BVH does not state its units) the guess: the first of m, cm, in, mm that puts the character height
      (:func:`motionrep.model.kinematics.character_height`, the rest pose's largest extent) between 1 and 2.5 m; when
      none does (a CMU clip of about 24 units is 0.6 m in inches, 24 m in metres), the scale that makes it
      1.8 m tall.  A skeleton of height 0 gets 1.

    Raises:
        ValidationError: both given, an unknown unit, or a scale that is not a positive number.
    """
    from ..model.kinematics import character_height

    if scale is not None and units is not None:
        raise ValidationError("give a glTF scale or units, not both")
    if units is not None:
        if units not in GLTF_UNITS:
            raise ValidationError(f"units must be one of {', '.join(GLTF_UNITS)}, got {units!r}")
        return UNIT_METRES[units], None
    if scale is not None:
        return _check_write_options(motion, scale, "y")[0], None
    stated = (motion.skeleton.units or "").strip().lower()
    if stated in UNIT_METRES:
        return UNIT_METRES[stated], None
    height = character_height(motion.skeleton)
    if not height > 0:
        return 1.0, "the character has no size: written at 1 m per file unit"
    low, high, fallback = HUMAN_HEIGHT
    for unit in GLTF_UNITS:
        if low <= height * UNIT_METRES[unit] <= high:
            return UNIT_METRES[unit], Note(f"assumed units {unit} (the character is {height:.4g} units tall: "
                                           f"{height * UNIT_METRES[unit]:.3g} m); units= or scale= to choose",
                                           "units=", "scale=")
    s = fallback / height
    return s, Note(f"no unit puts the character ({height:.4g} units tall) at {low:g}-{high:g} m: scaled by "
                   f"{s:.4g} m per unit to {fallback:g} m; units= or scale= to choose", "units=", "scale=")


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
        from ..model.kinematics import global_positions
        from ..model.ops import detect_up_axis

        step = max(1, motion.num_frames // 500)  # a few hundred frames decide as well as all of them
        up = detect_up_axis(global_positions(motion.frames(slice(None, None, step))))
    return scale, up


def _build(motion: Motion, name: str, scale: float, up: str) -> tuple[Any, bytes]:
    """The pygltflib document and its binary buffer for ``motion``."""
    import pygltflib as g

    from .._version import __version__
    from ..model.rotations import quat_make_continuous

    sk = motion.skeleton
    J, E, F = sk.num_joints, sk.num_end_sites, motion.num_frames
    unique = Unique(sk.names)
    site_names: list[str] = []
    per_joint: dict[int, int] = {}
    for p in sk.end_site_parents.tolist():
        per_joint[p] = per_joint.get(p, 0) + 1
    seen: dict[int, int] = {}
    for p in sk.end_site_parents.tolist():
        seen[p] = seen.get(p, 0) + 1
        base = f"{sk.names[p]}_end" + (f"{seen[p]}" if per_joint[p] > 1 else "")
        site_names.append(unique(base))
    armature_name = unique("Armature")

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
    accessors.append(g.Accessor(bufferView=0, byteOffset=0, componentType=FLOAT, count=F, type="SCALAR",
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
        accessors.append(g.Accessor(bufferView=1, byteOffset=start - out_start, componentType=FLOAT, count=F,
                                    type="VEC4" if path == "rotation" else "VEC3"))
        samplers.append(g.AnimationSampler(input=0, output=len(accessors) - 1, interpolation="LINEAR"))
        channels.append(g.AnimationChannel(sampler=k, target=g.AnimationChannelTarget(node=node, path=path)))
    blob = b"".join(chunks)
    buffer_views = [g.BufferView(buffer=0, byteOffset=t_off, byteLength=t_len)]
    if offset > out_start:
        buffer_views.append(g.BufferView(buffer=0, byteOffset=out_start, byteLength=offset - out_start))

    # rest pose: identity rotations, every joint at its OFFSET; the skin binds it (inverse bind = -rest position,
    # in the armature's space, which is the skin's model space)
    from ..model.kinematics import rest_positions

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
    accessors.append(g.Accessor(bufferView=len(buffer_views) - 1, byteOffset=0, componentType=FLOAT,
                                count=J + E, type="MAT4"))

    nodes = [g.Node(name=armature_name, children=[1],
                    rotation=list(Z_TO_Y) if up == "z" else None,
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
        up: the clip's up axis, ``"y"``, ``"z"`` or ``"auto"`` (:func:`motionrep.model.ops.detect_up_axis`); a
            Z-up clip is turned to glTF's Y-up by the armature node.

    Raises:
        ValidationError: ``motion`` is not a Motion, or a bad ``scale`` or ``up``.
    """
    data = gltf_bytes(motion, binary=Path(path).suffix.lower() == BY_NAME["gltf"].binary,
                      clip=Path(path).stem if clip is None else clip, scale=scale, up=up)
    with atomic_path(path) as tmp:
        Path(tmp).write_bytes(data)


class GLTFFile(ClipFile):
    """A glTF file, parsed once: the names of its clips, each clip read when asked for.

    Each named animation is a clip; unnamed ones are ``animation0``, ``animation1``..., except that unnamed
    animations of different nodes are read together as one clip, ``animation`` (converters such as COLLADA2GLTF
    write one animation per joint).

    Raises:
        GLTFFormatError: naming the file, when it is missing, malformed or unsafe (see ``specs/formats/gltf.md``).
    """

    def __init__(self, path: str | os.PathLike[str]):
        self.path = path
        self._doc = Doc(path)
        self._clips = clips(self._doc)

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
                raise naming(self._doc.fail(f"the file holds {len(names)} animations; choose one with clip=NAME: "
                                            + ", ".join(names[:20]) + (" ..." if len(names) > 20 else "")),
                             "clip=NAME")
            index = 0
        elif clip in names:
            index = names.index(clip)
        else:
            raise self._doc.fail(f"no animation named {clip!r}; animations in this file: " + ", ".join(names[:20]))
        name, indices = self._clips[index]
        return name, read_animation(self._doc, indices, name)



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
