"""Feature columns to poses in one compiled pass: the :class:`PosePlan` and the kernel that runs it.

Every shipped representation decodes by a plan: for each joint, what its local rotation is computed from (a
quaternion to normalise, a rotation vector, Euler angles, a 6D encoding, or a rotation in world axes whose
parent's is taken off), and which columns hold the root's and the other joints' translations.  One compiled
kernel (:func:`decode_planned` and the runtime decoder ``motionrep.open``) converts a block of poses joint by
joint, each joint's arithmetic vectorised over the block's poses, straight from the feature columns into the
caller's ``(T, J, 4)`` rotations and ``(T, 3)`` / ``(T, P, 3)`` translations.  ``motionrep.model.rotations``'
``*_columns_*`` conversions (reading BVH, the plain conversion functions) run the same kernel, so every
conversion to quaternions is this one piece of code.

Features are read **feature-major**, ``X (D, >= T)`` float64 with feature ``d`` of pose ``i`` at ``X[d, i]``:
the layout in which codecs compute (a dense layer sums over its inputs for a block of times), so the kernel's
loads are contiguous and vectorise.  :func:`decode_planned` takes the usual ``(T, D)`` and transposes it once.

The arithmetic is float64 and IEEE throughout (``motionrep.jit``), so a pose decodes to the same bits alone or
anywhere in a batch; float32 rotations are the float64 ones rounded.  Conversions (xyzw, as everywhere):

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

The column conversions of ``motionrep.model.rotations`` (reading BVH, the plain conversion functions) are the same
arithmetic in C (``motionrep/_c/mr_rotconv.h``), bit for bit (``benchmarks/ccore_equivalence.py``).

Size: one concern, features to poses; the kernel is one function by design (one compiled pass for every kind),
and its inline helpers are one conversion each.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ValidationError
from ..jit import jit, jit_inline, sincos

__all__ = ["PosePlan", "decode_planned", "QUAT", "AXIS_ANGLE", "EULER", "EULER_DEGREES", "ORTHO6D", "WORLD_QUAT",
           "WORLD_IDENTITY", "SUB_BLOCK"]

QUAT, AXIS_ANGLE, EULER, EULER_DEGREES, ORTHO6D, WORLD_QUAT, WORLD_IDENTITY = range(7)
#: Number of columns each kind reads (Euler: up to three, ``-1`` pads).
_WIDTH = {QUAT: 4, AXIS_ANGLE: 3, EULER: 3, EULER_DEGREES: 3, ORTHO6D: 6, WORLD_QUAT: 4, WORLD_IDENTITY: 0}
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
        for r in range(R):
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
        world = (self.kinds == WORLD_QUAT) | (self.kinds == WORLD_IDENTITY)
        if world.any() and (not world.all() or not np.array_equal(self.joints, np.arange(J))):
            raise ValidationError("pose plan: world rotations need one entry per joint, in joint order")
        object.__setattr__(self, "_packed", self._pack())

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
    plan_i, plan_f = plan.packed()
    if keep_unplanned and plan_i[_H_M]:
        plan_i = plan_i.copy()
        plan_i[_H_M] = 0
    decode_feature_major(X, f.shape[0], (plan_i, plan_f), rotations, root_translation, joint_translations,
                         check_finite)


_NO_ROOT, _NO_MOVED = np.zeros((0, 3)), np.zeros((0, 0, 3))


def decode_feature_major(X: NDArray[np.float64], count: int, packed: tuple[NDArray, NDArray], rotations: NDArray,
                         root_translation: NDArray | None, joint_translations: NDArray | None,
                         check_finite: bool = True) -> None:
    """:func:`decode_planned` of the first ``count`` poses of feature-major ``X`` ``(D, >= count)`` float64
    (C-contiguous), with the plan's :meth:`PosePlan.packed` arrays.

    Raises:
        ValidationError: as :func:`decode_planned`.
    """
    plan_i, plan_f = packed
    J, N = int(plan_i[_H_J]), int(plan_i[_H_P])
    if (type(X) is not np.ndarray or X.dtype != np.float64 or X.ndim != 2 or not X.flags.c_contiguous
            or X.shape[1] < count):
        raise ValidationError(f"features must be a C-contiguous float64 array of shape (D, >= {count})")
    if (type(rotations) is not np.ndarray or rotations.shape != (count, J, 4)
            or rotations.dtype not in (np.float32, np.float64)):
        raise ValidationError(f"rotations must be float32 or float64 of shape ({count}, {J}, 4)")
    if N == 0:
        root_translation, joint_translations = _NO_ROOT, _NO_MOVED
    elif (root_translation is None or joint_translations is None or root_translation.shape != (count, 3)
          or joint_translations.shape != (count, N - 1, 3)):
        raise ValidationError(f"translations must have shapes ({count}, 3) and ({count}, {N - 1}, 3)")
    _raise_for(_poses_kernel(X, count, plan_i, plan_f, check_finite, rotations, root_translation,
                             joint_translations))


def _raise_for(status: int) -> None:
    if status == 1:
        raise ValidationError("features contain NaN or infinity")
    if status == 2:
        raise ValidationError("cannot normalise a quaternion of zero or non-finite length")
    if status == 3:
        raise ValidationError("6D rotation encoding has a zero or degenerate column")


# The conversions below store their result in ``Q[:, i]`` rather than returning a tuple: helpers that return
# tuples and contain a conditional keep the loop around them from vectorising (measured: 4x slower).
@jit_inline
def _axis_angle(x, y, z, QX, QY, QZ, QW, i):
    """``Q[i]`` = the quaternion of rotation vector ``(x, y, z)``."""
    theta2 = (x * x + y * y) + z * z
    theta = np.sqrt(theta2)
    s, c = sincos(0.5 * theta)
    # sin(theta / 2) / theta, by its series below 1e-3 (no 0 / 0), as scipy does
    k = s / theta if theta > 1e-3 else 0.5 - theta2 / 48.0 + theta2 * theta2 / 3840.0
    QX[i] = k * x
    QY[i] = k * y
    QZ[i] = k * z
    QW[i] = c


@jit_inline
def _normalized(x, y, z, w, QX, QY, QZ, QW, i):
    """``Q[i] = q / |q|``; False if ``|q|`` is zero or not finite."""
    n = np.sqrt(((x * x + y * y) + z * z) + w * w)
    QX[i] = x / n
    QY[i] = y / n
    QZ[i] = z / n
    QW[i] = w / n
    return (n != 0.0) & (n < np.inf)


@jit_inline
def _ortho6d(a1x, a1y, a1z, a2x, a2y, a2z, QX, QY, QZ, QW, i):
    """``Q[i]`` = the quaternion (w >= 0) of the 6D encoding ``[a1, a2]``; False if it is degenerate."""
    n1 = np.sqrt((a1x * a1x + a1y * a1y) + a1z * a1z)
    d = n1 if n1 > 0.0 else 1.0
    b1x, b1y, b1z = a1x / d, a1y / d, a1z / d
    dot = (b1x * a2x + b1y * a2y) + b1z * a2z
    u2x, u2y, u2z = a2x - dot * b1x, a2y - dot * b1y, a2z - dot * b1z
    n2 = np.sqrt((u2x * u2x + u2y * u2y) + u2z * u2z)
    b2x, b2y, b2z = u2x / n2, u2y / n2, u2z / n2
    b3x, b3y, b3z = b1y * b2z - b1z * b2y, b1z * b2x - b1x * b2z, b1x * b2y - b1y * b2x
    # the columns b1, b2, b3 form the matrix m[row, col]; its quaternion as scipy's from_matrix: the largest of
    # the trace and the diagonal picks the formula (selects, not branches, so the loop vectorises)
    m00, m10, m20 = b1x, b1y, b1z
    m01, m11, m21 = b2x, b2y, b2z
    m02, m12, m22 = b3x, b3y, b3z
    trace = (m00 + m11) + m22
    use_t = (trace >= m00) & (trace >= m11) & (trace >= m22)
    use_0 = ~use_t & (m00 >= m11) & (m00 >= m22)
    use_1 = ~use_t & ~use_0 & (m11 >= m22)
    s21, d21 = m21 + m12, m21 - m12
    s02, d02 = m02 + m20, m02 - m20
    s10, d10 = m10 + m01, m10 - m01
    e0, e1, e2 = 1.0 - trace + 2.0 * m00, 1.0 - trace + 2.0 * m11, 1.0 - trace + 2.0 * m22
    et = 1.0 + trace
    x1 = s10 if use_1 else s02  # one select per line: nested ones keep the loop scalar
    x0 = e0 if use_0 else x1
    x = d21 if use_t else x0
    y1 = e1 if use_1 else s21
    y0 = s10 if use_0 else y1
    y = d02 if use_t else y0
    z1 = s21 if use_1 else e2
    z0 = s02 if use_0 else z1
    z = d10 if use_t else z0
    w1 = d02 if use_1 else d10
    w0 = d21 if use_0 else w1
    w = et if use_t else w0
    # w >= 0; the rule for w == 0 is applied by the caller (:func:`_ortho6d_sign`), a second pass: with it here
    # the loop does not vectorise
    n = np.sqrt(((x * x + y * y) + z * z) + w * w)
    n = -n if w < 0.0 else n
    QX[i] = x / n
    QY[i] = y / n
    QZ[i] = z / n
    QW[i] = w / n
    return (n1 >= 1e-12) & (n2 >= 1e-12) & (n2 < np.inf)


@jit_inline
def _ortho6d_sign(QX, QY, QZ, QW, i):
    """Where ``w`` is zero, the sign that makes the first non-zero component positive (scipy's canonical
    quaternion); ``q / -n`` is ``-(q / n)`` exactly, so this is the sign :func:`_ortho6d` would have chosen."""
    if QW[i] == 0.0:
        x, y, z = QX[i], QY[i], QZ[i]
        if x < 0.0 or (x == 0.0 and (y < 0.0 or (y == 0.0 and z < 0.0))):
            QX[i], QY[i], QZ[i], QW[i] = -x, -y, -z, -QW[i]


@jit_inline
def _product(ax, ay, az, aw, bx, by, bz, bw):
    """The Hamilton product ``a b`` of two xyzw quaternions, as its four components (every product of the plan).

    Callers read their operands into locals and store the four results after the call: storing the call's
    result straight into ``G`` made world-rotation plans 3-4x slower (numba could no longer vectorise the loop).
    """
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


@jit_inline
def _times(QX, QY, QZ, QW, i, bx, by, bz, bw):
    """``Q[:, i] = Q[:, i] b``."""
    QX[i], QY[i], QZ[i], QW[i] = _product(QX[i], QY[i], QZ[i], QW[i], bx, by, bz, bw)


@jit_inline
def _conj_times(G, p, QX, QY, QZ, QW, i):
    """``Q[:, i] = conj(G[p, :, i]) Q[:, i]``."""
    ax, ay, az, aw = -G[p, 0, i], -G[p, 1, i], -G[p, 2, i], G[p, 3, i]
    x, y, z, w = _product(ax, ay, az, aw, QX[i], QY[i], QZ[i], QW[i])
    QX[i], QY[i], QZ[i], QW[i] = x, y, z, w


@jit_inline
def _world(G, j, QX, QY, QZ, QW, i):
    """``G[j, :, i] = Q[:, i]``: a ``WORLD_QUAT`` joint's world rotation is its own ``r / |r|``, kept before it is
    made local.  (Not ``G_parent local``: that product is ``|G_parent|^2 r``, so each level doubled the norm error
    of the one above, to 1e-9 on a 42-joint skeleton and overflow on a 60-joint chain.)"""
    G[j, 0, i], G[j, 1, i], G[j, 2, i], G[j, 3, i] = QX[i], QY[i], QZ[i], QW[i]


@jit_inline
def _inherit(G, j, p, i):
    """``G[j, :, i] = G[p, :, i]`` (the identity for the root, ``p < 0``): a ``WORLD_IDENTITY`` joint turns with
    its parent."""
    if p >= 0:
        G[j, 0, i], G[j, 1, i], G[j, 2, i], G[j, 3, i] = G[p, 0, i], G[p, 1, i], G[p, 2, i], G[p, 3, i]
    else:
        G[j, 0, i], G[j, 1, i], G[j, 2, i], G[j, 3, i] = 0.0, 0.0, 0.0, 1.0


@jit
def _poses_kernel(X, count, plan_i, plan_f, check_finite, out, root, moved):
    """Run the packed plan over the first ``count`` columns of ``X`` (see :func:`decode_feature_major`).
    Returns 0, or 1 (features not finite), 2 (a quaternion of zero length), 3 (a degenerate 6D encoding)."""
    R, J, N, M = plan_i[_H_R], plan_i[_H_J], plan_i[_H_P], plan_i[_H_M]
    o_kinds, o_cols, o_axes = plan_i[_H_KINDS], plan_i[_H_COLS], plan_i[_H_AXES]
    o_joints, o_parents, o_ident, o_tcols = plan_i[_H_JOINTS], plan_i[_H_PARENTS], plan_i[_H_IDENT], plan_i[_H_TCOLS]
    world = plan_i[_H_WORLD] != 0
    # one joint's quaternions for the sub-block's poses (four arrays: a 2-D one keeps the loops scalar)
    QX, QY, QZ, QW = np.empty(SUB_BLOCK), np.empty(SUB_BLOCK), np.empty(SUB_BLOCK), np.empty(SUB_BLOCK)
    G = np.empty((J if world else 0, 4, SUB_BLOCK))  # world rotations decoded so far (world plans)
    bad = 0
    # every feature column the plan reads must be finite
    for r in range(R if check_finite else 0):
        for k in range(6):
            c = plan_i[o_cols + 6 * r + k]
            if c >= 0:
                for i in range(count):
                    bad += 0 if abs(X[c, i]) < np.inf else 1
    for k in range(3 * N if check_finite else 0):
        c = plan_i[o_tcols + k]
        if c >= 0:
            for i in range(count):
                bad += 0 if abs(X[c, i]) < np.inf else 1
    if bad:
        return 1
    zero = 0
    degenerate = 0
    for a in range(0, count, SUB_BLOCK):
        n = min(SUB_BLOCK, count - a)
        for r in range(R):
            kind = plan_i[o_kinds + r]
            j = plan_i[o_joints + r]
            c = o_cols + 6 * r
            c0, c1, c2, c3, c4, c5 = plan_i[c], plan_i[c + 1], plan_i[c + 2], plan_i[c + 3], plan_i[c + 4], plan_i[c + 5]
            if kind == 1:  # AXIS_ANGLE
                for i in range(n):
                    _axis_angle(X[c0, a + i], X[c1, a + i], X[c2, a + i], QX, QY, QZ, QW, i)
            elif kind == 0:  # QUAT
                for i in range(n):
                    ok = _normalized(X[c0, a + i], X[c1, a + i], X[c2, a + i], X[c3, a + i], QX, QY, QZ, QW, i)
                    zero += 0 if ok else 1
            elif kind == 2 or kind == 3:  # EULER, EULER_DEGREES
                for i in range(n):
                    QX[i], QY[i], QZ[i], QW[i] = 0.0, 0.0, 0.0, 1.0
                for k in range(3):
                    col, axis = plan_i[c + k], plan_i[o_axes + 3 * r + k]
                    if col < 0:
                        break
                    ex = 1.0 if axis == 0 else 0.0
                    ey = 1.0 if axis == 1 else 0.0
                    ez = 1.0 if axis == 2 else 0.0
                    if kind == 3:
                        for i in range(n):
                            v = X[col, a + i]
                            # exact reduction to about [-360, 360] (Sterbenz), then the half angle in radians
                            s, cs = sincos((v - 720.0 * np.floor(v * (1.0 / 720.0) + 0.5)) * (np.pi / 360.0))
                            _times(QX, QY, QZ, QW, i, s * ex, s * ey, s * ez, cs)
                    else:
                        for i in range(n):
                            s, cs = sincos(0.5 * X[col, a + i])
                            _times(QX, QY, QZ, QW, i, s * ex, s * ey, s * ez, cs)
            elif kind == 4:  # ORTHO6D
                for i in range(n):
                    ok = _ortho6d(X[c0, a + i], X[c1, a + i], X[c2, a + i], X[c3, a + i], X[c4, a + i],
                                  X[c5, a + i], QX, QY, QZ, QW, i)
                    degenerate += 0 if ok else 1
                for i in range(n):
                    _ortho6d_sign(QX, QY, QZ, QW, i)
            else:  # WORLD_QUAT, WORLD_IDENTITY: G_j = r / |r|, or G_parent; local = conj(G_parent) r
                p = plan_i[o_parents + j]
                if kind == 5:
                    for i in range(n):
                        ok = _normalized(X[c0, a + i], X[c1, a + i], X[c2, a + i], X[c3, a + i], QX, QY, QZ, QW, i)
                        zero += 0 if ok else 1
                    for i in range(n):
                        _world(G, j, QX, QY, QZ, QW, i)
                    if p >= 0:
                        for i in range(n):
                            _conj_times(G, p, QX, QY, QZ, QW, i)
                else:
                    for i in range(n):
                        QX[i], QY[i], QZ[i], QW[i] = 0.0, 0.0, 0.0, 1.0
                        _inherit(G, j, p, i)
            for i in range(n):
                out[a + i, j, 0] = QX[i]
                out[a + i, j, 1] = QY[i]
                out[a + i, j, 2] = QZ[i]
                out[a + i, j, 3] = QW[i]
        for i in range(a, a + n):
            for e in range(M):
                j = plan_i[o_ident + e]
                out[i, j, 0], out[i, j, 1], out[i, j, 2], out[i, j, 3] = 0.0, 0.0, 0.0, 1.0
            for k in range(3 if N > 0 else 0):
                c = plan_i[o_tcols + k]
                root[i, k] = X[c, i] if c >= 0 else plan_f[k]
            for q in range(N - 1):
                for k in range(3):
                    c = plan_i[o_tcols + 3 * (q + 1) + k]
                    moved[i, q, k] = X[c, i] if c >= 0 else plan_f[3 * (q + 1) + k]
    if zero:
        return 2
    if degenerate:
        return 3
    return 0
