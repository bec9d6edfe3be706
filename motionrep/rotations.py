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

The conversions delegate to ``scipy.spatial.transform.Rotation``; only the algebra scipy lacks on plain arrays
(products, rotating vectors, sign and wrap continuity over frames) is written here.

Size: one concern, rotations on arrays; the length is the number of parameterisations (quaternion, matrix,
Euler in every order, axis-angle, 6D) times the conversions between them, each short, documented with its
shapes, and read next to its inverse.
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from .errors import ValidationError

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
    """Scale ``(..., 4)`` quaternions to unit length.

    Raises:
        ValidationError: if a quaternion has zero (or non-finite) length.
    """
    q = _last_dim(q, 4, "q")
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    if not np.all(np.isfinite(n) & (n > 0)):
        raise ValidationError("cannot normalise a quaternion of zero or non-finite length")
    return q / n


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


def _flat_rotation_from_quat(q: NDArray) -> Rotation:
    return Rotation.from_quat(q.reshape(-1, 4))


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
    q = Rotation.from_matrix(m.reshape(-1, 3, 3)).as_quat(canonical=True)
    return q.reshape(m.shape[:-2] + (4,))


def euler_to_quat(angles: ArrayLike, order: str, degrees: bool = False) -> NDArray[np.float64]:
    """Euler angles ``(..., len(order))`` to ``(..., 4)`` xyzw quaternions.

    Args:
        angles: angles in the sequence of ``order`` (``angles[..., 0]`` about ``order[0]``...).
        order: 1-3 axes; upper case intrinsic (BVH channel order), lower case extrinsic.
        degrees: angles in degrees rather than radians.

    Computed as the product of the per-axis quaternions, one component array at a time (the same result as
    scipy's ``Rotation.from_euler`` to rounding and many times faster on large batches, which matters when
    reading long BVH files).  The result is not sign-canonicalised.
    """
    order = _check_order(order)
    angles = _last_dim(angles, len(order), "angles")
    out = np.empty(angles.shape[:-1] + (4,))
    _euler_to_quat_into(angles, order, degrees, out)
    return out


def _euler_to_quat_into(angles: NDArray, order: str, degrees: bool, out: NDArray) -> None:
    """:func:`euler_to_quat` of ``angles (..., n)`` (checked, float64) written into ``out (..., 4)``, which may be
    a strided view (say, some joints of a ``(F, J, 4)`` array); chunked along the first axis."""
    n = len(order)
    axes = ["XYZ".index(a) for a in order.upper()]
    steps = list(range(n))
    if order.islower():  # extrinsic: the same axes applied in reverse order, intrinsically
        steps.reverse()
    scale = np.pi / 720.0 if degrees else 0.25  # to quarter angles in radians
    if angles.ndim == 1:
        angles, out = angles[None], out[None]
    per_row = max(1, int(np.prod(angles.shape[1:-1])))
    step = max(1, _CHUNK // per_row)
    for a in range(0, angles.shape[0], step):  # chunks stay in cache and reuse their memory
        _euler_to_quat_chunk(angles[a:a + step], out[a:a + step], axes, steps, scale)


#: Rows per chunk in the element-wise conversions (small temporaries are reused, large ones page-fault).
_CHUNK = 4096


def _euler_to_quat_chunk(angles: NDArray, out: NDArray, axes: list[int], steps: list[int], scale: float) -> None:
    """One chunk: ``angles (m, ..., n)`` to ``out (m, ..., 4)``."""
    # sin and cos of the half angles from the tangent of the quarter angles (t = tan(a / 4):
    # sin(a / 2) = 2t / (1 + t^2), cos(a / 2) = (1 - t^2) / (1 + t^2)), accurate to an ulp or two and
    # several times faster than numpy's sin and cos, which have no vectorised float64 loops.
    t = np.moveaxis(angles, -1, 0) * scale  # (n, m, ...) contiguous
    np.tan(t, out=t)
    t2 = t * t
    den = t2 + 1.0
    s = np.divide(2.0 * t, den)
    c = np.subtract(1.0, t2, out=t2)
    c /= den
    k0 = steps[0]
    if len(steps) == 1:
        out[...] = 0.0
        out[..., axes[k0]] = s[k0]
        out[..., 3] = c[k0]
        return
    # the first two factors in closed form: rotations about two different axes i, j (k the third)
    k1 = steps[1]
    i, j = axes[k0], axes[k1]
    comps: list = [None, None, None, c[k0] * c[k1]]
    comps[i] = s[k0] * c[k1]
    comps[j] = c[k0] * s[k1]
    cross = s[k0] * s[k1]  # e_i x e_j = +-e_k
    comps[3 - i - j] = cross if (j - i) % 3 == 1 else np.negative(cross, out=cross)
    for k in steps[2:]:
        comps = _times_axis_quat(comps, axes[k], s[k], c[k])
    for i in range(4):
        out[..., i] = comps[i]


def _times_axis_quat(q: list[NDArray], axis: int, s: NDArray, c: NDArray) -> list[NDArray]:
    """``q * (s * e_axis, c)`` on component arrays ``[x, y, z, w]``: the product with a rotation about one axis."""
    x, y, z, w = q
    if axis == 0:
        return [c * x + s * w, c * y + s * z, c * z - s * y, c * w - s * x]
    if axis == 1:
        return [c * x - s * z, c * y + s * w, c * z + s * x, c * w - s * y]
    return [c * x + s * y, c * y - s * x, c * z + s * w, c * w - s * z]


def euler_to_matrix(angles: ArrayLike, order: str, degrees: bool = False) -> NDArray[np.float64]:
    """Euler angles ``(..., len(order))`` to ``(..., 3, 3)`` rotation matrices (see :func:`euler_to_quat`)."""
    order = _check_order(order)
    angles = _last_dim(angles, len(order), "angles")
    if angles.size == 0:
        return np.zeros(angles.shape[:-1] + (3, 3))
    m = Rotation.from_euler(order, angles.reshape(-1, len(order)), degrees=degrees).as_matrix()
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
    flat = q.reshape(-1, 4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # gimbal lock: scipy picks a valid solution and warns
        e1 = Rotation.from_quat(flat).as_euler(full, degrees=degrees)
    half = 180.0 if degrees else np.pi
    # The other solution of the same rotation: (a + pi, pi - b, c + pi) for Tait-Bryan orders (three different
    # axes), (a + pi, -b, c + pi) for proper Euler orders (first axis repeated last).
    middle = -e1[:, 1] if full[0].upper() == full[2].upper() else half - e1[:, 1]
    e2 = np.stack([e1[:, 0] + half, middle, e1[:, 2] + half], axis=-1)
    e1 = _wrap(e1, half)
    e2 = _wrap(e2, half)
    n = len(order)
    if n == 3:
        valid = np.ones((flat.shape[0], 2), bool)
    else:
        tol = 1e-7 * half
        valid = np.stack([np.all(np.abs(_wrap(e[:, n:], half)) < tol, axis=-1) for e in (e1, e2)], axis=-1)
    shape = q.shape[:-1]
    return (e1[:, :n].reshape(shape + (n,)), e2[:, :n].reshape(shape + (n,)), valid.reshape(shape + (2,)))


def _wrap(a: NDArray, half: float) -> NDArray:
    """Wrap angles to [-half, half)."""
    return (a + half) % (2 * half) - half


def quat_to_euler(q: ArrayLike, order: str, degrees: bool = False) -> NDArray[np.float64]:
    """``(..., 4)`` xyzw quaternions to Euler angles ``(..., len(order))``, frame by frame.

    For three-axis orders this is scipy's solution (middle angle in [-90, 90] degrees for Tait-Bryan orders).
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
    """``(..., 3)`` rotation vectors (axis times angle, radians) to ``(..., 4)`` xyzw quaternions."""
    v = _last_dim(v, 3, "v")
    if v.size == 0:
        return np.zeros(v.shape[:-1] + (4,))
    return Rotation.from_rotvec(v.reshape(-1, 3)).as_quat().reshape(v.shape[:-1] + (4,))


def quat_to_axis_angle(q: ArrayLike) -> NDArray[np.float64]:
    """``(..., 4)`` xyzw quaternions to ``(..., 3)`` rotation vectors with angle in [0, pi] (frame by frame).

    Use :func:`axis_angle_make_continuous` to remove wrap jumps along a time axis.
    """
    q = _last_dim(q, 4, "q")
    if q.size == 0:
        return np.zeros(q.shape[:-1] + (3,))
    return _flat_rotation_from_quat(q).as_rotvec().reshape(q.shape[:-1] + (3,))


def axis_angle_make_continuous(v: ArrayLike) -> NDArray[np.float64]:
    """Make ``(F, ..., 3)`` rotation vectors continuous over axis 0.

    A rotation vector ``theta * n`` describes the same rotation as ``(theta + 2 pi k) * n`` for every integer
    ``k``; each frame takes the ``k`` that brings it closest (L2) to the previous frame's output.  A frame
    without rotation (``theta = 0``, any axis) takes the previous frame's axis: a whole number of turns about it.
    """
    v = _last_dim(v, 3, "v")
    if v.ndim < 2:
        raise ValidationError(f"v must have shape (frames, ..., 3), got {v.shape}")
    out = v.copy()
    theta = np.linalg.norm(v, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        axis = np.where(theta[..., None] > 1e-12, v / theta[..., None], 0.0)
    two_pi = 2 * np.pi
    for f in range(1, v.shape[0]):
        ax = axis[f]
        if np.any(theta[f] <= 1e-12):  # no rotation: any axis will do, so keep the previous frame's
            size = np.linalg.norm(out[f - 1], axis=-1, keepdims=True)
            before = np.where(size > 1e-12, out[f - 1] / np.where(size > 1e-12, size, 1.0), 0.0)
            ax = np.where(theta[f][..., None] > 1e-12, ax, before)
        k = np.round(((ax * out[f - 1]).sum(-1) - theta[f]) / two_pi)
        out[f] = (theta[f] + two_pi * k)[..., None] * ax
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
    """``(..., 6)`` 6D encodings to ``(..., 4)`` xyzw quaternions (Gram-Schmidt, then conversion)."""
    return matrix_to_quat(ortho6d_to_matrix(d6))


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
