"""Forward kinematics and character height.

Positions are in the file's units; global rotations are matrices ``(..., 3, 3)`` acting on column vectors or,
through :attr:`FKResult.rotations`, ``(..., 4)`` xyzw quaternions.  Points are ordered joints first (``J``), then
end sites (``E``), so every array over points has ``J + E`` entries.

FK composes unit quaternions (normalised first, so the result is exactly the pose the rotations stand for) in one
compiled loop over frames and joints (``motionrep._ccore``, C: ``motionrep/_c/fk.c``): per joint one quaternion
product and one vector rotation, in float64, each operation IEEE (no fused multiply-add, no fast-math), so the
same bits on every x86-64 CPU.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from .._ccore import fk as _fk_kernel
from ._pose import Motion, Skeleton
from .rotations import matrix_to_quat

__all__ = ["FKResult", "forward_kinematics", "global_positions", "rest_positions", "character_height",
           "point_names", "quat_to_matrix_fast", "fk_arrays"]


@dataclass(frozen=True)
class FKResult:
    """Global pose of every joint and end site.

    Attributes:
        positions: ``(F, J + E, 3)`` world positions (joints, then end sites).
        matrices: ``(F, J + E, 3, 3)`` world rotation matrices; an end site has its joint's rotation.
    """

    positions: NDArray[np.float64]
    matrices: NDArray[np.float64]

    @cached_property
    def rotations(self) -> NDArray[np.float64]:
        """``(F, J + E, 4)`` world rotations as unit xyzw quaternions (w >= 0)."""
        return matrix_to_quat(self.matrices)


def quat_to_matrix_fast(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(..., 4)`` unit xyzw quaternions to ``(..., 3, 3)`` matrices, without normalising or checking.

    The FK hot path; use :func:`motionrep.model.rotations.quat_to_matrix` for arbitrary input.
    """
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    m = np.empty(q.shape[:-1] + (3, 3))
    m[..., 0, 0] = 1 - 2 * (yy + zz)
    m[..., 0, 1] = 2 * (xy - wz)
    m[..., 0, 2] = 2 * (xz + wy)
    m[..., 1, 0] = 2 * (xy + wz)
    m[..., 1, 1] = 1 - 2 * (xx + zz)
    m[..., 1, 2] = 2 * (yz - wx)
    m[..., 2, 0] = 2 * (xz - wy)
    m[..., 2, 1] = 2 * (yz + wx)
    m[..., 2, 2] = 1 - 2 * (xx + yy)
    return m


def _fk(motion: Motion, want_rotations: bool) -> tuple[NDArray, NDArray | None]:
    """World positions ``(F, J + E, 3)`` and, if asked, world rotations ``(F, J + E, 4)`` (xyzw, w >= 0)."""
    sk = motion.skeleton
    return fk_arrays(sk, motion.rotations, motion.root_translation, motion.joint_translations, want_rotations)


def fk_arrays(skeleton: Skeleton, rotations: NDArray, root_translation: NDArray,
              joint_translations: NDArray, want_rotations: bool = False) -> tuple[NDArray, NDArray | None]:
    """FK of pose arrays without building a :class:`~motionrep.Motion` (the runtime decoder's path).

    Args:
        skeleton: the skeleton.
        rotations: ``(F, J, 4)`` local xyzw rotations, float32 or float64 (normalised here; arithmetic in
            float64).
        root_translation: ``(F, 3)``.
        joint_translations: ``(F, P, 3)`` local translations of ``skeleton.translated_joints``.
        want_rotations: also return world rotations.

    Returns:
        ``(F, J + E, 3)`` float64 world positions and ``(F, J + E, 4)`` world rotations (w >= 0) or None.
    """
    F, J, E = rotations.shape[0], skeleton.num_joints, skeleton.num_end_sites
    out_pos = np.empty((F, J + E, 3))
    out_rot = np.empty((F, J + E, 4)) if want_rotations else None
    rot = np.ascontiguousarray(rotations)
    if rot.dtype not in (np.float32, np.float64):
        rot = rot.astype(np.float64)
    _fk_kernel(rot, np.ascontiguousarray(root_translation, np.float64), skeleton.offsets, skeleton.parents,
               skeleton.translated_joints, np.ascontiguousarray(joint_translations, np.float64),
               skeleton.end_site_parents, skeleton.end_site_offsets, out_pos, out_rot)
    return out_pos, out_rot


def forward_kinematics(motion: Motion) -> FKResult:
    """Global positions and rotations of every joint and end site, for every frame.

    Rotations are normalised to unit length first (they are unit to 1e-6 in a valid Motion), so the result is
    exactly the pose the rotations stand for.

    Args:
        motion: the clip.

    Returns:
        :class:`FKResult` with ``positions (F, J + E, 3)`` and ``matrices (F, J + E, 3, 3)``.
    """
    pos, rot = _fk(motion, want_rotations=True)
    result = FKResult(pos, quat_to_matrix_fast(rot))
    result.__dict__["rotations"] = rot  # fills the cached property: no conversion back from the matrices
    return result


def global_positions(motion: Motion) -> NDArray[np.float64]:
    """``(F, J + E, 3)`` world positions of every joint then every end site (faster than full FK)."""
    return _fk(motion, want_rotations=False)[0]


def rest_positions(skeleton: Skeleton) -> NDArray[np.float64]:
    """``(J + E, 3)`` positions of the rest pose: zero rotations, every joint at its OFFSET (root included),
    position channels not applied."""
    J = skeleton.num_joints
    pos = np.zeros((J + skeleton.num_end_sites, 3))
    for j in range(J):
        p = skeleton.parents[j]
        pos[j] = skeleton.offsets[j] + (pos[p] if p >= 0 else 0.0)
    if skeleton.num_end_sites:
        pos[J:] = pos[skeleton.end_site_parents] + skeleton.end_site_offsets
    return pos


def character_height(skeleton: Skeleton) -> float:
    """The character's size: the largest extent over the three axes of the rest pose, end sites included.

    The rest pose has zero rotations and every joint at its OFFSET, with position channels *not* applied, so a
    file with position channels on every joint still has its real size.  Every error motionrep reports is
    also given as a percentage of this length.  A skeleton whose rest pose is a single point has height 0.
    """
    pos = rest_positions(skeleton)
    return float(np.max(pos.max(axis=0) - pos.min(axis=0)))


def point_names(skeleton: Skeleton) -> tuple[str, ...]:
    """Names of the ``J + E`` points FK returns: joint names, then ``"<joint>/End Site"`` (numbered when a joint
    has several end sites)."""
    counts: dict[int, int] = {}
    for p in skeleton.end_site_parents.tolist():
        counts[p] = counts.get(p, 0) + 1
    seen: dict[int, int] = {}
    sites = []
    for p in skeleton.end_site_parents.tolist():
        seen[p] = seen.get(p, 0) + 1
        suffix = f" {seen[p]}" if counts[p] > 1 else ""
        sites.append(f"{skeleton.names[p]}/End Site{suffix}")
    return skeleton.names + tuple(sites)
