"""glTF reading, part 3: the skeleton and the motion.  Which nodes are the skeleton (a skin's joints, or the
animated nodes), what is above it (folded into the root), node rest transforms and scales, motionrep's own
description of its files, and the :class:`~motionrep.Motion` put together (``specs/formats/gltf.md``)."""

from __future__ import annotations

import unicodedata
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..model._pose import DEFAULT_JOINT_CHANNELS, DEFAULT_ROOT_CHANNELS, Motion, Skeleton
from ..errors import MotionrepError, ValidationError
from ._gltf_anim import Track, Unique, frame_times, sample
from ._gltf_anim import tracks as read_tracks
from ._gltf_doc import GLTF_FORMAT, GLTF_FORMAT_VERSION, Z_TO_Y, Doc, get, is_int, number, short

__all__ = ["read_animation"]

_MAX_DEPTH = 10_000
# Scales that differ by at most this fraction (between axes, or over the frames) are exporters' rounding noise
# (Blender writes 1.0000156): they are read as one uniform, constant scale, their mean.
_SCALE_TOLERANCE = 1e-3


@dataclass
class _Rest:
    """A node's own transform: translation, xyzw rotation, uniform scale."""

    t: NDArray[np.float64]
    r: NDArray[np.float64]
    s: float


def _node_rest(doc: Doc, i: int) -> _Rest:
    node = doc.nodes[i]
    what = f"node {i} ({_raw_name(node, i)!r})"
    m = doc.floats(node, "matrix", 16, what)
    if m is not None:
        mat = m.reshape(4, 4).T  # column-major
        t = mat[:3, 3].copy()
        lin = mat[:3, :3]
        with np.errstate(all="ignore"):  # a 1e308 scale overflows: refused below, without a warning
            col = np.linalg.norm(lin, axis=0)
            det = np.linalg.det(lin)
        if (not np.all(np.isfinite(col)) or not np.isfinite(det) or det <= 0 or not col.min() > 0
                or np.ptp(col) > _SCALE_TOLERANCE * col.max()):
            raise doc.fail(f"{what}: its matrix is not a rotation with a uniform scale; motionrep's pose model "
                           "cannot hold it")
        from ..model.rotations import matrix_to_quat

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


def _uniform(doc: Doc, s: NDArray | None, what: str) -> float:
    if s is None:
        return 1.0
    with np.errstate(all="ignore"):
        uneven = np.ptp(s) > _SCALE_TOLERANCE * float(np.max(s))
    if np.any(s <= 0) or uneven:
        raise doc.fail(f"{what}: scale {s.tolist()} is not a positive uniform scale; motionrep's pose model "
                       "cannot hold it")
    return float(np.mean(s))


def _raw_name(node: Any, i: int) -> str:
    name = get(node, "name")
    return name if isinstance(name, str) and name.strip() else f"node{i}"


def _parents(doc: Doc) -> list[int]:
    """Parent of every node (-1 for none); refuses a node with two parents and cycles."""
    parents = [-1] * len(doc.nodes)
    for i, node in enumerate(doc.nodes):
        doc.item(doc.nodes, i, "node")
        kids = get(node, "children", [])
        if not isinstance(kids, list):
            raise doc.fail(f"node {i}: 'children' must be a list")
        for c in kids:
            if not is_int(c) or not 0 <= c < len(doc.nodes) or c == i:
                raise doc.fail(f"node {i} lists child {short(c)}, which is not another node")
            if parents[c] != -1:
                raise doc.fail(f"node {c} has two parents (nodes {parents[c]} and {i})")
            parents[c] = i
    depth = _depths(parents)
    if depth is None:
        raise doc.fail("the nodes' children form a cycle")
    deepest = max(depth, default=0)
    if deepest > _MAX_DEPTH:
        raise doc.fail(f"node {depth.index(deepest)} is nested {deepest} levels deep, deeper than {_MAX_DEPTH}")
    return parents


def _depths(parents: list[int]) -> list[int] | None:
    """Depth of every node (0 for a root), or None when walking up from some node never reaches a root (a
    cycle).  Linear: each node is walked over once, the path to a known depth kept on a list, not a stack of
    calls."""
    depth = [-1] * len(parents)
    for i in range(len(parents)):
        path = []
        p = i
        while p != -1 and depth[p] == -1:
            depth[p] = -2  # on the current path
            path.append(p)
            p = parents[p]
        if p != -1 and depth[p] == -2:
            return None
        d = -1 if p == -1 else depth[p]
        for q in reversed(path):
            d += 1
            depth[q] = d
    return depth


def _joints(doc: Doc, parents: list[int], tracks: dict[tuple[int, str], Track], where: str) -> tuple[int, list[int]]:
    """The skeleton's root node and its nodes in depth-first order (parents first)."""
    animated = {node for node, _ in tracks}
    members: set[int] | None = None
    best = 0
    for s, skin in enumerate(doc.skins):
        doc.item(doc.skins, s, "skin")
        joints = doc.list(skin, "joints")
        for j in joints:
            if not is_int(j) or not 0 <= j < len(doc.nodes):
                raise doc.fail(f"skin {s} lists joint {short(j)}, which is not a node")
        hit = len(animated.intersection(joints))
        if joints and (members is None or hit > best):
            members, best = set(joints), hit
    if members is None or best == 0:
        # no skin drives this animation: its animated nodes and the plain transform nodes under them
        members = set(animated)
        stack = list(animated)
        while stack:
            for c in get(doc.nodes[stack.pop()], "children", []):
                if c not in members and all(get(doc.nodes[c], k) is None for k in ("mesh", "camera", "skin")):
                    members.add(c)
                    stack.append(c)
    if not members:
        raise doc.fail(f"{where} animates no node")

    # the root is the deepest node above (or at) every member; the skeleton is the nodes on the paths from the
    # members up to it.  Linear in the nodes: each node's count of members at or below it, deepest nodes first.
    depth = _depths(parents)
    if depth is None:  # _parents refused cycles already
        raise doc.fail("the nodes' children form a cycle")
    below = [0] * len(parents)
    for i in members:
        below[i] = 1
    for i in sorted(range(len(parents)), key=depth.__getitem__, reverse=True):
        if below[i] and parents[i] != -1:
            below[parents[i]] += below[i]
    tops = [i for i in range(len(parents)) if below[i] == len(members)]
    if not tops:
        raise doc.fail(f"{where}: the skeleton's joints are not under one root node")
    root = max(tops, key=depth.__getitem__)
    keep = {i for i in range(len(parents)) if below[i] and depth[i] >= depth[root]}
    order: list[int] = []
    stack = [root]
    while stack:
        i = stack.pop()
        order.append(i)
        kids = [c for c in get(doc.nodes[i], "children", []) if c in keep]
        stack.extend(reversed(kids))
    return root, order


def _names(doc: Doc, nodes: list[int]) -> list[str]:
    """Joint names a BVH file can hold: braces and control characters (NUL, ESC...) become ``_``, runs of white
    space (tabs, line and paragraph separators) one space; then unique."""
    unique = Unique()
    out = []
    for i in nodes:
        raw = _raw_name(doc.nodes[i], i)
        raw = "".join("_" if c in "{}" or (unicodedata.category(c) in ("Cc", "Cf") and not c.isspace()) else c
                      for c in raw)
        clean = " ".join(raw.split()) or f"node{i}"
        out.append(unique(clean))
    return out


def _motionrep_extras(doc: Doc, root: int, parents: list[int]) -> dict | None:
    """motionrep's own description on the armature node above ``root``, if it is there and still true."""
    arm = parents[root]
    if arm == -1:
        return None
    extras = get(doc.nodes[arm], "extras")
    info = extras.get("motionrep") if isinstance(extras, dict) else None
    if not isinstance(info, dict) or info.get("format") != GLTF_FORMAT:
        return None
    version = info.get("version")
    if not is_int(version) or version > GLTF_FORMAT_VERSION:
        raise doc.fail(f"motionrep glTF layout version {short(version)} is newer than this motionrep reads "
                       f"({GLTF_FORMAT_VERSION}); upgrade motionrep")
    scale, up = number(info.get("scale")), info.get("up")
    rest = _node_rest(doc, arm)
    want_r = np.array(Z_TO_Y if up == "z" else (0.0, 0.0, 0.0, 1.0))
    if (scale is None or not np.allclose(rest.s, scale, rtol=1e-12, atol=0)
            or not np.allclose(rest.t, 0.0) or not np.allclose(rest.r, want_r, atol=1e-12)):
        return None  # the armature was moved since motionrep wrote it: read it as any other file
    return info


def read_animation(doc: Doc, indices: list[int], name: str) -> Motion:
    """The clip made of the animations ``indices``.  Numbers out of float64's range (scales of 1e200 on nested
    joints, a singular matrix) give no numpy warning: what they produce is checked, and refused, instead."""
    where = f"animation {short(name)}"
    with np.errstate(all="ignore"):
        return _read_animation(doc, indices, name, where)


def _finite(doc: Doc, where: str, **arrays: Any) -> None:
    for what, a in arrays.items():
        if not np.all(np.isfinite(a)):
            raise doc.fail(f"{where}: its node transforms give {what} that are not finite numbers (scales or "
                           "translations beyond float64's range)")


def _read_animation(doc: Doc, indices: list[int], name: str, where: str) -> Motion:
    parents = _parents(doc)
    tracks = read_tracks(doc, indices)
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
    extras = get(doc.animations[indices[0]], "extras")
    hint = None
    if ours is not None and isinstance(extras, dict) and isinstance(extras.get("motionrep"), dict):
        hint = extras["motionrep"].get("fps")
    fps, times = frame_times(doc, used, hint, where, joints=len(order) + len(ancestors))
    F = times.size
    snap = 0.01 / fps

    sampled: dict[int, NDArray[np.float64]] = {}  # channels sharing a sampler are sampled once

    def channel(node: int, path: str, rest: NDArray, what: str) -> NDArray[np.float64]:
        track = tracks.get((node, path))
        if track is None:
            return np.broadcast_to(rest, (F, rest.size))
        if id(track) not in sampled:
            try:
                sampled[id(track)] = sample(track, times, path == "rotation", snap)
            except MotionrepError:
                raise doc.fail(f"{where}: {what} has a zero rotation quaternion") from None
        return sampled[id(track)]

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
    from ..model.rotations import quat_apply, quat_multiply

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
    _finite(doc, where, scales=cum, offsets=offsets, rotations=rotations, translations=translations)
    if ours is None:
        _rest_to_identity(parent_idx, rest_r, [r.r for r in rests], offsets, rotations, translations)
        _finite(doc, where, offsets=offsets, rotations=rotations, translations=translations)

    sites: list[int] = []
    channels: list[tuple[str, ...]] | None = None
    units = "m"
    if ours is not None:
        units = ours.get("units") if isinstance(ours.get("units"), str) else None
        flagged = ours.get("end_sites")
        flagged = {i for i in flagged if is_int(i)} if isinstance(flagged, list) else set()
        sites = [k for k, i in enumerate(order) if k and i in flagged and not get(doc.nodes[i], "children")]
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
    from ..model.rotations import quat_apply, quat_conjugate, quat_multiply

    J = len(rest)
    G = np.empty((J, 4))
    local = np.array(rest).reshape(J, 4)
    G[0] = quat_multiply(top, local[0])
    # level by level (parents come before their children): one vector operation per level, not per joint
    depth = np.zeros(J, dtype=np.int64)
    for k in range(1, J):
        depth[k] = depth[parents[k]] + 1
    by_level = np.argsort(depth, kind="stable")
    ends = np.searchsorted(depth[by_level], np.arange(1, int(depth.max(initial=0)) + 2))
    for a, b in zip(ends[:-1], ends[1:]):
        level = by_level[a:b]
        G[level] = quat_multiply(G[parents[level]], local[level])
    inverse = quat_conjugate(G)
    rotations[:, 0] = quat_multiply(rotations[:, 0], inverse[0])
    if J > 1:
        above = G[parents[1:]]
        offsets[1:] = quat_apply(above, offsets[1:])
        translations[:, 1:] = quat_apply(above, translations[:, 1:])
        rotations[:, 1:] = quat_multiply(quat_multiply(above, rotations[:, 1:]), inverse[1:])


def _assemble(doc: Doc, where: str, names: list[str], parents: NDArray, offsets: NDArray, rotations: NDArray,
              translations: NDArray, sites: list[int], channels: list[tuple[str, ...]] | None, units: str | None,
              fps: float) -> Motion:
    """The Motion: end sites split off, translated joints found, the channel layout chosen."""
    from ..model.kinematics import character_height
    from ..model.rotations import euler_to_quat, quat_to_euler

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
