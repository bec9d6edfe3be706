"""Augmentation of poses for the dataset (``specs/dataset.md``, "Augmentation") and foot contacts.

Poses are plain arrays: root translation ``(F, 3)``, local rotations ``(F, J, 4)`` xyzw, joint translations
``(F, P, 3)`` of ``skeleton.translated_joints``.

- **Rotation about the up axis** (through the origin): the root rotation is pre-multiplied by the rotation, the
  root translation rotated; every other joint is local to its parent and unchanged.
- **Mirroring** across the plane through the origin normal to the skeleton's lateral axis (the axis along which
  paired left and right joints lie apart in the rest pose): a position ``p`` becomes ``M p`` with ``M`` the
  reflection, a rotation ``R`` becomes ``M R M``, i.e. the quaternion ``(v, w)`` becomes ``(-M v, w)``, and each
  joint takes the mirrored rotation (and translation) of its partner.  The skeleton is kept, so this is exact
  for a left/right-symmetric rest pose (the usual case) and close to it otherwise.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from ..model._pose import Skeleton
from ..errors import ValidationError
from ..model.kinematics import rest_positions

__all__ = ["mirror_pairs", "lateral_axis", "mirror_poses", "rotate_poses", "foot_contacts", "contact_joints",
           "UP_AXES"]

UP_AXES = {"x": 0, "y": 1, "z": 2}
#: A contact joint's floor is this percentile of its height over the clip.
FLOOR_PERCENTILE = 5.0

# (left, right) spellings tried on each joint name, first match wins: whole words, then prefixes and suffixes.
_WORDS = (("Left", "Right"), ("left", "right"), ("LEFT", "RIGHT"))
_PREFIX = re.compile(r"^(?P<pre>(?:.*[:_.\s])?)(?P<s>[LlRr])(?P<rest>.+)$")
_SUFFIX = re.compile(r"^(?P<rest>.*[_.\-\s])(?P<s>[LlRr])$")
_SWAP = {"L": "R", "R": "L", "l": "r", "r": "l"}


def _partner_names(name: str) -> list[str]:
    out = []
    for left, right in _WORDS:
        if left in name:
            out.append(name.replace(left, right))
        if right in name:
            out.append(name.replace(right, left))
    m = _PREFIX.match(name)
    if m:
        out.append(m.group("pre") + _SWAP[m.group("s")] + m.group("rest"))
    m = _SUFFIX.match(name)
    if m:
        out.append(m.group("rest") + _SWAP[m.group("s")])
    return out


def mirror_pairs(skeleton: Skeleton, mapping: Mapping[str, str] | None = None) -> NDArray[np.int64]:
    """``(J,)`` the index of each joint's left/right partner (itself for a joint on the midline).

    Partners are found from the names: ``Left``/``Right`` (any case as a whole: ``LeftUpLeg``, ``mixamorig:LeftArm``),
    a leading ``L``/``l``/``R``/``r`` (``lShldr``, ``LHipJoint``, ``l_hip``, ``lfemur``),
    or a trailing ``_L``/``.R``...; a partner must exist and name this joint back.  ``mapping`` (names to names,
    one direction is enough) replaces what the names say for the joints it lists.

    Raises:
        ValidationError: for a mapping naming an unknown joint.
    """
    names = skeleton.names
    index = {n: i for i, n in enumerate(names)}
    pairs = np.arange(len(names), dtype=np.int64)
    for i, n in enumerate(names):
        for cand in _partner_names(n):
            j = index.get(cand)
            if j is not None and j != i and n in _partner_names(cand):
                pairs[i] = j
                break
    for a, b in (mapping or {}).items():
        for x in (a, b):
            if x not in index:
                raise ValidationError(f"mirror map names joint {x!r}, which the skeleton does not have")
        pairs[index[a]], pairs[index[b]] = index[b], index[a]
    return pairs


def lateral_axis(skeleton: Skeleton, pairs: NDArray[np.int64], up: int) -> int:
    """The axis (0, 1, 2; never ``up``) along which paired joints lie farthest apart in the rest pose."""
    rest = rest_positions(skeleton)[:skeleton.num_joints]
    spread = np.abs(rest - rest[pairs]).sum(axis=0)
    spread[up] = -1.0
    return int(np.argmax(spread))


def mirror_poses(skeleton: Skeleton, pairs: NDArray[np.int64], axis: int, root: NDArray, rotations: NDArray,
                 joint_translations: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """The mirrored poses (new arrays): see the module docstring."""
    sign = np.ones(3)
    sign[axis] = -1.0
    rot = rotations[:, pairs].copy()
    rot[..., :3] *= -sign  # (v, w) -> (-M v, w)
    root = root * sign
    jt = joint_translations * sign
    translated = skeleton.translated_joints
    if translated.size:
        slot = {int(j): k for k, j in enumerate(translated.tolist())}
        order = [slot.get(int(pairs[j]), k) for k, j in enumerate(translated.tolist())]
        jt = jt[:, order]
    return root, rot, jt


def rotate_poses(angle: float, up: int, root: NDArray, rotations: NDArray) -> tuple[NDArray, NDArray]:
    """Root translation and rotations turned by ``angle`` radians about axis ``up`` (right-handed)."""
    c, s = np.cos(angle), np.sin(angle)
    a, b = [(1, 2), (2, 0), (0, 1)][up]
    new_root = root.copy()
    new_root[:, a] = c * root[:, a] - s * root[:, b]
    new_root[:, b] = s * root[:, a] + c * root[:, b]
    q = np.zeros(4)
    q[up] = np.sin(angle / 2)
    q[3] = np.cos(angle / 2)
    r0 = rotations[:, 0]
    x, y, z, w = q
    X, Y, Z, W = r0[:, 0], r0[:, 1], r0[:, 2], r0[:, 3]
    rot = rotations.copy()
    rot[:, 0] = np.stack([w * X + x * W + y * Z - z * Y, w * Y - x * Z + y * W + z * X,
                          w * Z + x * Y - y * X + z * W, w * W - x * X - y * Y - z * Z], axis=-1)
    return new_root, rot


def contact_joints(skeleton: Skeleton, names: list[str] | None = None) -> NDArray[np.int64]:
    """Indices of the joints foot contacts are computed for: ``names`` if given, else every joint whose name
    contains ``foot`` or ``toe`` (any case), else those containing ``ankle``.

    Raises:
        ValidationError: for an unknown name, or when no joint matches.
    """
    if names is not None:
        missing = [n for n in names if n not in skeleton.names]
        if missing:
            raise ValidationError(f"contact joints {missing} are not in the skeleton")
        return np.array([skeleton.names.index(n) for n in names], dtype=np.int64)
    low = [n.lower() for n in skeleton.names]
    found = [i for i, n in enumerate(low) if "foot" in n or "toe" in n] or [i for i, n in enumerate(low)
                                                                             if "ankle" in n]
    if not found:
        raise ValidationError("no joint named like a foot, toe or ankle; give contact_joints=[names]")
    return np.array(found, dtype=np.int64)


def foot_contacts(positions: NDArray, joints: NDArray[np.int64], up: int, fps: float, height: float,
                  *, height_threshold: float, speed_threshold: float) -> NDArray[np.float32]:
    """``(F, C)`` 1.0 where a contact joint touches the ground, else 0.0.

    A joint is in contact in a frame when it is within ``height_threshold * height`` above its floor -- its own
    5th-percentile height over the clip (robust to a stray frame below the floor) -- and its speed (central
    differences of the world positions) is below ``speed_threshold * height`` per second; ``height`` is the
    character's height (:func:`motionrep.character_height`).
    """
    p = positions[:, joints]  # (F, C, 3)
    h = p[..., up]
    low = np.percentile(h, FLOOR_PERCENTILE, axis=0, keepdims=True)
    if p.shape[0] > 1:
        speed = np.linalg.norm(np.gradient(p, axis=0), axis=-1) * fps
    else:
        speed = np.zeros(h.shape)
    return ((h - low <= height_threshold * height) & (speed <= speed_threshold * height)).astype(np.float32)
