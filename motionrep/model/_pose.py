"""The pose model: :class:`Skeleton` and :class:`Motion`, thin validated containers of arrays.

Conventions (they hold everywhere in motionrep):

* Quaternions are ``(..., 4)`` arrays in **xyzw** order (scalar last, scipy's order).
* Arrays are ``(frames, joints, ...)`` and float64.
* Joint 0 is the root; every parent comes before its children (``parents[j] < j``), so forward kinematics is
  one pass over the joints.
* Lengths are in the file's units (BVH does not state them; ``Skeleton.units`` records them when known).
* Channel names are BVH's: ``Xposition``, ``Yposition``, ``Zposition``, ``Xrotation``, ``Yrotation``,
  ``Zrotation``.  A joint's rotation order is the sequence of its rotation channels, read as *intrinsic*
  rotations: ``Zrotation Xrotation Yrotation`` means ``R = Rz @ Rx @ Ry`` (scipy ``from_euler("ZXY", ...)``).
* A position channel replaces that axis of the joint's OFFSET for that frame; axes without a position channel
  keep the OFFSET value.  ``Motion.root_translation`` and ``Motion.joint_translations`` therefore hold the
  complete local translation of those joints.

Operations on these classes are free functions elsewhere (``motionrep.model.kinematics``, ``motionrep.io``, ...).
"""

from __future__ import annotations

import math
import unicodedata
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ValidationError

__all__ = ["Skeleton", "Motion", "CHANNEL_NAMES", "DEFAULT_ROOT_CHANNELS", "DEFAULT_JOINT_CHANNELS"]

#: The six BVH channel names motionrep knows, in canonical spelling.
CHANNEL_NAMES: tuple[str, ...] = ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation")

#: Channel layout used for the root when a skeleton is built without one (for example from arrays).
DEFAULT_ROOT_CHANNELS: tuple[str, ...] = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
#: Channel layout used for every other joint when a skeleton is built without one.
DEFAULT_JOINT_CHANNELS: tuple[str, ...] = ("Zrotation", "Xrotation", "Yrotation")

_UNIT_TOLERANCE = 1e-6


def _checked_motion_header(skeleton: Any, fps: Any) -> float:
    """``fps`` as a float after checking what every clip class needs: ``skeleton`` a :class:`Skeleton` and ``fps``
    a finite number > 0 (raises :class:`ValidationError` otherwise)."""
    if not isinstance(skeleton, Skeleton):
        raise ValidationError(f"skeleton must be a Skeleton, got {type(skeleton).__name__}")
    try:
        value = float(fps)
    except (TypeError, ValueError):
        raise ValidationError(f"fps must be a number, got {fps!r}") from None
    if not np.isfinite(value) or value <= 0:
        raise ValidationError(f"fps must be finite and > 0, got {fps!r}")
    if not math.isfinite(1.0 / value):  # 5e-324 fps: a frame time of inf, which no BVH file can hold
        raise ValidationError(f"fps {fps!r} gives an infinite frame time (1 / fps); fps must be at least "
                              f"{_MIN_FPS!r}")
    return value


#: The smallest fps whose frame time ``1 / fps`` is finite.
_MIN_FPS = float(np.nextafter(1.0 / np.finfo(np.float64).max, 1.0))


def name_problem(name: str) -> str | None:
    """What keeps ``name`` from being a joint name every format writes and reads back unchanged (BVH reads a
    name as the words after ``ROOT``/``JOINT``, joined by one space), or None: it must be non-empty, its words
    separated by single spaces (no tabs, newlines, ``\v``, U+2028 or other whitespace, none around it), with
    no braces and no control characters (NUL, ESC, ...), surrogates or line and paragraph separators."""
    if not name:
        return "names must be non-empty"
    if any(c in name for c in "{}"):
        return "names must be without braces"
    bad = next((c for c in name if unicodedata.category(c) in ("Cc", "Cs", "Zl", "Zp")), None)
    if bad is not None:
        return f"names must be without control characters (found U+{ord(bad):04X})"
    if " ".join(name.split()) != name:
        return "names must be words separated by single spaces, without tabs, newlines or surrounding spaces"
    return None


def _readonly(a: NDArray) -> NDArray:
    """A read-only contiguous array that no caller can still write to (copies unless already read-only)."""
    if not a.flags.writeable and a.flags.c_contiguous:
        return a
    if not (a.flags.owndata and a.flags.c_contiguous):  # a view: copy, so no alias stays writeable
        a = np.array(a, copy=True, order="C")
    a.flags.writeable = False
    return a


def _as_float_array(value: ArrayLike, name: str, shape: tuple[int | None, ...]) -> NDArray[np.float64]:
    if (isinstance(value, np.ndarray) and value.dtype == np.float64 and value.flags.c_contiguous
            and value.flags.owndata and not value.flags.writeable):
        a = value  # already an immutable float64 array (for example another Motion's): no copy needed
    else:
        try:
            a = np.array(value, dtype=np.float64, order="C")  # C order: _readonly then keeps it
        except (TypeError, ValueError) as exc:
            raise ValidationError(f"{name} must be numeric, got {type(value).__name__}: {exc}") from None
    if a.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, a.shape)):
        want = "(" + ", ".join("?" if s is None else str(s) for s in shape) + ")"
        raise ValidationError(f"{name} must have shape {want}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        bad = tuple(int(i) for i in np.argwhere(~np.isfinite(a))[0])
        raise ValidationError(f"{name} must be finite, found {a[bad]} at index {bad}")
    return a


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A joint hierarchy with its rest offsets, BVH channel layout and end sites.

    Args:
        names: joint names, ``J`` of them, unique; ``names[0]`` is the root.
        parents: ``(J,)`` int, parent index of each joint, ``-1`` for the root (only joint 0);
            ``parents[j] < j`` for every other joint.
        offsets: ``(J, 3)`` float, each joint's OFFSET from its parent (for the root: from the origin), in
            file units.
        channels: per joint, the BVH channel names in file order, e.g.
            ``("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")``.  ``None`` gives
            the documented default layout (:data:`DEFAULT_ROOT_CHANNELS` for the root,
            :data:`DEFAULT_JOINT_CHANNELS` for the others).
        end_site_parents: ``(E,)`` int, the joint each end site hangs from.
        end_site_offsets: ``(E, 3)`` float, each end site's OFFSET from its joint.
        units: length unit of the offsets and translations (``"cm"``, ``"m"``, ``"in"``...) when known.

    Raises:
        ValidationError: quoting what is wrong (shape, order of parents, duplicate names, unknown channels...).
    """

    names: tuple[str, ...]
    parents: NDArray[np.int64]
    offsets: NDArray[np.float64]
    channels: tuple[tuple[str, ...], ...] | None = None
    end_site_parents: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))
    end_site_offsets: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))
    units: str | None = None

    def __post_init__(self) -> None:
        names = tuple(self.names) if not isinstance(self.names, str) else None
        if names is None or not all(isinstance(n, str) for n in names):
            raise ValidationError("Skeleton names must be a sequence of strings")
        J = len(names)
        if J == 0:
            raise ValidationError("a Skeleton needs at least one joint")
        for n in names:
            problem = name_problem(n)
            if problem:
                raise ValidationError(f"invalid joint name {n[:80]!r}: {problem}")
        seen: dict[str, int] = {}
        for i, n in enumerate(names):
            if n in seen:
                raise ValidationError(f"duplicate joint name {n!r} (joints {seen[n]} and {i})")
            seen[n] = i
        try:
            parents = np.array(self.parents, dtype=np.int64)
        except (TypeError, ValueError):
            raise ValidationError("Skeleton parents must be integers") from None
        if parents.shape != (J,):
            raise ValidationError(f"parents must have shape ({J},) for {J} names, got {parents.shape}")
        if parents[0] != -1:
            raise ValidationError(f"joint 0 ({names[0]!r}) must be the root (parent -1), got parent {parents[0]}")
        idx = np.arange(J)
        bad = np.nonzero((parents[1:] < 0) | (parents[1:] >= idx[1:]))[0]
        if bad.size:
            j = int(bad[0]) + 1
            raise ValidationError(f"joint {j} ({names[j]!r}) has parent {parents[j]}: every joint but the root "
                                  "needs a parent that comes before it (0 <= parent < index)")
        offsets = _as_float_array(self.offsets, "offsets", (J, 3))

        if self.channels is None:
            channels = (DEFAULT_ROOT_CHANNELS,) + (DEFAULT_JOINT_CHANNELS,) * (J - 1)
        else:
            channels = tuple(tuple(c) for c in self.channels)
            if len(channels) != J:
                raise ValidationError(f"channels must list {J} joints, got {len(channels)}")
            for j, ch in enumerate(channels):
                for c in ch:
                    if c not in CHANNEL_NAMES:
                        raise ValidationError(f"joint {names[j]!r} has unknown channel {c!r}; known channels: "
                                              + ", ".join(CHANNEL_NAMES))
                if len(set(ch)) != len(ch):
                    raise ValidationError(f"joint {names[j]!r} lists a channel twice: {' '.join(ch)}")

        try:
            esp = np.array(self.end_site_parents, dtype=np.int64).reshape(-1)
        except (TypeError, ValueError):
            raise ValidationError(f"end_site_parents must be integers, got {self.end_site_parents!r}") from None
        E = esp.shape[0]
        eso = self.end_site_offsets
        if np.size(eso) == 0 and E == 0:
            eso = np.zeros((0, 3))
        elif np.ndim(eso) == 1 and np.size(eso) == 3 * E:  # a flat list of E * 3 values
            eso = np.reshape(eso, (E, 3))
        eso = _as_float_array(eso, "end_site_offsets", (E, 3))
        if E and (esp.min() < 0 or esp.max() >= J):
            raise ValidationError(f"end_site_parents must index joints 0..{J - 1}, got {esp.tolist()}")

        object.__setattr__(self, "names", names)
        object.__setattr__(self, "parents", _readonly(parents))
        object.__setattr__(self, "offsets", _readonly(offsets))
        object.__setattr__(self, "channels", channels)
        object.__setattr__(self, "end_site_parents", _readonly(esp))
        object.__setattr__(self, "end_site_offsets", _readonly(eso))
        if self.units is not None and not isinstance(self.units, str):
            raise ValidationError(f"units must be a string or None, got {self.units!r}")

    # ---- derived facts -------------------------------------------------------------------------------------
    @property
    def num_joints(self) -> int:
        """Number of joints ``J`` (end sites excluded)."""
        return len(self.names)

    @property
    def num_end_sites(self) -> int:
        """Number of end sites ``E``."""
        return int(self.end_site_parents.shape[0])

    @cached_property
    def rotation_orders(self) -> tuple[str, ...]:
        """Per joint, the axes of its rotation channels in file order (``"ZXY"``; ``""`` if none).

        The order is intrinsic: ``"ZXY"`` means ``R = Rz @ Rx @ Ry``.
        """
        return tuple("".join(c[0] for c in ch if c.endswith("rotation")) for ch in self.channels)

    @cached_property
    def position_axes(self) -> tuple[str, ...]:
        """Per joint, the axes of its position channels in file order (``"XYZ"``; ``""`` if none)."""
        return tuple("".join(c[0] for c in ch if c.endswith("position")) for ch in self.channels)

    @cached_property
    def translated_joints(self) -> NDArray[np.int64]:
        """``(P,)`` indices of the non-root joints that have position channels (see ``Motion.joint_translations``)."""
        return _readonly(np.array([j for j in range(1, self.num_joints) if self.position_axes[j]], dtype=np.int64))

    @cached_property
    def rotated_joints(self) -> NDArray[np.int64]:
        """``(R,)`` indices of the joints that have at least one rotation channel."""
        return _readonly(np.array([j for j in range(self.num_joints) if self.rotation_orders[j]], dtype=np.int64))

    @property
    def num_channels(self) -> int:
        """Number of BVH channel values per frame."""
        return sum(len(c) for c in self.channels)

    @property
    def num_rotation_channels(self) -> int:
        """Number of BVH rotation channel values per frame (the width of ``Motion.euler_angles``)."""
        return sum(len(o) for o in self.rotation_orders)

    @cached_property
    def children(self) -> tuple[tuple[int, ...], ...]:
        """Per joint, the indices of its child joints."""
        kids: list[list[int]] = [[] for _ in range(self.num_joints)]
        for j in range(1, self.num_joints):
            kids[int(self.parents[j])].append(j)
        return tuple(tuple(k) for k in kids)

    @cached_property
    def depths(self) -> NDArray[np.int64]:
        """``(J,)`` depth of each joint in the tree (root 0)."""
        d = np.zeros(self.num_joints, np.int64)
        for j in range(1, self.num_joints):
            d[j] = d[self.parents[j]] + 1
        return _readonly(d)

    def index(self, name: str) -> int:
        """Index of the joint called ``name``.

        Raises:
            ValidationError: if there is no such joint.
        """
        try:
            return self.names.index(name)
        except ValueError:
            raise ValidationError(f"no joint named {name!r} in this skeleton") from None

    def replace(self, **changes) -> "Skeleton":
        """A copy with some fields replaced (validated again)."""
        fields = dict(names=self.names, parents=self.parents, offsets=self.offsets, channels=self.channels,
                      end_site_parents=self.end_site_parents, end_site_offsets=self.end_site_offsets,
                      units=self.units)
        fields.update(changes)
        return Skeleton(**fields)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Skeleton):
            return NotImplemented
        return (self.names == other.names and self.channels == other.channels and self.units == other.units
                and np.array_equal(self.parents, other.parents) and np.array_equal(self.offsets, other.offsets)
                and np.array_equal(self.end_site_parents, other.end_site_parents)
                and np.array_equal(self.end_site_offsets, other.end_site_offsets))

    def same_structure(self, other: "Skeleton") -> bool:
        """True if ``other`` has the same joints, parents and end-site parents (offsets may differ)."""
        return (self.names == other.names and np.array_equal(self.parents, other.parents)
                and np.array_equal(self.end_site_parents, other.end_site_parents))

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return (f"Skeleton({self.num_joints} joints, {self.num_end_sites} end sites, {self.num_channels} channels, "
                f"root={self.names[0]!r}, units={self.units!r})")


@dataclass(frozen=True, eq=False)
class Motion:
    """A clip: a skeleton animated over frames.

    Args:
        skeleton: the :class:`Skeleton`.
        fps: frames per second (finite, > 0).
        root_translation: ``(F, 3)`` float, the root joint's position per frame (its OFFSET with the axes that have
            position channels replaced by their values; a root without position channels repeats its OFFSET).
        rotations: ``(F, J, 4)`` float, local (parent-relative) rotation of every joint as a unit quaternion in
            **xyzw** order; joint 0 holds the root orientation.
        joint_translations: ``(F, P, 3)`` float, local translation per frame of each joint in
            ``skeleton.translated_joints`` (non-root joints with position channels), replacing their OFFSET.
            May be omitted when ``P == 0``; ``None`` with ``P > 0`` repeats their OFFSETs.
        euler_branch: optional ``(F, J)`` bool, a hint for writers of Euler channels: True where the clip's
            source used the second of the two Euler solutions of a rotation (middle angle outside [-90, 90]
            degrees).  The BVH reader sets it so that BVH -> any format -> BVH gives back the very channel
            values; it never changes the pose.  ``None``: writers choose angles continuous over frames.
        euler_angles: optional ``(F, R)`` float, the rotation channel values of the clip's source in degrees
            (``R = skeleton.num_rotation_channels``; joints in index order, each joint's rotation channels in its
            channel order).  A hint for writers of Euler channels, like ``euler_branch`` but exact: the BVH reader
            sets it so that writing BVH gives back the file's very numbers, bit for bit, full turns beyond
            +-180 degrees included.  Writers use it only where it describes ``rotations`` (within 1e-9 per
            quaternion component); :meth:`replace` drops it when the rotations or the skeleton change.

    Raises:
        ValidationError: quoting the shapes received, non-finite values, or quaternions that are not unit length.
    """

    skeleton: Skeleton
    fps: float
    root_translation: NDArray[np.float64]
    rotations: NDArray[np.float64]
    joint_translations: NDArray[np.float64] | None = None
    euler_branch: NDArray[np.bool_] | None = None
    euler_angles: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        fps = _checked_motion_header(self.skeleton, self.fps)
        J = self.skeleton.num_joints
        rot = _as_float_array(self.rotations, "rotations", (None, J, 4))
        F = rot.shape[0]
        if F == 0:
            raise ValidationError("a Motion needs at least one frame, got rotations of shape "
                                  f"{rot.shape}")
        root = _as_float_array(self.root_translation, "root_translation", (F, 3))
        squared = np.einsum("fjc,fjc->fj", rot, rot)  # cheap screen; the exact test runs only if it fails
        if not (squared.min() >= (1.0 - _UNIT_TOLERANCE) ** 2 and squared.max() <= (1.0 + _UNIT_TOLERANCE) ** 2):
            norms = np.sqrt(squared)
            bad = np.argwhere(np.abs(norms - 1.0) > _UNIT_TOLERANCE)
            if bad.size:
                f, j = (int(i) for i in bad[0])
                raise ValidationError(f"rotations must be unit quaternions (xyzw); frame {f}, joint "
                                      f"{self.skeleton.names[j]!r} has norm {norms[f, j]:.9g}")
        P = self.skeleton.translated_joints.shape[0]
        if self.joint_translations is None:
            jt = np.broadcast_to(self.skeleton.offsets[self.skeleton.translated_joints], (F, P, 3)).copy()
        else:
            jt = _as_float_array(self.joint_translations, "joint_translations", (F, P, 3))
        object.__setattr__(self, "fps", fps)
        object.__setattr__(self, "rotations", _readonly(rot))
        object.__setattr__(self, "root_translation", _readonly(root))
        object.__setattr__(self, "joint_translations", _readonly(jt))
        if self.euler_branch is not None:
            eb = np.asarray(self.euler_branch)
            if eb.shape != (F, J) or eb.dtype.kind not in "bui":
                raise ValidationError(f"euler_branch must be a ({F}, {J}) bool array, got {eb.dtype} {eb.shape}")
            object.__setattr__(self, "euler_branch", _readonly(eb.astype(bool)))
        if self.euler_angles is not None:
            ea = _as_float_array(self.euler_angles, "euler_angles", (F, self.skeleton.num_rotation_channels))
            object.__setattr__(self, "euler_angles", _readonly(ea))

    @property
    def num_frames(self) -> int:
        """Number of frames ``F``."""
        return int(self.rotations.shape[0])

    @property
    def num_joints(self) -> int:
        """Number of joints ``J``."""
        return self.skeleton.num_joints

    @property
    def frame_time(self) -> float:
        """Seconds between frames (``1 / fps``)."""
        return 1.0 / self.fps

    @property
    def duration(self) -> float:
        """Length of the clip in seconds, ``num_frames / fps`` (each frame lasts one frame time; the one definition,
        :func:`motionrep.model.timefmt.duration`, ``specs/times.md``)."""
        return self.num_frames / self.fps

    def local_translations(self) -> NDArray[np.float64]:
        """``(F, J, 3)`` local translation of every joint: OFFSETs, with the root and position-channel joints
        replaced by their per-frame values."""
        t = np.broadcast_to(self.skeleton.offsets, (self.num_frames, self.num_joints, 3)).copy()
        t[:, 0] = self.root_translation
        if self.joint_translations.shape[1]:
            t[:, self.skeleton.translated_joints] = self.joint_translations
        return t

    def replace(self, **changes) -> "Motion":
        """A copy with some fields replaced (validated again)."""
        fields = dict(skeleton=self.skeleton, fps=self.fps, root_translation=self.root_translation,
                      rotations=self.rotations, joint_translations=self.joint_translations,
                      euler_branch=self.euler_branch, euler_angles=self.euler_angles)
        if ("rotations" in changes or "skeleton" in changes) and "euler_angles" not in changes:
            fields["euler_angles"] = None  # the source's angles describe the old rotations only
        fields.update(changes)
        return Motion(**fields)

    def frames(self, index: slice | Sequence[int] | NDArray) -> "Motion":
        """The frames selected by ``index`` (a slice or integer array), as a new Motion."""
        return Motion(self.skeleton, self.fps, self.root_translation[index], self.rotations[index],
                      self.joint_translations[index],
                      None if self.euler_branch is None else self.euler_branch[index],
                      None if self.euler_angles is None else self.euler_angles[index])

    def __repr__(self) -> str:
        return (f"Motion({self.num_frames} frames at {self.fps:g} fps, {self.num_joints} joints, "
                f"root={self.skeleton.names[0]!r})")
