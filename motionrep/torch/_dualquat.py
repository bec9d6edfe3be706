"""Dual-quaternion algebra on torch tensors, the conventions of ``motionrep_dualquat``'s numpy algebra.

A dual quaternion is a ``(..., 8)`` tensor ``[real xyzw, dual xyzw]``; a unit one encodes "rotate by ``q_r``,
then translate by ``t``" with ``q_d = 1/2 t q_r`` (Andreou et al. 2022 eq. 6) and ``t = 2 q_d q_r*`` (eq. 8).
Shared by the ``dual-quaternion`` representation's torch path and the losses of eq. 14-16.
"""

from __future__ import annotations

import torch

from ..errors import ValidationError
from .rotations import quat_conjugate, quat_multiply

__all__ = ["dualquat_multiply", "dualquat_conjugate", "dualquat_normalize", "dualquat_from_rotation_translation",
           "dualquat_to_rotation_translation"]


def _dq(a: torch.Tensor, name: str) -> torch.Tensor:
    if not isinstance(a, torch.Tensor) or a.ndim == 0 or a.shape[-1] != 8:
        raise ValidationError(f"{name} must be a tensor of shape (..., 8) (real xyzw, dual xyzw), got "
                              f"{tuple(getattr(a, 'shape', ()))}")
    return a


def dualquat_multiply(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """``a b = a_r b_r + eps (a_r b_d + a_d b_r)`` (eq. 1; broadcasting): ``b``'s transform, then ``a``'s."""
    a, b = _dq(a, "a"), _dq(b, "b")
    ar, ad, br, bd = a[..., :4], a[..., 4:], b[..., :4], b[..., 4:]
    return torch.cat([quat_multiply(ar, br), quat_multiply(ar, bd) + quat_multiply(ad, br)], dim=-1)


def dualquat_conjugate(a: torch.Tensor) -> torch.Tensor:
    """``q_r* + eps q_d*``: the inverse of a unit dual quaternion."""
    a = _dq(a, "a")
    return torch.cat([quat_conjugate(a[..., :4]), quat_conjugate(a[..., 4:])], dim=-1)


def dualquat_normalize(a: torch.Tensor) -> torch.Tensor:
    """Eq. 13: ``q_r / |q_r| + eps (q_d / |q_r| - q_r <q_r, q_d> / |q_r|**3)`` (NaN for a zero real part)."""
    a = _dq(a, "a")
    r, d = a[..., :4], a[..., 4:]
    n = torch.linalg.vector_norm(r, dim=-1, keepdim=True)
    rn = r / n
    return torch.cat([rn, d / n - rn * ((r * d).sum(-1, keepdim=True) / (n * n))], dim=-1)


def dualquat_from_rotation_translation(q: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
    """``(..., 8)`` of "rotate by unit ``q`` ``(..., 4)``, then translate by ``t`` ``(..., 3)``" (eq. 6)."""
    if q.shape[-1:] != (4,) or t.shape[-1:] != (3,):
        raise ValidationError(f"q must be (..., 4) and t (..., 3), got {tuple(q.shape)} and {tuple(t.shape)}")
    pure = torch.cat([t, torch.zeros_like(t[..., :1])], dim=-1)
    d = 0.5 * quat_multiply(pure, q)
    return torch.cat([q.expand(d.shape), d], dim=-1)


def dualquat_to_rotation_translation(a: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Rotation ``(..., 4)`` (the real part) and translation ``2 q_d q_r*`` ``(..., 3)`` (eq. 8) of unit dual
    quaternions; normalise lossy ones with :func:`dualquat_normalize` first."""
    a = _dq(a, "a")
    r, d = a[..., :4], a[..., 4:]
    return r, 2.0 * quat_multiply(d, quat_conjugate(r))[..., :3]
