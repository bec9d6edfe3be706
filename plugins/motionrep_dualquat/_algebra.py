"""Dual-quaternion algebra on numpy arrays (scipy has none).

Conventions:

* A dual quaternion ``q = q_r + eps q_d`` (``eps**2 = 0``) is a ``(..., 8)`` array: the real part ``q_r`` in
  columns 0-3 and the dual part ``q_d`` in columns 4-7, **both in xyzw order** (scalar last), like every
  quaternion in motionrep.
* A unit dual quaternion encodes the rigid transform "rotate by ``q_r``, then translate by ``t``" with
  ``q_d = 1/2 t q_r`` (``t`` the pure quaternion ``(x, y, z, 0)``), Andreou et al. (2022) eq. 6; the
  translation is recovered as ``t = 2 q_d q_r*`` (eq. 8).
* Every function accepts any leading batch dimensions and returns float64.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep.errors import ValidationError
from motionrep.model.rotations import quat_conjugate, quat_multiply

__all__ = [
    "dualquat_multiply",
    "dualquat_conjugate",
    "dualquat_normalize",
    "dualquat_from_rotation_translation",
    "dualquat_to_rotation_translation",
    "dualquat_make_continuous",
]


def _dq(a: ArrayLike, name: str) -> NDArray[np.float64]:
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 0 or a.shape[-1] != 8:
        raise ValidationError(f"{name} must have shape (..., 8) (real xyzw, dual xyzw), got {a.shape}")
    return a


def _pure(t: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(..., 3)`` vectors as pure quaternions ``(..., 4)`` xyzw with ``w = 0``."""
    return np.concatenate([t, np.zeros(t.shape[:-1] + (1,))], axis=-1)


def dualquat_multiply(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Product ``a b`` of ``(..., 8)`` dual quaternions (broadcasting): ``a_r b_r + eps (a_r b_d + a_d b_r)``
    (Andreou et al. eq. 1).  For unit dual quaternions this applies ``b``'s transform, then ``a``'s."""
    a = _dq(a, "a")
    b = _dq(b, "b")
    ar, ad = a[..., :4], a[..., 4:]
    br, bd = b[..., :4], b[..., 4:]
    return np.concatenate([quat_multiply(ar, br), quat_multiply(ar, bd) + quat_multiply(ad, br)], axis=-1)


def dualquat_conjugate(a: ArrayLike) -> NDArray[np.float64]:
    """Quaternion conjugate of both parts, ``q_r* + eps q_d*``: the inverse of a unit dual quaternion."""
    a = _dq(a, "a")
    return np.concatenate([quat_conjugate(a[..., :4]), quat_conjugate(a[..., 4:])], axis=-1)


def dualquat_normalize(a: ArrayLike) -> NDArray[np.float64]:
    """The unit dual quaternion nearest to ``(..., 8)`` ``a`` by Andreou et al. (2022) eq. 13.

    ``q_r / |q_r| + eps (q_d / |q_r| - q_r <q_r, q_d> / |q_r|**3)``: the real part becomes a unit quaternion
    and the dual part orthogonal to it (the unit conditions, eq. 3).

    Raises:
        ValidationError: if a real part has zero (or non-finite) length.
    """
    a = _dq(a, "a")
    r, d = a[..., :4], a[..., 4:]
    n = np.linalg.norm(r, axis=-1, keepdims=True)
    if not np.all(np.isfinite(n) & (n > 0)):
        raise ValidationError("cannot normalise a dual quaternion whose real part has zero or non-finite length")
    rn = r / n
    dn = d / n - rn * (np.sum(r * d, axis=-1, keepdims=True) / n**2)
    return np.concatenate([rn, dn], axis=-1)


def dualquat_from_rotation_translation(q: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
    """Unit dual quaternions ``(..., 8)`` of "rotate by ``q`` ``(..., 4)`` xyzw, then translate by ``t``
    ``(..., 3)``": real part ``q``, dual part ``1/2 t q`` (eq. 6).  ``q`` must be unit length."""
    q = np.asarray(q, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    if q.shape[-1:] != (4,) or t.shape[-1:] != (3,):
        raise ValidationError(f"q must be (..., 4) and t (..., 3), got {q.shape} and {t.shape}")
    d = 0.5 * quat_multiply(_pure(t), q)
    q = np.broadcast_to(q, d.shape)
    return np.concatenate([q, d], axis=-1)


def dualquat_to_rotation_translation(a: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Rotation ``(..., 4)`` xyzw (the real part) and translation ``(..., 3)`` (``2 q_d q_r*``, eq. 8) of unit
    dual quaternions ``(..., 8)``.  Normalise lossy input with :func:`dualquat_normalize` first."""
    a = _dq(a, "a")
    r, d = a[..., :4], a[..., 4:]
    return r.copy(), 2.0 * quat_multiply(d, quat_conjugate(r))[..., :3]


def dualquat_make_continuous(a: ArrayLike) -> NDArray[np.float64]:
    """Flip the signs of ``(F, ..., 8)`` dual quaternions so no real part changes sign between frames.

    ``q`` and ``-q`` are the same rigid transform.  Each frame takes the sign whose *real part* is closest in
    L2 to the previous frame's (4-D dot product >= 0); the dual part follows.  Andreou et al. (2022) section
    5.1 compare whole 8-vectors, but the dual part scales with the length unit, so in centimetres a foot
    moving fast relative to the root can outvote the rotation and flip the real part (it happens in real
    clips); the real part alone gives the same choice in every unit.
    """
    a = _dq(a, "a")
    if a.ndim < 2:
        raise ValidationError(f"a must have shape (frames, ..., 8), got {a.shape}")
    if a.shape[0] < 2:
        return a.copy()
    flips = np.where(np.sum(a[1:, ..., :4] * a[:-1, ..., :4], axis=-1) < 0, -1.0, 1.0)
    signs = np.concatenate([np.ones((1,) + flips.shape[1:]), np.cumprod(flips, axis=0)], axis=0)
    return a * signs[..., None]
