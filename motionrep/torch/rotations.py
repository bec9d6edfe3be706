"""Rotation conversions and quaternion algebra on torch tensors, under the names of :mod:`motionrep.model.rotations`.

Conventions (those of :mod:`motionrep.model.rotations`):

* Quaternions are ``(..., 4)`` tensors in **xyzw** order (scalar last); roma uses the same order.
* Rotation matrices are ``(..., 3, 3)`` and act on column vectors (``v' = R @ v``).
* Euler orders: upper case (``"ZXY"``) intrinsic (``R = Rz @ Rx @ Ry``, a BVH channel list), lower case
  extrinsic; one, two or three axes.
* Axis-angle is ``(..., 3)``: unit axis times the angle in radians.
* The 6D encoding (Zhou et al. 2019) is ``(..., 6)``: the first two **columns** of the rotation matrix,
  ``[R00, R10, R20, R01, R11, R21]`` (pytorch3d's ``matrix_to_rotation_6d`` takes rows, pytorch3d #1214).
* Every function takes any leading batch dimensions and keeps the input's dtype and device.

Hemisphere rule: ``q`` and ``-q`` are the same rotation.  Conversions *to* quaternions from a matrix or a 6D
encoding return ``w >= 0`` (as :func:`motionrep.model.rotations.matrix_to_quat`); :func:`axis_angle_to_quat` and
:func:`euler_to_quat` return the product of the half-angle quaternions without choosing a sign (an angle beyond
pi gives ``w < 0``), as numpy does; :func:`quat_to_axis_angle` reads ``q`` with ``w >= 0`` (angle in
``[0, pi]``).  A map that picks a hemisphere is discontinuous where ``w = 0`` (180 degrees): there its gradient
is the one-sided derivative from ``w > 0``, finite; any hemisphere-invariant use of it (a matrix, a position,
an axis-angle turned back into a rotation) is smooth there.

Gradients are finite at the identity and at 180 degrees: the axis-angle maps use the sinc-type factor
``angle / |v|`` with its series below ``1e-6`` (the square root of ``|v|**2`` is never differentiated at 0,
the cause of NaN gradients in some libraries, kornia #3949).

roma does the conversions it has (Euler in any order, axis-angle to quaternion, matrix to quaternion, Gram-Schmidt
of the 6D columns, products); written here: the hemisphere rules, the 1- and 2-axis Euler orders, the
axis-angle extraction with a gradient at the identity, and :func:`quat_make_continuous`.  The
``*_columns_*`` kernels and the frame-by-frame Euler continuity of :mod:`motionrep.model.rotations` belong to numpy
decoding and encoding and have no counterpart here.
"""

from __future__ import annotations

import math

import roma
import torch

from ..errors import ValidationError
from ..model.rotations import _check_order, _complete_order

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
    "euler_to_matrix",
    "axis_angle_to_quat",
    "quat_to_axis_angle",
    "quat_make_continuous",
    "quat_to_ortho6d",
    "ortho6d_to_matrix",
    "ortho6d_to_quat",
    "quat_slerp",
    "quat_xyzw_to_wxyz",
    "quat_wxyz_to_xyzw",
]

#: Below this rotation-vector (or quaternion vector-part) length, the sinc-type factors use their series.
_SMALL = 1e-6


def _last(t: torch.Tensor, n: int, name: str) -> torch.Tensor:
    if not isinstance(t, torch.Tensor):
        raise ValidationError(f"{name} must be a torch tensor, got {type(t).__name__}")
    if t.ndim == 0 or t.shape[-1] != n:
        raise ValidationError(f"{name} must have shape (..., {n}), got {tuple(t.shape)}")
    return t


def quat_identity(shape: tuple[int, ...] = (), dtype: torch.dtype | None = None,
                  device: torch.device | str | None = None) -> torch.Tensor:
    """Identity quaternions of shape ``shape + (4,)`` (xyzw ``[0, 0, 0, 1]``)."""
    q = torch.zeros(tuple(shape) + (4,), dtype=dtype, device=device)
    q[..., 3] = 1.0
    return q


def quat_normalize(q: torch.Tensor) -> torch.Tensor:
    """``(..., 4)`` quaternions scaled to unit length (a zero quaternion gives NaN, as numpy raises)."""
    q = _last(q, 4, "q")
    return q / torch.linalg.vector_norm(q, dim=-1, keepdim=True)


def quat_conjugate(q: torch.Tensor) -> torch.Tensor:
    """Conjugate (the inverse of a unit quaternion) of ``(..., 4)`` xyzw quaternions."""
    q = _last(q, 4, "q")
    return torch.cat([-q[..., :3], q[..., 3:]], dim=-1)


def quat_multiply(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Hamilton product ``a * b`` of ``(..., 4)`` xyzw quaternions (broadcasting): rotates by ``b``, then ``a``."""
    return roma.quat_product(_last(a, 4, "a"), _last(b, 4, "b"))


def quat_apply(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """Rotate ``(..., 3)`` vectors by ``(..., 4)`` unit xyzw quaternions (broadcasting):
    ``v + w t + u x t`` with ``t = 2 u x v`` (the arithmetic of motionrep's compiled FK)."""
    q = _last(q, 4, "q")
    v = _last(v, 3, "v")
    if v.ndim < q.ndim:  # linalg.cross broadcasts over equal numbers of dimensions only
        v = v.reshape((1,) * (q.ndim - v.ndim) + v.shape)
    elif q.ndim < v.ndim:
        q = q.reshape((1,) * (v.ndim - q.ndim) + q.shape)
    u = q[..., :3]
    t = 2.0 * torch.linalg.cross(u, v, dim=-1)
    return v + q[..., 3:] * t + torch.linalg.cross(u, t, dim=-1)


def quat_to_matrix(q: torch.Tensor) -> torch.Tensor:
    """``(..., 4)`` xyzw quaternions (normalised first) to ``(..., 3, 3)`` rotation matrices."""
    return roma.unitquat_to_rotmat(quat_normalize(q))


def _positive_w(q: torch.Tensor) -> torch.Tensor:
    """The hemisphere rule: ``q`` with ``w >= 0`` (``-q`` where ``w < 0``)."""
    return torch.where(q[..., 3:] < 0, -q, q)


def matrix_to_quat(m: torch.Tensor) -> torch.Tensor:
    """``(..., 3, 3)`` rotation matrices to ``(..., 4)`` unit xyzw quaternions with ``w >= 0``.

    The input must be a rotation (project other matrices first, e.g. with ``roma.special_procrustes``).
    """
    if not isinstance(m, torch.Tensor) or m.ndim < 2 or m.shape[-2:] != (3, 3):
        raise ValidationError(f"m must be a tensor of shape (..., 3, 3), got {tuple(getattr(m, 'shape', ()))}")
    return _positive_w(roma.rotmat_to_unitquat(m))


def _angles(angles: torch.Tensor, order: str, degrees: bool) -> torch.Tensor:
    order = _check_order(order)
    angles = _last(angles, len(order), "angles")
    return angles * (math.pi / 180.0) if degrees else angles


def euler_to_quat(angles: torch.Tensor, order: str, degrees: bool = False) -> torch.Tensor:
    """Euler angles ``(..., len(order))`` to ``(..., 4)`` xyzw quaternions: the product of the per-axis
    half-angle quaternions (roma), not sign-canonicalised, as :func:`motionrep.model.rotations.euler_to_quat`."""
    a = _angles(angles, order, degrees)
    return roma.euler_to_unitquat(order, a, normalize=False)


def euler_to_matrix(angles: torch.Tensor, order: str, degrees: bool = False) -> torch.Tensor:
    """Euler angles ``(..., len(order))`` to ``(..., 3, 3)`` rotation matrices."""
    return roma.unitquat_to_rotmat(euler_to_quat(angles, order, degrees))


def quat_to_euler(q: torch.Tensor, order: str, degrees: bool = False) -> torch.Tensor:
    """``(..., 4)`` xyzw quaternions to Euler angles ``(..., len(order))``, as :func:`motionrep.model.rotations.quat_to_euler`.

    Three-axis orders: scipy's solution (roma's, the same algorithm), the middle angle in [-90, 90] degrees for
    Tait-Bryan orders.  One- and two-axis orders: of the two solutions of the order completed to three axes, the
    one whose missing angles are zero (the rotation must be expressible with those axes; not checked here, as it
    cannot be in a differentiable function; numpy's version raises).  Angles lie in [-180, 180) degrees except at
    the wrap.  Gradients are undefined at gimbal lock (middle angle at +-90 degrees), where the angles are.
    """
    order = _check_order(order)
    q = _last(q, 4, "q")
    full = _complete_order(order)
    e1 = torch.stack(roma.unitquat_to_euler(full, quat_normalize(q), as_tuple=True), dim=-1)
    n = len(order)
    if n < 3:
        half = math.pi
        middle = -e1[..., 1] if full[0].upper() == full[2].upper() else half - e1[..., 1]
        e2 = torch.stack([e1[..., 0] + half, middle, e1[..., 2] + half], dim=-1)
        e2 = torch.remainder(e2 + half, 2 * half) - half
        wrap = lambda e: torch.remainder(e[..., n:] + half, 2 * half) - half  # noqa: E731
        first = wrap(e1).abs().sum(-1, keepdim=True) <= wrap(e2).abs().sum(-1, keepdim=True)
        e1 = torch.where(first, e1, e2)[..., :n]
    return e1 * (180.0 / math.pi) if degrees else e1


def axis_angle_to_quat(v: torch.Tensor) -> torch.Tensor:
    """``(..., 3)`` rotation vectors to ``(..., 4)`` xyzw quaternions ``[sin(theta / 2) n, cos(theta / 2)]``
    (roma; not sign-canonicalised: ``theta > pi`` gives ``w < 0``, as numpy)."""
    return roma.rotvec_to_unitquat(_last(v, 3, "v"))


def quat_to_axis_angle(q: torch.Tensor) -> torch.Tensor:
    """``(..., 4)`` xyzw quaternions (normalised first) to ``(..., 3)`` rotation vectors, angle in [0, pi]
    (``q`` read with ``w >= 0``, as :func:`motionrep.model.rotations.quat_to_axis_angle`).

    ``v = u * 2 atan2(|u|, w) / |u|`` with ``u`` the vector part; below ``|u| = 1e-6`` the factor is its series
    ``(2 / w) (1 - |u|**2 / (3 w**2))``, so the gradient at the identity is finite (2 / w times the identity).
    """
    q = _positive_w(quat_normalize(_last(q, 4, "q")))
    u, w = q[..., :3], q[..., 3:]
    s2 = (u * u).sum(-1, keepdim=True)
    small = s2 < _SMALL ** 2
    s = torch.sqrt(torch.where(small, torch.ones_like(s2), s2))
    w_safe = torch.where(small, w, torch.ones_like(w))
    factor = torch.where(small, (2.0 / w_safe) * (1.0 - s2 / (3.0 * w_safe * w_safe)),
                         2.0 * torch.atan2(s, w) / s)
    return u * factor


def quat_make_continuous(q: torch.Tensor) -> torch.Tensor:
    """Flip the signs of ``(F, ..., 4)`` quaternions so consecutive frames have dot >= 0 (the signs are chosen
    from the values, not differentiated; the flips are exactly numpy's)."""
    q = _last(q, 4, "q")
    if q.ndim < 2:
        raise ValidationError(f"q must have shape (frames, ..., 4), got {tuple(q.shape)}")
    if q.shape[0] < 2:
        return q.clone()
    with torch.no_grad():
        flips = torch.where((q[1:] * q[:-1]).sum(-1) < 0, -1.0, 1.0).to(q.dtype)
        signs = torch.cat([torch.ones_like(flips[:1]), torch.cumprod(flips, dim=0)], dim=0)
    return q * signs[..., None]


def quat_to_ortho6d(q: torch.Tensor) -> torch.Tensor:
    """``(..., 4)`` xyzw quaternions to the ``(..., 6)`` 6D encoding: the first two matrix columns."""
    m = quat_to_matrix(q)
    return torch.cat([m[..., :, 0], m[..., :, 1]], dim=-1)


def ortho6d_to_matrix(d6: torch.Tensor) -> torch.Tensor:
    """``(..., 6)`` 6D encodings (two columns) to ``(..., 3, 3)`` rotation matrices by Gram-Schmidt, the cross
    product third (roma's ``special_gramschmidt``, which works on columns as Zhou et al.)."""
    d6 = _last(d6, 6, "d6")
    return roma.special_gramschmidt(torch.stack([d6[..., :3], d6[..., 3:]], dim=-1))


def ortho6d_to_quat(d6: torch.Tensor) -> torch.Tensor:
    """``(..., 6)`` 6D encodings to ``(..., 4)`` xyzw quaternions with ``w >= 0``."""
    return matrix_to_quat(ortho6d_to_matrix(d6))


def quat_slerp(q0: torch.Tensor, q1: torch.Tensor, t: torch.Tensor | float) -> torch.Tensor:
    """Spherical linear interpolation between unit xyzw quaternions along the shorter arc (roma);
    ``t`` broadcasts against ``q0[..., 0]``."""
    q0 = _last(q0, 4, "q0")
    q1 = _last(q1, 4, "q1")
    t = torch.as_tensor(t, dtype=q0.dtype, device=q0.device)
    shape = torch.broadcast_shapes(q0.shape, q1.shape, t.shape + (1,))
    q0, q1 = q0.expand(shape), q1.expand(shape)
    q1 = torch.where((q0 * q1).sum(-1, keepdim=True) < 0, -q1, q1)
    dot = (q0 * q1).sum(-1, keepdim=True).clamp(-1.0, 1.0)
    theta = torch.acos(dot)
    sin = torch.sin(theta)
    small = sin < 1e-9
    safe = torch.where(small, torch.ones_like(sin), sin)
    t = t[..., None].expand(shape[:-1] + (1,))
    w0 = torch.where(small, 1.0 - t, torch.sin((1.0 - t) * theta) / safe)
    w1 = torch.where(small, t, torch.sin(t * theta) / safe)
    return quat_normalize(w0 * q0 + w1 * q1)


def quat_xyzw_to_wxyz(q: torch.Tensor) -> torch.Tensor:
    """Reorder ``(..., 4)`` quaternions from xyzw to wxyz (pytorch3d's order)."""
    return roma.quat_xyzw_to_wxyz(_last(q, 4, "q"))


def quat_wxyz_to_xyzw(q: torch.Tensor) -> torch.Tensor:
    """Reorder ``(..., 4)`` quaternions from wxyz to motionrep's xyzw."""
    return roma.quat_wxyz_to_xyzw(_last(q, 4, "q"))
