"""Feature columns to poses in one compiled pass: the :class:`PosePlan` and the kernel that runs it.

Every shipped representation decodes by a plan: for each joint, what its local rotation is computed from (a
quaternion to normalise, a rotation vector, Euler angles, a 6D encoding, or a rotation in world axes whose
parent's is taken off), and which columns hold the root's and the other joints' translations.  One compiled
kernel, in C (``motionrep/_c/plan/plan.c``, the extension ``motionrep._cplan`` built on install; :func:`decode_planned`
and the runtime decoder ``motionrep.open`` run it), converts a block of poses joint by joint, each joint's
arithmetic vectorised over the block's poses, straight from the feature columns into the caller's ``(T, J, 4)``
rotations and ``(T, 3)`` / ``(T, P, 3)`` translations.

Features are read **feature-major**, ``X (D, >= T)`` float64 with feature ``d`` of pose ``i`` at ``X[d, i]``:
the layout in which codecs compute (a dense layer sums over its inputs for a block of times), so the kernel's
loads are contiguous and vectorise.  :func:`decode_planned` takes the usual ``(T, D)`` and transposes it once.

The arithmetic is float64 and IEEE throughout (no fused multiply-add, no fast-math: ``setup.py``), so a pose
decodes to the same bits alone or anywhere in a batch, on any CPU; float32 rotations are the float64 ones
rounded.  Conversions (xyzw, as everywhere):

* ``QUAT``: ``q / |q|``;
* ``AXIS_ANGLE``: ``[sin(theta / 2) v / theta, cos(theta / 2)]`` with ``theta = |v|`` (its series below 1e-3 rad),
  as scipy's ``Rotation.from_rotvec`` (not sign-canonicalised);
* ``EULER`` / ``EULER_DEGREES``: the product of up to three rotations about ``axes`` (intrinsic: the first
  factor leftmost), angles in radians or degrees (degrees reduced exactly modulo 720 first);
* ``ORTHO6D``: Gram-Schmidt of the two columns, their cross product third, then the matrix's quaternion as
  scipy's ``Rotation.from_matrix`` (w >= 0);
* ``WORLD_QUAT`` / ``WORLD_IDENTITY``: a rotation in world axes, ``r / |r|`` (or the parent's, for a joint that
  does not rotate), made local: ``conj(G_parent) r``, ``G`` the world rotations decoded so far (the
  dual-quaternion representation's real parts); a plan with one such joint has one for every joint.

Each conversion is the compiled core's (``motionrep/_c/mr_rotconv.h``, one value at a time, inlined into the
kernel's loops over poses), the one implementation that ``motionrep.model.rotations``' column conversions (reading
BVH, the plain conversion functions) run too.

Size: one concern, features to poses: the plan and its packing for the C kernel.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ValidationError

__all__ = ["PosePlan", "decode_planned", "QUAT", "AXIS_ANGLE", "EULER", "EULER_DEGREES", "ORTHO6D", "WORLD_QUAT",
           "WORLD_IDENTITY", "SUB_BLOCK"]

QUAT, AXIS_ANGLE, EULER, EULER_DEGREES, ORTHO6D, WORLD_QUAT, WORLD_IDENTITY = range(7)
#: Number of columns each kind reads (Euler: up to three, ``-1`` pads).
_WIDTH = {QUAT: 4, AXIS_ANGLE: 3, EULER: 3, EULER_DEGREES: 3, ORTHO6D: 6, WORLD_QUAT: 4, WORLD_IDENTITY: 0}
_WIDTH_OF = np.array([_WIDTH[kind] for kind in range(len(_WIDTH))], np.int64)
#: Poses converted together inside the kernel: each joint's inputs and results for them stay in the L1 cache.
SUB_BLOCK = 64
# the header of the packed plan (int64): counts, then offsets of the parts
_H_R, _H_J, _H_P, _H_M, _H_KINDS, _H_COLS, _H_AXES, _H_JOINTS, _H_PARENTS, _H_IDENT, _H_TCOLS, _H_WORLD = range(12)
_HEADER = 12


@dataclass(frozen=True, eq=False)
class PosePlan:
    """How ``(T, D)`` features become poses (see the module docstring).  Build it once per skeleton.

    Attributes:
        width: number of feature columns ``D``.
        num_joints: ``J``.
        kinds: ``(R,)`` conversion of each entry (``QUAT``, ``AXIS_ANGLE``...).
        columns: ``(R, 6)`` the feature columns each entry reads, ``-1`` after the last (an Euler entry of one or
            two axes ends early).
        axes: ``(R, 3)`` Euler entries: the axis of each factor (0 = X, 1 = Y, 2 = Z), ``-1`` after the last.
        joints: ``(R,)`` the joint each entry writes; joints without an entry decode to the identity.
        parents: ``(J,)`` the skeleton's parents (used by world entries).
        translation_columns: ``(1 + P, 3)`` columns of the root's and then each translated joint's x, y, z;
            ``-1`` takes the value from ``translation_values`` instead (an axis without a position channel);
            ``(0, 3)`` for a plan of rotations only (``motionrep.model.rotations``' column conversions).
        translation_values: ``(1 + P, 3)`` float64, those values.

    Raises:
        ValidationError: for an entry that does not fit the feature width, the joints or its kind.
    """

    width: int
    num_joints: int
    kinds: NDArray[np.int64]
    columns: NDArray[np.int64]
    axes: NDArray[np.int64]
    joints: NDArray[np.int64]
    parents: NDArray[np.int64]
    translation_columns: NDArray[np.int64]
    translation_values: NDArray[np.float64]

    def __post_init__(self) -> None:
        R, J = self.kinds.shape[0], self.num_joints
        for name, a, shape in (("columns", self.columns, (R, 6)), ("axes", self.axes, (R, 3)),
                               ("joints", self.joints, (R,)), ("parents", self.parents, (J,))):
            if a.shape != shape or a.dtype != np.int64:
                raise ValidationError(f"pose plan: {name} must be int64 of shape {shape}, got {a.dtype} {a.shape}")
        tc, tv = self.translation_columns, self.translation_values
        if tc.ndim != 2 or tc.shape[1] != 3 or tv.shape != tc.shape or tc.dtype != np.int64:
            raise ValidationError("pose plan: translation columns and values must be (1 + P, 3)")
        if np.any(tc < -1) or np.any(tc >= self.width):
            raise ValidationError("pose plan: a translation column is outside the features")
        if np.any(self.parents >= np.arange(J)) or (J and self.parents[0] != -1):
            raise ValidationError("pose plan: parents must come before their children, the root first")
        if len(set(self.joints.tolist())) != R or np.any(self.joints < 0) or np.any(self.joints >= J):
            raise ValidationError("pose plan: each entry must write a different joint")
        if not self._entries_fit():
            self._check_entries()
        world = (self.kinds == WORLD_QUAT) | (self.kinds == WORLD_IDENTITY)
        if world.any() and (not world.all() or not np.array_equal(self.joints, np.arange(J))):
            raise ValidationError("pose plan: world rotations need one entry per joint, in joint order")
        object.__setattr__(self, "_packed", self._pack())

    def _entries_fit(self) -> bool:
        """Whether every entry passes :meth:`_check_entries`, all entries at once (a plan is built for every
        decoder and codec call; the loop then only runs to name the first entry that does not fit)."""
        k, cols, axes = self.kinds, self.columns, self.axes
        if k.ndim != 1 or k.dtype.kind not in "iu" or not np.all((k >= 0) & (k < _WIDTH_OF.size)):
            return False
        euler = (k == EULER) | (k == EULER_DEGREES)
        count = np.where(euler, np.maximum(1, np.sum(cols >= 0, axis=1)), _WIDTH_OF[k])[:, None]
        fits = np.where(np.arange(cols.shape[1]) < count, (cols >= 0) & (cols < self.width), cols == -1)
        named = np.where(np.arange(axes.shape[1]) < count, (axes >= 0) & (axes <= 2), axes == -1)
        return bool(np.all(fits) and np.all(named | ~euler[:, None]))

    def _check_entries(self) -> None:
        """Each entry's kind, the columns it reads (within the width, ``-1`` after) and an Euler entry's axes."""
        for r in range(self.kinds.shape[0]):
            kind = int(self.kinds[r])
            if kind not in _WIDTH:
                raise ValidationError(f"pose plan: unknown conversion kind {kind}")
            n = _WIDTH[kind]
            cols, axes = self.columns[r], self.axes[r]
            used = cols[:n] if kind not in (EULER, EULER_DEGREES) else cols[:max(1, int(np.sum(cols >= 0)))]
            if (np.any(used < 0) or np.any(used >= self.width) or np.any(cols[used.size:] != -1)):
                raise ValidationError(f"pose plan: entry {r} ({kind=}) must read {n} columns of the {self.width}")
            if kind in (EULER, EULER_DEGREES) and (np.any(axes[:used.size] < 0) or np.any(axes[:used.size] > 2)
                                                   or np.any(axes[used.size:] != -1)):
                raise ValidationError(f"pose plan: Euler entry {r} needs an axis 0-2 per angle")

    @property
    def num_translated(self) -> int:
        """``P``: joints other than the root with translation columns."""
        return max(self.translation_columns.shape[0] - 1, 0)

    def with_fixed_axes(self, fixed: NDArray[np.bool_], values: NDArray[np.float64]) -> "PosePlan":
        """The plan with the translation axes where ``fixed`` ``(1 + P, 3)`` is True taken from ``values``
        instead of the features (the runtime decoder restores axes without a position channel this way)."""
        cols = np.where(fixed, -1, self.translation_columns)
        vals = np.where(fixed, values, self.translation_values).astype(np.float64)
        return replace(self, translation_columns=cols, translation_values=vals)

    def packed(self) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """``(plan_i, plan_f)``: the plan as the kernel reads it (one int64 and one float64 array)."""
        return self._packed  # type: ignore[attr-defined]

    def compiled(self, keep_unplanned: bool = False) -> Any:
        """The plan in the compiled kernel (``motionrep._cplan.Plan``, built on first use and kept): joints without
        an entry are set to the identity, or left as they are with ``keep_unplanned``."""
        key = "_compiled_keep" if keep_unplanned else "_compiled"
        found = self.__dict__.get(key)
        if found is None:
            from .._cplan import Plan

            plan_i, plan_f = self.packed()
            if keep_unplanned and plan_i[_H_M]:
                plan_i = plan_i.copy()
                plan_i[_H_M] = 0
            found = Plan(plan_i, plan_f)
            object.__setattr__(self, key, found)
        return found

    def _pack(self) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        R, J, P = self.kinds.shape[0], self.num_joints, self.translation_columns.shape[0]
        unplanned = np.ones(J, bool)
        unplanned[self.joints] = False
        identity = np.flatnonzero(unplanned)  # not np.setdiff1d: its np.unique imports numpy.ma (50 ms at start-up)
        parts = [self.kinds, self.columns.ravel(), self.axes.ravel(), self.joints, self.parents, identity,
                 self.translation_columns.ravel()]
        header = np.zeros(_HEADER, np.int64)
        header[[_H_R, _H_J, _H_P, _H_M]] = R, J, P, identity.size
        header[_H_WORLD] = int(((self.kinds == WORLD_QUAT) | (self.kinds == WORLD_IDENTITY)).any())
        offset = _HEADER
        for slot, part in zip(range(_H_KINDS, _H_TCOLS + 1), parts):
            header[slot] = offset
            offset += part.size
        plan_i = np.concatenate([header] + [np.asarray(p, np.int64) for p in parts])
        return plan_i, np.ascontiguousarray(self.translation_values.ravel(), dtype=np.float64)


def decode_planned(features: ArrayLike, plan: PosePlan, rotations: NDArray, root_translation: NDArray | None,
                   joint_translations: NDArray | None, *, check_finite: bool = True,
                   keep_unplanned: bool = False) -> None:
    """Decode ``(T, D)`` features by ``plan`` into ``rotations`` ``(T, J, 4)`` (float32 or float64),
    ``root_translation`` ``(T, 3)`` and ``joint_translations`` ``(T, P, 3)`` (float64; None for a plan without
    translations), in place.

    Args:
        check_finite: refuse features whose planned columns hold NaN or infinity (else they decode to NaN).
        keep_unplanned: leave the joints without an entry as they are (else they are set to the identity).

    Raises:
        ValidationError: for features of the wrong shape (or not finite), a quaternion of zero length or a
            degenerate 6D encoding.
    """
    f = np.asarray(features)
    if f.ndim != 2 or f.shape[1] != plan.width:
        raise ValidationError(f"features must have shape (T, {plan.width}), got {f.shape}")
    X = np.ascontiguousarray(f.T, dtype=np.float64)
    decode_feature_major(X, f.shape[0], plan, rotations, root_translation, joint_translations, check_finite,
                         keep_unplanned)


_NO_ROOT, _NO_MOVED = np.zeros((0, 3)), np.zeros((0, 0, 3))


def decode_feature_major(X: NDArray[np.float64], count: int, plan: "PosePlan", rotations: NDArray,
                         root_translation: NDArray | None, joint_translations: NDArray | None,
                         check_finite: bool = True, keep_unplanned: bool = False) -> None:
    """:func:`decode_planned` of the first ``count`` poses of feature-major ``X`` ``(D, >= count)`` float64
    (C-contiguous).

    Raises:
        ValidationError: as :func:`decode_planned`.
    """
    J, N = plan.num_joints, plan.translation_columns.shape[0]
    if (type(X) is not np.ndarray or X.dtype != np.float64 or X.ndim != 2 or not X.flags.c_contiguous
            or X.shape[1] < count or X.shape[0] < plan.width):
        raise ValidationError(f"features must be a C-contiguous float64 array of shape ({plan.width}, >= {count})")
    if (type(rotations) is not np.ndarray or rotations.shape != (count, J, 4)
            or rotations.dtype not in (np.float32, np.float64) or not rotations.flags.c_contiguous):
        raise ValidationError(f"rotations must be C-contiguous float32 or float64 of shape ({count}, {J}, 4)")
    if N == 0:
        root_translation, joint_translations = _NO_ROOT, _NO_MOVED
    elif (root_translation is None or joint_translations is None or root_translation.shape != (count, 3)
          or joint_translations.shape != (count, N - 1, 3)):
        raise ValidationError(f"translations must have shapes ({count}, 3) and ({count}, {N - 1}, 3)")
    _raise_for(plan.compiled(keep_unplanned).run(X, count, check_finite, rotations, root_translation,
                                                  joint_translations))


def _raise_for(status: int) -> None:
    if status == 1:
        raise ValidationError("features contain NaN or infinity")
    if status == 2:
        raise ValidationError("cannot normalise a quaternion of zero or non-finite length")
    if status == 3:
        raise ValidationError("6D rotation encoding has a zero or degenerate column")
