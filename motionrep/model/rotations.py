"""Rotation conversions and quaternion algebra on numpy arrays.

Conventions:

* Quaternions are ``(..., 4)`` arrays in **xyzw** order (scalar last), as scipy's ``Rotation``.
* Rotation matrices are ``(..., 3, 3)`` and act on column vectors: ``v' = R @ v``.
* Euler orders follow scipy: upper case (``"ZXY"``) is *intrinsic* (``R = Rz @ Rx @ Ry``), which is what a BVH
  channel list ``Zrotation Xrotation Yrotation`` means; lower case (``"zxy"``) is extrinsic.  Orders may have one,
  two or three axes.
* Axis-angle (rotation vector) is ``(..., 3)``: unit axis times angle in radians.
* The 6D encoding (Zhou et al. 2019) is ``(..., 6)``: the first two *columns* of the rotation matrix,
  ``[R00, R10, R20, R01, R11, R21]``.
* Every function accepts any number of leading batch dimensions and returns float64.

Conversions *to* quaternions (what decoding and reading BVH spend their time on) are compiled loops in C
(``motionrep._ccore``, built at install time) that read their input straight from the columns of a 2-D array (a
feature matrix, a BVH frame block) and write into the joint slots of a ``(T, J, 4)`` array: the ``*_columns_*``
functions below, which the BVH reader calls, and which the plain functions (:func:`axis_angle_to_quat`,
:func:`euler_to_quat`, :func:`ortho6d_to_quat`, :func:`quat_normalize`) call too.  Their arithmetic is float64
whatever the input's dtype, and IEEE throughout (no fused multiply-add, no fast-math), so a value does not depend on
the batch it is in or on the CPU; it is the pose plan's (``motionrep.model.poseplan``), operation for operation.
Quaternions to Euler angles (writing BVH) are compiled too (``motionrep/_c/euler.c``: scipy's algorithm and
operations, the same bits), so writing a BVH file does not import scipy.  The other conversions delegate to
``scipy.spatial.transform.Rotation``; the algebra scipy lacks on plain arrays
(products, rotating vectors, sign and wrap continuity over frames) is written here.

Size: one concern, rotations on arrays; the length is the number of parameterisations (quaternion, matrix,
Euler in every order, axis-angle, 6D) times the conversions between them, each short, documented with its
shapes, and read next to its inverse; the compiled conversions from columns (the decoding and BVH-reading hot
path) sit at the end, each kernel beside the public function that checks its arguments.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ValidationError
from .._ccore import axis_angle_continuous as _continuous, columns_to_quat as _columns_to_quat
from .._ccore import quat_to_axis_angle as _quat_to_axis_angle, quat_to_euler as _quat_to_euler

__all__ = [
    "quat_identity",
    "quat_normalize",
    "quat_conjugate",
    "quat_multiply",
    "quat_apply",
    "quat_to_matrix",
    "matrix_to_quat",
    "euler_to_quat",
    "quat_to_euler",
    "quat_to_euler_continuous",
    "euler_branch",
    "euler_to_matrix",
    "axis_angle_to_quat",
    "quat_to_axis_angle",
    "axis_angle_make_continuous",
    "quat_make_continuous",
    "quat_to_ortho6d",
    "ortho6d_to_matrix",
    "ortho6d_to_quat",
    "quat_slerp",
    "quat_xyzw_to_wxyz",
    "quat_wxyz_to_xyzw",
    "quat_columns_normalized",
    "axis_angle_columns_to_quat",
    "euler_columns",
    "euler_columns_to_quat",
    "ortho6d_columns_to_quat",
]


def _last_dim(a: ArrayLike, n: int, name: str) -> NDArray[np.float64]:
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 0 or a.shape[-1] != n:
        raise ValidationError(f"{name} must have shape (..., {n}), got {a.shape}")
    return a


def _check_order(order: str) -> str:
    if (not isinstance(order, str) or not 1 <= len(order) <= 3 or not (order.isupper() or order.islower())
            or set(order.upper()) - set("XYZ") or any(a == b for a, b in zip(order, order[1:]))):
        raise ValidationError(f"invalid Euler order {order!r}: use 1-3 of the axes X, Y, Z, all upper case "
                              "(intrinsic) or all lower case (extrinsic), no axis twice in a row")
    return order


def quat_identity(shape: tuple[int, ...] = ()) -> NDArray[np.float64]:
    """Identity quaternions of shape ``shape + (4,)`` (xyzw: ``[0, 0, 0, 1]``)."""
    q = np.zeros(tuple(shape) + (4,))
    q[..., 3] = 1.0
    return q


def quat_normalize(q: ArrayLike) -> NDArray[np.float64]:
    """Scale ``(..., 4)`` quaternions to unit length (``q / sqrt(x^2 + y^2 + z^2 + w^2)``).

    Raises:
        ValidationError: if a quaternion has zero (or non-finite) length.
    """
    q = _last_dim(q, 4, "q")
    flat = q.reshape(-1, 4)
    out = np.empty((flat.shape[0], 1, 4))
    quat_columns_normalized(flat, _XYZW_COLUMNS, np.zeros(1, np.int64), out)
    return out.reshape(q.shape)


def quat_conjugate(q: ArrayLike) -> NDArray[np.float64]:
    """Conjugate (the inverse, for unit quaternions) of ``(..., 4)`` xyzw quaternions."""
    q = _last_dim(q, 4, "q")
    return q * np.array([-1.0, -1.0, -1.0, 1.0])


def quat_multiply(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Hamilton product ``a * b`` of ``(..., 4)`` xyzw quaternions (broadcasting); rotates by ``b`` then ``a``."""
    a = _last_dim(a, 4, "a")
    b = _last_dim(b, 4, "b")
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack([
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ], axis=-1)


def quat_apply(q: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    """Rotate ``(..., 3)`` vectors ``v`` by ``(..., 4)`` unit xyzw quaternions ``q`` (broadcasting)."""
    q = _last_dim(q, 4, "q")
    v = _last_dim(v, 3, "v")
    u = q[..., :3]
    w = q[..., 3:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _scipy_rotation():
    """scipy's ``Rotation``, imported on first use: scipy.spatial takes most of a second to import, and reading a
    BVH file or starting the command line never needs it."""
    from scipy.spatial.transform import Rotation

    return Rotation


def _flat_rotation_from_quat(q: NDArray):
    return _scipy_rotation().from_quat(q.reshape(-1, 4))


def quat_to_matrix(q: ArrayLike) -> NDArray[np.float64]:
    """``(..., 4)`` xyzw quaternions (normalised first) to ``(..., 3, 3)`` rotation matrices."""
    q = _last_dim(q, 4, "q")
    if q.size == 0:
        return np.zeros(q.shape[:-1] + (3, 3))
    return _flat_rotation_from_quat(q).as_matrix().reshape(q.shape[:-1] + (3, 3))


def matrix_to_quat(m: ArrayLike) -> NDArray[np.float64]:
    """``(..., 3, 3)`` rotation matrices to ``(..., 4)`` unit xyzw quaternions (w >= 0).

    Matrices that are not exactly orthonormal are projected to the nearest rotation.
    """
    m = np.asarray(m, dtype=np.float64)
    if m.ndim < 2 or m.shape[-2:] != (3, 3):
        raise ValidationError(f"m must have shape (..., 3, 3), got {m.shape}")
    if m.size == 0:
        return np.zeros(m.shape[:-2] + (4,))
    q = _scipy_rotation().from_matrix(m.reshape(-1, 3, 3)).as_quat(canonical=True)
    return q.reshape(m.shape[:-2] + (4,))


def euler_to_quat(angles: ArrayLike, order: str, degrees: bool = False) -> NDArray[np.float64]:
    """Euler angles ``(..., len(order))`` to ``(..., 4)`` xyzw quaternions.

    Args:
        angles: angles in the sequence of ``order`` (``angles[..., 0]`` about ``order[0]``...).
        order: 1-3 axes; upper case intrinsic (BVH channel order), lower case extrinsic.
        degrees: angles in degrees rather than radians.

    Computed as the product of the per-axis quaternions in one compiled loop (see
    :func:`euler_columns_to_quat`); the same result as scipy's ``Rotation.from_euler`` to an ulp or two, many
    times faster.  The result is not sign-canonicalised.
    """
    order = _check_order(order)
    angles = _last_dim(angles, len(order), "angles")
    flat = angles.reshape(-1, len(order))
    out = np.empty((flat.shape[0], 1, 4))
    columns, axes = euler_columns([order])
    euler_columns_to_quat(flat, columns, axes, np.zeros(1, np.int64), out, degrees=degrees)
    return out.reshape(angles.shape[:-1] + (4,))


def euler_to_matrix(angles: ArrayLike, order: str, degrees: bool = False) -> NDArray[np.float64]:
    """Euler angles ``(..., len(order))`` to ``(..., 3, 3)`` rotation matrices (see :func:`euler_to_quat`)."""
    order = _check_order(order)
    angles = _last_dim(angles, len(order), "angles")
    if angles.size == 0:
        return np.zeros(angles.shape[:-1] + (3, 3))
    m = _scipy_rotation().from_euler(order, angles.reshape(-1, len(order)), degrees=degrees).as_matrix()
    return m.reshape(angles.shape[:-1] + (3, 3))


def _complete_order(order: str) -> str:
    if len(order) == 3:
        return order
    missing = [a for a in "XYZ" if a not in order.upper()][: 3 - len(order)]
    return order + "".join(missing if order.isupper() else [a.lower() for a in missing])


def _euler_candidates(q: NDArray, order: str, degrees: bool) -> tuple[NDArray, NDArray, NDArray]:
    """Both 3-axis Euler solutions of ``q`` for ``order`` completed to three axes, and which are valid.

    Returns (primary, alternative, valid) with ``valid (..., 2)`` saying whether the dropped axes are zero
    (always true for three-axis orders).
    """
    full = _complete_order(order)
    e1 = _converted_from_quat(q, _quat_to_euler, full, degrees)
    half = 180.0 if degrees else np.pi
    # The other solution of the same rotation: (a + pi, pi - b, c + pi) for Tait-Bryan orders (three different
    # axes), (a + pi, -b, c + pi) for proper Euler orders (first axis repeated last).
    middle = -e1[:, 1] if full[0].upper() == full[2].upper() else half - e1[:, 1]
    e2 = np.stack([e1[:, 0] + half, middle, e1[:, 2] + half], axis=-1)
    e1 = _wrap(e1, half)
    e2 = _wrap(e2, half)
    n = len(order)
    if n == 3:
        valid = np.ones((e1.shape[0], 2), bool)
    else:
        tol = 1e-7 * half
        valid = np.stack([np.all(np.abs(_wrap(e[:, n:], half)) < tol, axis=-1) for e in (e1, e2)], axis=-1)
    shape = q.shape[:-1]
    return (e1[:, :n].reshape(shape + (n,)), e2[:, :n].reshape(shape + (n,)), valid.reshape(shape + (2,)))


def _converted_from_quat(q: NDArray, convert, *args) -> NDArray[np.float64]:
    """``(N, 3)``: the compiled conversion ``convert(flat, *args, out)`` (``motionrep._ccore``: scipy's operations,
    the same bits) of the ``(..., 4)`` quaternions ``q`` flattened to ``(N, 4)``; a zero or NaN quaternion raises
    scipy's own error."""
    flat = np.ascontiguousarray(q.reshape(-1, 4), dtype=np.float64)
    out = np.empty((flat.shape[0], 3))
    if convert(flat, *args, out) >= 0:
        raise ValueError("Found zero norm quaternions in `quat`.")
    return out


def _wrap(a: NDArray, half: float) -> NDArray:
    """Wrap angles to [-half, half)."""
    return (a + half) % (2 * half) - half


def quat_to_euler(q: ArrayLike, order: str, degrees: bool = False) -> NDArray[np.float64]:
    """``(..., 4)`` xyzw quaternions to Euler angles ``(..., len(order))``, frame by frame.

    For three-axis orders this is scipy's solution (middle angle in [-90, 90] degrees for Tait-Bryan orders; computed
    by the compiled core, ``motionrep/_c/euler.c``, scipy's operations bit for bit, without importing scipy).
    For one- or two-axis orders the solution whose missing axes are zero is returned.

    Raises:
        ValidationError: if a rotation cannot be expressed with the axes of a one- or two-axis order.
    """
    order = _check_order(order)
    q = _last_dim(q, 4, "q")
    if q.size == 0:
        return np.zeros(q.shape[:-1] + (len(order),))
    e1, e2, valid = _euler_candidates(q, order, degrees)
    if not np.all(valid.any(axis=-1)):
        raise ValidationError(f"a rotation is not expressible with the rotation axes {order!r} alone")
    return np.where(valid[..., :1], e1, e2)


def quat_to_euler_continuous(q: ArrayLike, order: str, degrees: bool = False,
                             branch: ArrayLike | None = None) -> NDArray[np.float64]:
    """``(F, ..., 4)`` xyzw quaternions to Euler angles ``(F, ..., len(order))`` continuous over axis 0.

    A three-axis rotation has two Euler solutions, ``(a, b, c)`` and ``(a + 180, 180 - b, c + 180)`` degrees
    (``-b`` for proper orders such as ``"ZXZ"``); :func:`quat_to_euler` returns the first, with the middle
    angle in [-90, 90].

    Args:
        q: ``(F, ..., 4)`` quaternions, frames first.
        order: 1-3 axes (see :func:`euler_to_quat`).
        degrees: return degrees rather than radians.
        branch: optional ``(F, ...)`` bool, True where the second solution is wanted (for example the one a
            BVH file used; see ``Motion.euler_branch``).  Without it, the first frame takes the first solution
            and every later frame the solution closest to the frame before it, so the angles pass smoothly
            through the middle angle's +-90 degrees.  At gimbal lock (middle angle at +-90 degrees, or 0/180
            for proper orders) only a combination of the first and third angles is determined: the first
            keeps the previous frame's value and the third is solved for.

    Every angle is then unwrapped over frames (full turns added) so it never jumps by 360 degrees.

    Raises:
        ValidationError: if a rotation cannot be expressed with the axes of a one- or two-axis order.
    """
    order = _check_order(order)
    q = _last_dim(q, 4, "q")
    n = len(order)
    if q.ndim < 2:
        raise ValidationError(f"q must have shape (frames, ..., 4), got {q.shape}")
    if q.size == 0:
        return np.zeros(q.shape[:-1] + (n,))
    e1, e2, valid = _euler_candidates(q, order, degrees)
    if not np.all(valid.any(axis=-1)):
        raise ValidationError(f"a rotation is not expressible with the rotation axes {order!r} alone")
    turn = 360.0 if degrees else 2 * np.pi
    if branch is not None:
        branch = np.asarray(branch, dtype=bool)
        if branch.shape != q.shape[:-1]:
            raise ValidationError(f"branch must have shape {q.shape[:-1]}, got {branch.shape}")
        use2 = (branch & valid[..., 1]) | ~valid[..., 0]
        out = np.where(use2[..., None], e2, e1)
    else:
        locked = _gimbal_locked(e1, order, degrees) if n == 3 else None
        out = np.empty_like(e1)
        prev = np.where(valid[0, ..., :1], e1[0], e2[0])
        out[0] = prev
        for f in range(1, q.shape[0]):
            c1 = e1[f] + turn * np.round((prev - e1[f]) / turn)
            c2 = e2[f] + turn * np.round((prev - e2[f]) / turn)
            d1 = np.where(valid[f, ..., 0], np.abs(c1 - prev).sum(-1), np.inf)
            d2 = np.where(valid[f, ..., 1], np.abs(c2 - prev).sum(-1), np.inf)
            chosen = np.where((d1 <= d2)[..., None], c1, c2)
            if locked is not None and locked[f].any():
                chosen = _keep_first_angle(q[f], chosen, prev, locked[f], order, degrees)
            prev = chosen
            out[f] = prev
    if out.shape[0] < 2:
        return out
    return np.unwrap(out, axis=0, period=turn)


def _gimbal_locked(e1: NDArray, order: str, degrees: bool) -> NDArray[np.bool_]:
    """Where the middle angle locks the first and third axes together (``(F, ...)`` bool)."""
    middle = np.deg2rad(e1[..., 1]) if degrees else e1[..., 1]
    if order[0].upper() == order[2].upper():
        return np.abs(np.sin(middle)) < 1e-9
    return np.abs(np.cos(middle)) < 1e-9


def _keep_first_angle(q: NDArray, angles: NDArray, previous: NDArray, locked: NDArray, order: str,
                      degrees: bool) -> NDArray:
    """At gimbal lock only a combination of the first and third angles is fixed: take the previous frame's first
    angle and solve the third (where ``locked``), so the angles stay continuous."""
    angles = angles.copy()
    angles[locked, 0] = previous[locked][:, 0]
    first_two = euler_to_quat(angles[locked][:, :2], order[:2], degrees=degrees)
    if order.isupper():  # R = R0 R1 R2  ->  R2 = (R0 R1)^-1 R
        rest = quat_multiply(quat_conjugate(first_two), q[locked])
    else:  # extrinsic: R = R2 R1 R0  ->  R2 = R (R1 R0)^-1
        rest = quat_multiply(q[locked], quat_conjugate(first_two))
    third = 2.0 * np.arctan2(rest[:, "XYZ".index(order[2].upper())], rest[:, 3])
    third = np.rad2deg(third) if degrees else third
    turn = 360.0 if degrees else 2 * np.pi
    before = previous[locked][:, 2]
    angles[locked, 2] = third + turn * np.round((before - third) / turn)
    return angles


def euler_branch(angles: ArrayLike, order: str, degrees: bool = False) -> NDArray[np.bool_]:
    """Which of the two Euler solutions ``angles`` ``(..., len(order))`` are: True for the second one.

    For three-axis Tait-Bryan orders the first solution has its middle angle in [-90, 90] degrees; for proper
    orders in [0, 180].  One- and two-axis orders always give False.
    """
    order = _check_order(order)
    angles = _last_dim(angles, len(order), "angles")
    if len(order) < 3:
        return np.zeros(angles.shape[:-1], bool)
    half = 180.0 if degrees else np.pi
    middle = angles[..., 1]
    if middle.size and np.abs(middle).max() >= half:  # wrap only when needed (it costs, and rounds)
        middle = _wrap(middle, half)
    if order[0].upper() == order[2].upper():
        return middle < 0
    return np.abs(middle) > half / 2


def axis_angle_to_quat(v: ArrayLike) -> NDArray[np.float64]:
    """``(..., 3)`` rotation vectors (axis times angle, radians) to ``(..., 4)`` xyzw quaternions
    (``[sin(theta / 2) n, cos(theta / 2)]``, not sign-canonicalised; see :func:`axis_angle_columns_to_quat`)."""
    v = _last_dim(v, 3, "v")
    flat = v.reshape(-1, 3)
    out = np.empty((flat.shape[0], 1, 4))
    axis_angle_columns_to_quat(flat, _XYZ_COLUMNS, np.zeros(1, np.int64), out)
    return out.reshape(v.shape[:-1] + (4,))


def quat_to_axis_angle(q: ArrayLike) -> NDArray[np.float64]:
    """``(..., 4)`` xyzw quaternions to ``(..., 3)`` rotation vectors with angle in [0, pi] (frame by frame).

    Use :func:`axis_angle_make_continuous` to remove wrap jumps along a time axis.
    """
    q = _last_dim(q, 4, "q")
    if q.size == 0:
        return np.zeros(q.shape[:-1] + (3,))
    # compiled: scipy's as_rotvec operation for operation (rotations.c)
    return _converted_from_quat(q, _quat_to_axis_angle).reshape(q.shape[:-1] + (3,))


def axis_angle_make_continuous(v: ArrayLike) -> NDArray[np.float64]:
    """Make ``(F, ..., 3)`` rotation vectors continuous over axis 0.

    A rotation vector ``theta * n`` describes the same rotation as ``(theta + 2 pi k) * n`` for every integer
    ``k``; each frame takes the ``k`` that brings it closest (L2) to the previous frame's output.  A frame
    without rotation (``theta = 0``, any axis) takes the previous frame's axis: a whole number of turns about it.
    Frame by frame, so a compiled loop (``motionrep/_c/rotations.c``), its sums and products in numpy's order
    (``((a0 b0 + a1 b1) + a2 b2)``): the result of the frame-by-frame numpy loop it replaced, bit for bit.
    """
    v = _last_dim(v, 3, "v")
    if v.ndim < 2:
        raise ValidationError(f"v must have shape (frames, ..., 3), got {v.shape}")
    theta = np.linalg.norm(v, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        axis = np.where(theta[..., None] > 1e-12, v / theta[..., None], 0.0)
    out = np.array(v, dtype=np.float64, order="C", copy=True)
    flat = out.reshape(v.shape[0], -1, 3)
    _continuous(np.ascontiguousarray(theta).reshape(flat.shape[:2]),
                       np.ascontiguousarray(axis).reshape(flat.shape), flat)
    return out


def quat_make_continuous(q: ArrayLike) -> NDArray[np.float64]:
    """Flip the signs of ``(F, ..., 4)`` xyzw quaternions so consecutive frames are closest in L2 (dot >= 0).

    ``q`` and ``-q`` are the same rotation; after this, no quaternion changes sign between frames.
    """
    q = _last_dim(q, 4, "q")
    if q.ndim < 2:
        raise ValidationError(f"q must have shape (frames, ..., 4), got {q.shape}")
    if q.shape[0] < 2:
        return q.copy()
    dots = np.sum(q[1:] * q[:-1], axis=-1)
    flips = np.where(dots < 0, -1.0, 1.0)
    signs = np.concatenate([np.ones((1,) + flips.shape[1:]), np.cumprod(flips, axis=0)], axis=0)
    return q * signs[..., None]


def quat_to_ortho6d(q: ArrayLike) -> NDArray[np.float64]:
    """``(..., 4)`` xyzw quaternions to the ``(..., 6)`` 6D encoding (first two matrix columns)."""
    m = quat_to_matrix(q)
    return np.concatenate([m[..., :, 0], m[..., :, 1]], axis=-1)


def ortho6d_to_matrix(d6: ArrayLike) -> NDArray[np.float64]:
    """``(..., 6)`` 6D encodings to ``(..., 3, 3)`` rotation matrices by Gram-Schmidt (Zhou et al. 2019).

    Raises:
        ValidationError: if the two columns are (nearly) zero or parallel.
    """
    d6 = _last_dim(d6, 6, "d6")
    a1, a2 = d6[..., :3], d6[..., 3:]
    n1 = np.linalg.norm(a1, axis=-1, keepdims=True)
    b1 = a1 / np.where(n1 > 0, n1, 1.0)
    u2 = a2 - np.sum(b1 * a2, axis=-1, keepdims=True) * b1
    n2 = np.linalg.norm(u2, axis=-1, keepdims=True)
    if np.any(n1 < 1e-12) or np.any(n2 < 1e-12):
        raise ValidationError("6D rotation encoding has a zero or degenerate column")
    b2 = u2 / n2
    b3 = np.cross(b1, b2)
    return np.stack([b1, b2, b3], axis=-1)


def ortho6d_to_quat(d6: ArrayLike) -> NDArray[np.float64]:
    """``(..., 6)`` 6D encodings to ``(..., 4)`` xyzw quaternions (w >= 0): Gram-Schmidt, then the matrix's
    quaternion (see :func:`ortho6d_columns_to_quat`).

    Raises:
        ValidationError: if the two columns are (nearly) zero or parallel.
    """
    d6 = _last_dim(d6, 6, "d6")
    flat = d6.reshape(-1, 6)
    out = np.empty((flat.shape[0], 1, 4))
    ortho6d_columns_to_quat(flat, _SIX_COLUMNS, np.zeros(1, np.int64), out)
    return out.reshape(d6.shape[:-1] + (4,))


def quat_slerp(q0: ArrayLike, q1: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
    """Spherical linear interpolation between ``(..., 4)`` xyzw unit quaternions, along the shorter arc.

    Args:
        q0, q1: endpoints (broadcasting).
        t: interpolation parameter, broadcast against ``q0[..., 0]``; 0 gives ``q0``, 1 gives ``q1``.
    """
    q0 = _last_dim(q0, 4, "q0")
    q1 = _last_dim(q1, 4, "q1")
    t = np.asarray(t, dtype=np.float64)[..., None]
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0, -q1, q1)
    dot = np.abs(dot)
    theta = np.arccos(np.clip(dot, -1.0, 1.0))
    sin = np.sin(theta)
    small = sin < 1e-9
    with np.errstate(invalid="ignore", divide="ignore"):
        w0 = np.where(small, 1.0 - t, np.sin((1.0 - t) * theta) / np.where(small, 1.0, sin))
        w1 = np.where(small, t, np.sin(t * theta) / np.where(small, 1.0, sin))
    out = w0 * q0 + w1 * q1
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def quat_xyzw_to_wxyz(q: ArrayLike) -> NDArray[np.float64]:
    """Reorder ``(..., 4)`` quaternions from xyzw (motionrep, scipy) to wxyz (pytorch3d, some file formats)."""
    q = _last_dim(q, 4, "q")
    return q[..., [3, 0, 1, 2]]


def quat_wxyz_to_xyzw(q: ArrayLike) -> NDArray[np.float64]:
    """Reorder ``(..., 4)`` quaternions from wxyz to motionrep's xyzw."""
    q = _last_dim(q, 4, "q")
    return q[..., [1, 2, 3, 0]]


# ---------------------------------------------------------------------------------------------------------------
# conversions from the columns of a 2-D array into the joint slots of (T, J, 4) quaternions (motionrep/_c)
# ---------------------------------------------------------------------------------------------------------------
_XYZ_COLUMNS = np.arange(3, dtype=np.int64).reshape(1, 3)
_XYZW_COLUMNS = np.arange(4, dtype=np.int64).reshape(1, 4)
_SIX_COLUMNS = np.arange(6, dtype=np.int64).reshape(1, 6)
_F64, _F32, _I64 = np.dtype(np.float64), np.dtype(np.float32), np.dtype(np.int64)
#: the conversions of motionrep._ccore.columns_to_quat (the pose plan's kinds of the same names)
_QUAT, _AXIS_ANGLE, _EULER, _EULER_DEGREES, _ORTHO6D = range(5)


def _convert_columns(features: NDArray, columns: ArrayLike, joints: ArrayLike, out: NDArray, width: int,
                     kind: int, axes: ArrayLike | None = None) -> None:
    """Check the arguments of the ``*_columns_*`` functions and run the compiled conversion (``motionrep._ccore``:
    ``motionrep/_c/mr_rotconv.h``, one entry of ``kind`` per row of ``columns``)."""
    f = features if type(features) is np.ndarray else np.asarray(features)
    if f.dtype is not _F64 and f.dtype is not _F32:
        f = f.astype(np.float64)
    cols = columns if type(columns) is np.ndarray and columns.dtype is _I64 else np.asarray(columns, np.int64)
    idx = joints if type(joints) is np.ndarray and joints.dtype is _I64 else np.asarray(joints, np.int64)
    if f.ndim != 2:
        raise ValidationError(f"features must be 2-D (rows, columns), got shape {f.shape}")
    if idx.ndim != 1 or cols.ndim != 2 or cols.shape[1] != width or cols.shape[0] != idx.shape[0]:
        raise ValidationError(f"columns must have shape (R, {width}) and joints (R,), got {cols.shape} and "
                              f"{idx.shape}")
    if (type(out) is not np.ndarray or out.ndim != 3 or out.shape[0] != f.shape[0] or out.shape[2] != 4
            or (out.dtype is not _F64 and out.dtype is not _F32) or not out.flags.c_contiguous):
        raise ValidationError(f"out must be a C-contiguous float32 or float64 array of shape ({f.shape[0]}, J, 4), "
                              f"got {getattr(out, 'dtype', type(out).__name__)} {getattr(out, 'shape', '')}")
    R, J = cols.shape[0], out.shape[1]
    euler = kind == _EULER or kind == _EULER_DEGREES
    used = cols >= 0
    if euler:  # -1 ends a joint's factors early: after its first, and never followed by a column
        used = np.cumprod(used, axis=1).astype(bool)
    if (np.any(cols[~used] != -1) or np.any(cols >= f.shape[1]) or np.any(idx < 0) or np.any(idx >= J)
            or (R and not used[:, 0].all())):
        raise ValidationError("columns must index the columns of features (-1 only to end a joint's Euler "
                              "factors early) and joints the joints of out")
    if np.unique(idx).size != R:
        raise ValidationError("joints must all be different: each conversion writes its own joint")
    ax = None
    if euler:
        ax = np.asarray(axes, np.int64)
        if ax.shape != (R, 3):
            raise ValidationError(f"axes must have the shape of columns {cols.shape}, got {ax.shape}")
        if np.any(used & ((ax < 0) | (ax > 2))):
            raise ValidationError("axes must be 0 (X), 1 (Y) or 2 (Z) for every angle")
    status = _columns_to_quat(kind, np.ascontiguousarray(f), np.ascontiguousarray(cols), ax,
                              np.ascontiguousarray(idx), out)
    if status == 2:
        raise ValidationError("cannot normalise a quaternion of zero or non-finite length")
    if status == 3:
        raise ValidationError("6D rotation encoding has a zero or degenerate column")


def quat_columns_normalized(features: NDArray, columns: ArrayLike, joints: ArrayLike, out: NDArray) -> None:
    """``out[:, joints[r]] = q / |q|`` for the quaternion (xyzw) in ``features[:, columns[r]]``.

    Args:
        features: ``(T, C)`` float32 or float64.
        columns: ``(R, 4)`` column indices of each quaternion's x, y, z, w.
        joints: ``(R,)`` where each goes in ``out`` (all different).
        out: ``(T, J, 4)`` float32 or float64, written in place (the other joints are left as they are).

    Raises:
        ValidationError: if a quaternion has zero (or non-finite) length.
    """
    _convert_columns(features, columns, joints, out, 4, _QUAT)


def axis_angle_columns_to_quat(features: NDArray, columns: ArrayLike, joints: ArrayLike, out: NDArray) -> None:
    """``out[:, joints[r]]`` = the quaternion of the rotation vector in ``features[:, columns[r]]``.

    ``q = [sin(theta / 2) v / theta, cos(theta / 2)]`` with ``theta = |v|`` (its series below 1e-3 rad), in
    float64, not sign-canonicalised (``theta > pi`` gives ``w < 0``), as scipy's ``Rotation.from_rotvec``.

    Args:
        features: ``(T, C)`` float32 or float64.
        columns: ``(R, 3)`` column indices of each rotation vector's x, y, z.
        joints: ``(R,)`` where each goes in ``out`` (all different).
        out: ``(T, J, 4)`` float32 or float64, written in place.
    """
    _convert_columns(features, columns, joints, out, 3, _AXIS_ANGLE)


def euler_columns(orders: list[str] | tuple[str, ...]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Per joint, which of its own angles each factor of :func:`euler_columns_to_quat` takes, and the axes.

    For joint ``r`` with ``order = orders[r]`` (angles stored in the order's sequence), returns ``positions[r, k]``,
    the index among that joint's angles of the ``k``-th factor applied intrinsically (the reverse sequence for
    an extrinsic, lower-case order), and ``axes[r, k]`` its axis (0 = X, 1 = Y, 2 = Z); ``-1`` pads orders of
    fewer than three axes.  Add each joint's first column to its positions (keeping the ``-1``) to get the
    ``columns`` argument.

    Example::

        positions, axes = euler_columns(["ZXY", "zyx"])  # positions [[0, 1, 2], [2, 1, 0]], axes [[2, 0, 1], [0, 1, 2]]
    """
    R = len(orders)
    positions = np.full((R, 3), -1, np.int64)
    axes = np.full((R, 3), -1, np.int64)
    for r, order in enumerate(orders):
        order = _check_order(order)
        k = list(range(len(order)))
        if order.islower():  # extrinsic: the same axes applied in reverse order, intrinsically
            k.reverse()
        positions[r, :len(k)] = k
        axes[r, :len(k)] = ["XYZ".index(order[i].upper()) for i in k]
    return positions, axes


def euler_columns_to_quat(features: NDArray, columns: ArrayLike, axes: ArrayLike, joints: ArrayLike, out: NDArray,
                          degrees: bool = False) -> None:
    """``out[:, joints[r]]`` = the product of the rotations about ``axes[r, k]`` by the angles in
    ``features[:, columns[r, k]]`` (``k`` = 0, 1, 2; intrinsic: the first factor leftmost).

    Args:
        features: ``(T, C)`` float32 or float64 angles.
        columns: ``(R, 3)`` column of each factor's angle; ``-1`` ends a joint's factors early.
        axes: ``(R, 3)`` axis of each factor (0 = X, 1 = Y, 2 = Z); see :func:`euler_columns` for orders.
        joints: ``(R,)`` where each goes in ``out`` (all different).
        out: ``(T, J, 4)`` float32 or float64, written in place.
        degrees: the angles are in degrees (reduced exactly modulo 720 before the conversion to radians).

    Raises:
        ValidationError: for columns, axes or joints out of range.
    """
    _convert_columns(features, columns, joints, out, 3, _EULER_DEGREES if degrees else _EULER, axes)


def ortho6d_columns_to_quat(features: NDArray, columns: ArrayLike, joints: ArrayLike, out: NDArray) -> None:
    """``out[:, joints[r]]`` = the quaternion (w >= 0) of the 6D encoding in ``features[:, columns[r]]``
    (Gram-Schmidt of the two columns, their cross product third; then the matrix's quaternion as scipy's
    ``Rotation.from_matrix``).

    Args:
        features: ``(T, C)`` float32 or float64.
        columns: ``(R, 6)`` column indices of ``[R00, R10, R20, R01, R11, R21]``.
        joints: ``(R,)`` where each goes in ``out`` (all different).
        out: ``(T, J, 4)`` float32 or float64, written in place.

    Raises:
        ValidationError: if the two columns are (nearly) zero or parallel.
    """
    _convert_columns(features, columns, joints, out, 6, _ORTHO6D)
