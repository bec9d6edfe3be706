"""FBX reading (binary and ASCII FBX 7.x) through the ``ufbx`` bindings (``pip install 'motionrep[fbx]'``).

The skeleton is the file's tree of bones (``LimbNode`` models); what is above its top bone (a Blender armature
object, scene nodes) is folded into the root.  Each anim stack is a clip; its curves are evaluated by ufbx at the
scene's frame rate over the stack's time span, each node's local transform with its rotation order, pre- and
post-rotation and pivots applied as FBX defines them.  Lengths are the file's (``Skeleton.units`` from its unit
scale), axes the file's.  motionrep does not write FBX (``specs/formats/fbx.md``).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..model._pose import Motion, Skeleton
from ..errors import FBXFormatError, ValidationError, naming
from ._clipfile import ClipFile
from ._files import read_regular

__all__ = ["read_fbx", "read_fbx_clip", "list_fbx_clips", "iter_fbx_clips", "FBXFile"]

#: ufbx's RotationOrder values (XYZ, XZY, YZX, YXZ, ZXY, ZYX; 6 is "spheric", read as XYZ) as motionrep's
#: intrinsic channel order: FBX's eEulerXYZ turns about X first, in the parent's frame, so R = Rz Ry Rx.
_ORDERS = ("ZYX", "YZX", "XZY", "ZXY", "YXZ", "XYZ", "ZYX")
_UNITS = {0.01: "cm", 1.0: "m", 0.001: "mm", 0.0254: "in"}
# A joint's scale may differ from one constant uniform value by this fraction (between axes and over frames):
# exporters' float32 rounding (Blender writes 0.99999994, and 1.00002 on some frames), as for glTF.  The scale
# taken is the median of the values, so that sporadic noise leaves an exact 1 exact.  Larger differences are
# refused.
_SCALE_TOLERANCE = 1e-3
# A joint gets position channels when its translation leaves its OFFSET by more than this fraction of the
# skeleton's size on some frame; below it, the OFFSET stands for it.
TRANSLATION_TOLERANCE = 1e-6
_MAX_POSE_VALUES = 1 << 28  # frames x joints x 4 float64 values, about 2 GiB
_MAX_FILE_BYTES = 2 << 30


def _ufbx(path: Any) -> Any:
    try:
        import ufbx
    except ImportError:
        raise FBXFormatError("reading FBX needs the ufbx package: pip install 'motionrep[fbx]'", path) from None
    return ufbx


class FBXFile(ClipFile):
    """An FBX file loaded once; its anim stacks are its clips (``names``), each read by :meth:`read_clip`.

    The ufbx scene and every object taken from it are kept referenced here while in use: the bindings' objects
    point into the scene's memory.

    Raises:
        FBXFormatError: naming the file, if it is missing, not FBX, truncated or damaged, or holds no skeleton.
    """

    def __init__(self, path: str | os.PathLike[str]):
        self.path = Path(path)
        ufbx = self._ufbx = _ufbx(path)
        try:
            size = self.path.stat().st_size
        except OSError as exc:
            raise FBXFormatError(f"cannot read file: {exc.strerror or exc}", path) from None
        if size > _MAX_FILE_BYTES:
            raise FBXFormatError(f"{size} bytes is more than the {_MAX_FILE_BYTES} motionrep reads", path)
        data = read_regular(path, FBXFormatError)  # regular files only: never blocks on a FIFO
        try:
            self.scene = ufbx.load_memory(data, file_format=ufbx.FileFormat.FBX, ignore_geometry=True,
                                          ignore_embedded=True, load_external_files=False)
        except ufbx.UfbxError as exc:
            raise FBXFormatError(f"not a readable FBX file ({' '.join(str(exc).split()) or type(exc).__name__})",
                                 path) from None
        # every object taken from the scene is kept referenced while the scene lives: ufbx 0.0.5's bindings crash
        # when some of them (lists of curves, keyframes...) are released before the scene
        self._keep: list[Any] = []
        self._nodes_list = self.scene.nodes
        self.nodes = [self._nodes_list[i] for i in range(len(self._nodes_list))]
        self._stacks_list = self.scene.anim_stacks
        self.stacks = [self._stacks_list[i] for i in range(len(self._stacks_list))]
        self.names = [s.name or f"take{i}" for i, s in enumerate(self.stacks)] or [self.path.stem]
        self._skeleton_nodes()

    def fail(self, message: str) -> FBXFormatError:
        return FBXFormatError(message, self.path)

    # the skeleton: which nodes, in which order
    def _skeleton_nodes(self) -> None:
        nodes = self.nodes
        index = {n.typed_id: i for i, n in enumerate(nodes)}
        parent = [-1 if (n.parent is None or n.is_root) else index.get(n.parent.typed_id, -1) for n in nodes]
        parent = [p if p >= 0 and not nodes[p].is_root else -1 for p in parent]
        is_bone = [n.bone is not None for n in nodes]
        if not any(is_bone):
            raise self.fail("holds no skeleton (no bone / LimbNode models)")
        tops = [i for i in range(len(nodes)) if is_bone[i] and (parent[i] < 0 or not is_bone[parent[i]])]
        holders = {parent[i] for i in tops}
        if len(tops) == 1:
            root = tops[0]
        elif len(holders) == 1 and -1 not in holders:
            root = holders.pop()  # several top bones under one node (an armature): that node is the root joint
        else:
            names = ", ".join(repr(nodes[i].name) for i in tops[:6])
            raise self.fail(f"holds {len(tops)} separate skeletons (top bones {names}); motionrep reads one")
        children: dict[int, list[int]] = {}
        for i, p in enumerate(parent):
            children.setdefault(p, []).append(i)
        has_bone: dict[int, bool] = {}

        def bony(i: int) -> bool:  # a bone, or a node with bones below it (kept so the chain stays whole)
            stack = [i]
            while stack:
                k = stack.pop()
                if is_bone[k]:
                    return True
                stack.extend(children.get(k, ()))
            return False

        order: list[int] = []
        parents: list[int] = []
        stack = [(root, -1)]
        while stack:
            i, p = stack.pop()
            k = len(order)
            order.append(i)
            parents.append(p)
            kids = [c for c in children.get(i, ()) if has_bone.setdefault(c, bony(c))]
            stack.extend((c, k) for c in reversed(kids))
        ancestors = []
        a = parent[root]
        while a >= 0:
            ancestors.append(a)
            a = parent[a]
        self.order, self.parents, self.ancestors = order, np.array(parents, np.int64), ancestors[::-1]
        names: list[str] = []
        seen_names: set[str] = set()
        for k, i in enumerate(order):
            name = nodes[i].name or f"joint{k}"
            base, n = name, 2
            while name in seen_names:  # FBX allows repeated names; motionrep's do not repeat
                name, n = f"{base}_{n}", n + 1
            seen_names.add(name)
            names.append(name)
        self.joint_names = tuple(names)

    def _times(self, stack: Any) -> NDArray[np.float64]:
        fps = float(self.scene.settings.frames_per_second)
        if not (np.isfinite(fps) and fps > 0):
            raise self.fail(f"frame rate {fps!r} is not a positive number")
        begin, end = float(stack.time_begin), float(stack.time_end)
        if not (np.isfinite(begin) and np.isfinite(end) and end >= begin):
            raise self.fail(f"anim stack {stack.name!r} spans {begin!r} to {end!r} s")
        frames = int(round((end - begin) * fps)) + 1
        if frames * (len(self.order) + len(self.ancestors)) * 4 > _MAX_POSE_VALUES:
            raise self.fail(f"anim stack {stack.name!r} has {frames} frames, more than motionrep reads")
        times = begin + np.arange(frames) / fps
        keys = self._key_times(stack.anim)
        # keys one per frame (a baked export): sampled at the very key times, not at times a rounding of the
        # frame rate away from them (Blender writes 23.976 fps as a float32, 23.97599983)
        if keys is not None and keys.size == frames and np.abs(keys - times).max() < 0.25 / fps:
            times = keys
        return times

    def _key_times(self, anim: Any) -> NDArray[np.float64] | None:
        """Key times of the skeleton's curve with the most keys (None without curves)."""
        keep = self._keep
        wanted = {self.nodes[i].element_id for i in self.order + self.ancestors}
        best: Any = None
        layers = anim.layers
        keep.append(layers)
        for li in range(len(layers)):
            layer = layers[li]
            props = layer.anim_props
            keep.extend((layer, props))
            for pi in range(len(props)):
                prop = props[pi]
                element = prop.element
                keep.extend((prop, element))
                if element is None or element.element_id not in wanted:
                    continue
                value = prop.anim_value
                curves = value.curves
                keep.extend((value, curves))
                for curve in curves:
                    if curve is None:
                        continue
                    keyframes = curve.keyframes
                    keep.extend((curve, keyframes))
                    if best is None or len(keyframes) > len(best):
                        best = keyframes
        if best is None or len(best) == 0:
            return None
        return np.array([best[k].time for k in range(len(best))], dtype=np.float64)

    def _sample(self, anim: Any, node: Any, times: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """``(F, 3)`` translations, ``(F, 4)`` xyzw rotations and ``(F, 3)`` scales of one node's local
        transform."""
        ufbx = self._ufbx
        F = times.size
        out = np.empty((F, 10))
        for f in range(F):
            tr = ufbx.evaluate_transform(anim, node, float(times[f]))
            t, r, s = tr.translation, tr.rotation, tr.scale
            out[f] = (t.x, t.y, t.z, r.x, r.y, r.z, r.w, s.x, s.y, s.z)
        return out[:, :3], out[:, 3:7], out[:, 7:]

    def _rest(self, node: Any) -> tuple[NDArray, NDArray, NDArray]:
        tr = node.local_transform
        t, r, s = tr.translation, tr.rotation, tr.scale
        return np.array([t.x, t.y, t.z]), np.array([r.x, r.y, r.z, r.w]), np.array([s.x, s.y, s.z])

    def _uniform(self, scales: NDArray, what: str) -> float:
        s = float(np.median(scales))
        if not (s > 0 and np.all(np.abs(scales - s) <= _SCALE_TOLERANCE * s)):
            raise self.fail(f"{what} has an animated or non-uniform scale (from {float(scales.min()):.9g} to "
                            f"{float(scales.max()):.9g}); motionrep's pose model holds rotations and translations only")
        return s

    def read_clip(self, name: str | None = None) -> tuple[str, Motion]:
        """``(name, motion)`` of one anim stack (``name`` may be omitted when the file has at most one).

        Raises:
            FBXFormatError: naming the file, for an unknown clip, an omitted one among several, or a skeleton that
                motionrep's pose model cannot hold (a non-uniform or animated scale).
        """
        if not self.stacks:
            if name is not None and name != self.names[0]:
                raise self.fail(f"has no anim stack {name!r} (it has no animation)")
            return self.names[0], self._motion(None, np.zeros(1), 30.0)
        if name is None:
            if len(self.stacks) > 1:
                raise naming(self.fail(f"holds {len(self.stacks)} anim stacks; choose one with clip=NAME: "
                                       + ", ".join(self.names)), "clip=NAME")
            k = 0
        elif name in self.names:
            k = self.names.index(name)
        else:
            raise self.fail(f"has no anim stack {name!r}; it has " + ", ".join(self.names))
        stack = self.stacks[k]
        times = self._times(stack)
        return self.names[k], self._motion(stack, times, float(self.scene.settings.frames_per_second))

    def _motion(self, stack: Any, times: NDArray, fps: float) -> Motion:
        from ..model.rotations import quat_apply, quat_multiply
        from ._gltf_read import _rest_to_identity

        anim = stack.anim if stack is not None else None
        F, J = times.size, len(self.order)
        nodes = self.nodes

        def sample(i: int):
            if anim is None:
                t, r, s = self._rest(nodes[i])
                return t[None], r[None], s[None]
            return self._sample(anim, nodes[i], times)

        top_r = np.tile([0.0, 0.0, 0.0, 1.0], (F, 1))
        top_t = np.zeros((F, 3))
        top_s = 1.0
        top_m = np.broadcast_to(np.eye(4), (F, 4, 4))  # the same with scales, as FBX composes them
        rest_r, rest_t = np.array([0.0, 0.0, 0.0, 1.0]), np.zeros(3)
        for a in self.ancestors:
            what = f"node {nodes[a].name!r}"
            t, r, s = sample(a)
            rt, rr, rs = self._rest(nodes[a])
            top_t = top_t + top_s * quat_apply(top_r, t)
            top_r = quat_multiply(top_r, r)
            top_m = top_m @ _affine(t, r, s)
            rest_t = rest_t + top_s * quat_apply(rest_r, rt)
            rest_r = quat_multiply(rest_r, rr)
            top_s *= self._uniform(np.concatenate([s.ravel(), rs]), what)
        rests = [self._rest(nodes[i]) for i in self.order]
        rotations = np.empty((F, J, 4))
        translations = np.empty((F, J, 3))
        world = np.empty((F, J, 4, 4))
        cum = np.ones(J)
        for k, i in enumerate(self.order):
            t, r, s = sample(i)
            what = f"joint {self.joint_names[k]!r}"
            rotations[:, k] = r
            translations[:, k] = t
            world[:, k] = (top_m if k == 0 else world[:, self.parents[k]]) @ _affine(t, r, s)
            own = self._uniform(np.concatenate([s.ravel(), rests[k][2]]), what)
            cum[k] = (top_s if k == 0 else cum[self.parents[k]]) * own
        above = np.array([top_s if k == 0 else cum[self.parents[k]] for k in range(J)])
        offsets = np.array([r[0] for r in rests]) * above[:, None]
        translations *= above[None, :, None]
        rotations[:, 0] = quat_multiply(top_r, rotations[:, 0])
        translations[:, 0] = top_t + quat_apply(top_r, translations[:, 0])
        offsets[0] = rest_t + quat_apply(rest_r, offsets[0])
        norms = np.linalg.norm(rotations, axis=-1, keepdims=True)
        if not (np.all(np.isfinite(rotations)) and np.all(np.isfinite(translations)) and np.all(np.isfinite(world))
                and np.all(norms > 0)):
            raise self.fail("its animation evaluates to non-finite transforms")
        rotations /= norms
        _rest_to_identity(self.parents, rest_r, [r[1] for r in rests], offsets, rotations, translations)
        _exact_translations(self.parents, world[:, :, :3, 3], rotations, translations)
        return self._assemble(offsets, rotations, translations, fps)

    def _assemble(self, offsets: NDArray, rotations: NDArray, translations: NDArray, fps: float) -> Motion:
        from ..model.kinematics import character_height

        J = len(self.order)
        scale = max(float(np.abs(offsets).max()), float(np.abs(translations[:, 0]).max()), 1e-12)
        # a joint is translated when its translation leaves its OFFSET by more than float32 rounding of the
        # character's size (exporters work in float32: Blender's bones move by 1e-7 of it)
        moved = [k for k in range(1, J)
                 if np.abs(translations[:, k] - offsets[k]).max() > TRANSLATION_TOLERANCE * scale]
        # the others keep one translation: their mean over the frames (the exporters' float32 noise averages out;
        # the rest transform may sit at the edge of it)
        fixed = np.setdiff1d(np.arange(1, J), moved)
        offsets[fixed] = translations[:, fixed].mean(axis=0)
        channels = []
        for k, i in enumerate(self.order):
            order = _ORDERS[int(self.nodes[i].rotation_order) % 7]
            rot = tuple(f"{a}rotation" for a in order)
            channels.append(("Xposition", "Yposition", "Zposition") + rot if k == 0 or k in moved else rot)
        unit = float(self.scene.settings.unit_meters)
        units = next((u for m, u in _UNITS.items() if abs(unit - m) <= 1e-9 * m), None)
        try:
            skeleton = Skeleton(names=self.joint_names, parents=self.parents, offsets=offsets,
                                channels=tuple(channels), units=units)
            motion = Motion(skeleton, fps, translations[:, 0], rotations,
                            translations[:, skeleton.translated_joints] if len(moved) else None)
        except ValidationError as exc:
            raise self.fail(str(exc)) from None
        if character_height(skeleton) <= 0 and J > 1:
            raise self.fail("its skeleton's rest pose is a single point")
        return motion


def _affine(t: NDArray, r: NDArray, s: NDArray) -> NDArray[np.float64]:
    """``(F, 4, 4)`` local matrices ``T R S`` of a node from its ``(F, 3)`` translations, ``(F, 4)`` xyzw rotations
    and ``(F, 3)`` scales."""
    from ..model.kinematics import quat_to_matrix_fast

    m = np.zeros((t.shape[0], 4, 4))
    m[:, :3, :3] = quat_to_matrix_fast(r / np.linalg.norm(r, axis=-1, keepdims=True)) * s[:, None, :]
    m[:, :3, 3] = t
    m[:, 3, 3] = 1.0
    return m


def _exact_translations(parents: NDArray, positions: NDArray, rotations: NDArray, translations: NDArray) -> None:
    """Local translations (in place) that put every joint at ``positions`` ``(F, J, 3)``, the FBX world positions
    with the scales composed, under the rigid rotations ``rotations``.

    With scales of exactly 1 they are the translations already there (to rounding).  Exporters leave float32
    noise in scales (Blender: 1.00002 on a hip) and compensate it in the children's transforms, so dropping the
    scale alone would move the children by that noise; this keeps every joint where the file puts it.
    """
    from ..model.rotations import quat_apply, quat_conjugate, quat_multiply

    J = parents.size
    G = np.empty_like(rotations)
    G[:, 0] = rotations[:, 0]
    for k in range(1, J):
        G[:, k] = quat_multiply(G[:, parents[k]], rotations[:, k])
    translations[:, 0] = positions[:, 0]
    if J > 1:
        above = parents[1:]
        translations[:, 1:] = quat_apply(quat_conjugate(G[:, above]), positions[:, 1:] - positions[:, above])


def list_fbx_clips(path: str | os.PathLike[str]) -> list[str]:
    """Names of the anim stacks of an FBX file (the file's stem when it has none)."""
    return list(FBXFile(path).names)


def read_fbx_clip(path: str | os.PathLike[str], clip: str | None = None) -> tuple[str, Motion]:
    """``(name, motion)`` of one anim stack of an FBX file (see :class:`FBXFile`)."""
    return FBXFile(path).read_clip(clip)


def iter_fbx_clips(path: str | os.PathLike[str]) -> Iterator[tuple[str, Motion]]:
    """Yield ``(name, motion)`` for every anim stack of an FBX file, one at a time."""
    f = FBXFile(path)
    for name in f.names:
        yield f.read_clip(name)


def read_fbx(path: str | os.PathLike[str], clip: str | None = None) -> Motion:
    """Read one clip (an anim stack) of an FBX file as a :class:`~motionrep.Motion`.

    Args:
        path: a binary or ASCII FBX file.
        clip: the anim stack's name; may be omitted when the file has at most one (a file without animation
            gives its rest pose, one frame).

    Raises:
        FBXFormatError: naming the file, if ufbx is not installed, the file is missing, malformed or truncated,
            holds no skeleton or several, the clip is not found, or a joint has a scale other than one uniform
            constant.
    """
    return read_fbx_clip(path, clip)[1]
