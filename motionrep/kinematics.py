"""Forward kinematics and character height.

Positions are in the file's units; global rotations are matrices ``(..., 3, 3)`` acting on column vectors or,
through :attr:`FKResult.rotations`, ``(..., 4)`` xyzw quaternions.  Points are ordered joints first (``J``), then
end sites (``E``), so every array over points has ``J + E`` entries.

FK is vectorised over frames and over all joints of one depth of the tree: one matrix product per tree level,
not per joint or per frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from ._model import Motion, Skeleton
from .rotations import matrix_to_quat

__all__ = ["FKResult", "forward_kinematics", "global_positions", "rest_positions", "character_height",
           "point_names", "quat_to_matrix_fast"]


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
        """``(F, J + E, 4)`` world rotations as unit xyzw quaternions."""
        return matrix_to_quat(self.matrices)


def quat_to_matrix_fast(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(..., 4)`` unit xyzw quaternions to ``(..., 3, 3)`` matrices, without normalising or checking.

    The FK hot path; use :func:`motionrep.rotations.quat_to_matrix` for arbitrary input.
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


def _levels(parents: NDArray[np.int64]) -> list[NDArray[np.int64]]:
    depth = np.zeros(parents.shape[0], np.int64)
    for j in range(1, parents.shape[0]):
        depth[j] = depth[parents[j]] + 1
    return [np.nonzero(depth == d)[0] for d in range(1, int(depth.max(initial=0)) + 1)]


def _fk(skeleton: Skeleton, local_rot: NDArray, local_trans: NDArray, want_matrices: bool):
    """Core FK on joint-major arrays.

    Args:
        local_rot: ``(J, F, 3, 3)`` local rotation matrices.
        local_trans: ``(J, F, 3)`` local translations.

    Returns:
        positions ``(F, J + E, 3)`` and, if asked, matrices ``(F, J + E, 3, 3)``.
    """
    J, F = local_rot.shape[:2]
    parents = skeleton.parents
    g_rot = np.empty_like(local_rot)
    g_pos = np.empty_like(local_trans)
    g_rot[0] = local_rot[0]
    g_pos[0] = local_trans[0]
    for idx in _levels(parents):
        par = parents[idx]
        pr = g_rot[par]
        g_rot[idx] = pr @ local_rot[idx]
        g_pos[idx] = g_pos[par] + (pr @ local_trans[idx][..., None])[..., 0]
    E = skeleton.num_end_sites
    esp = skeleton.end_site_parents
    out_pos = np.empty((F, J + E, 3))
    out_pos[:, :J] = g_pos.transpose(1, 0, 2)
    if E:
        site = g_pos[esp] + np.einsum("efij,ej->efi", g_rot[esp], skeleton.end_site_offsets)
        out_pos[:, J:] = site.transpose(1, 0, 2)
    if not want_matrices:
        return out_pos, None
    out_rot = np.empty((F, J + E, 3, 3))
    out_rot[:, :J] = g_rot.transpose(1, 0, 2, 3)
    if E:
        out_rot[:, J:] = g_rot[esp].transpose(1, 0, 2, 3)
    return out_pos, out_rot


def _joint_major_inputs(motion: Motion) -> tuple[NDArray, NDArray]:
    sk = motion.skeleton
    local_rot = quat_to_matrix_fast(np.ascontiguousarray(motion.rotations.transpose(1, 0, 2)))
    trans = np.empty((sk.num_joints, motion.num_frames, 3))
    trans[:] = sk.offsets[:, None, :]
    trans[0] = motion.root_translation
    if sk.translated_joints.size:
        trans[sk.translated_joints] = motion.joint_translations.transpose(1, 0, 2)
    return local_rot, trans


def forward_kinematics(motion: Motion) -> FKResult:
    """Global positions and rotations of every joint and end site, for every frame.

    Args:
        motion: the clip.

    Returns:
        :class:`FKResult` with ``positions (F, J + E, 3)`` and ``matrices (F, J + E, 3, 3)``.
    """
    pos, rot = _fk(motion.skeleton, *_joint_major_inputs(motion), want_matrices=True)
    return FKResult(pos, rot)


def global_positions(motion: Motion) -> NDArray[np.float64]:
    """``(F, J + E, 3)`` world positions of every joint then every end site (faster than full FK)."""
    return _fk(motion.skeleton, *_joint_major_inputs(motion), want_matrices=False)[0]


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
