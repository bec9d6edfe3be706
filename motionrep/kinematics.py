"""Forward kinematics and character height.

Positions are in the file's units; global rotations are matrices ``(..., 3, 3)`` acting on column vectors or,
through :attr:`FKResult.rotations`, ``(..., 4)`` xyzw quaternions.  Points are ordered joints first (``J``), then
end sites (``E``), so every array over points has ``J + E`` entries.

FK composes unit quaternions (normalised first, so the result is exactly the pose the rotations stand for),
vectorised over frames and over all joints of one depth of the tree: one quaternion product and one vector
rotation per tree level, on joint-major component arrays, a cache-sized chunk of frames at a time.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache

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
        """``(F, J + E, 4)`` world rotations as unit xyzw quaternions (w >= 0)."""
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


class _Plan:
    """Joints in tree-level order, so each level is a contiguous slice and FK writes results in place."""

    def __init__(self, parents: NDArray[np.int64], end_site_parents: NDArray[np.int64]):
        J = parents.shape[0]
        depth = np.zeros(J, np.int64)
        for j in range(1, J):
            depth[j] = depth[parents[j]] + 1
        self.order = np.argsort(depth, kind="stable")  # new index -> joint
        new_index = np.empty(J, np.int64)
        new_index[self.order] = np.arange(J)
        new_parents = new_index[parents[self.order][1:]]
        bounds = np.searchsorted(depth[self.order], np.arange(1, int(depth.max(initial=0)) + 2))
        self.levels = [(int(a), int(b), new_parents[a - 1:b - 1]) for a, b in zip(bounds[:-1], bounds[1:])]
        self.site_parents = new_index[end_site_parents]


@lru_cache(maxsize=64)
def _plan(parents: bytes, end_site_parents: bytes) -> _Plan:
    return _Plan(np.frombuffer(parents, np.int64), np.frombuffer(end_site_parents, np.int64))


#: Joint-frames per FK chunk: the temporaries stay in cache and their memory is reused.
_CHUNK_JOINT_FRAMES = 1 << 16


def _quat_mul_into(a, b, out) -> None:
    """Hamilton product ``a * b`` of xyzw component sequences into ``out`` (4 arrays), broadcasting."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    ox, oy, oz, ow = out
    np.multiply(aw, bx, out=ox)
    ox += ax * bw
    ox += ay * bz
    ox -= az * by
    np.multiply(aw, by, out=oy)
    oy -= ax * bz
    oy += ay * bw
    oy += az * bx
    np.multiply(aw, bz, out=oz)
    oz += ax * by
    oz -= ay * bx
    oz += az * bw
    np.multiply(aw, bw, out=ow)
    ow -= ax * bx
    ow -= ay * by
    ow -= az * bz


def _rotate_add_into(q, v, base, out) -> None:
    """``out = base + rotate(q, v)`` for unit xyzw quaternion components ``q`` and vector components ``v``."""
    qx, qy, qz, qw = q
    vx, vy, vz = v
    tx = qy * vz  # t = 2 (q_vec x v)
    tx -= qz * vy
    tx += tx
    ty = qz * vx
    ty -= qx * vz
    ty += ty
    tz = qx * vy
    tz -= qy * vx
    tz += tz
    for o, b, vc, tc, c1, t1, c2, t2 in ((out[0], base[0], vx, tx, qy, tz, qz, ty),
                                         (out[1], base[1], vy, ty, qz, tx, qx, tz),
                                         (out[2], base[2], vz, tz, qx, ty, qy, tx)):
        np.add(b, vc, out=o)  # out = base + v + w t + q_vec x t
        o += qw * tc
        o += c1 * t1
        o -= c2 * t2


def _fk_chunk(skeleton: Skeleton, plan: _Plan, rot: NDArray, trans: NDArray | None, out_pos: NDArray,
              out_rot: NDArray | None) -> None:
    """FK for a few frames, joint-major inside (``(component, J, frame)`` arrays), joints in tree-level order.

    Args:
        rot: ``(m, J, 4)`` local rotations (xyzw).
        trans: ``(m, J, 3)`` local translations, or None when only the root moves (then ``out_pos[:, 0]``
            already holds the root translation and other joints use their OFFSETs).
        out_pos: ``(m, J + E, 3)`` filled with world positions.
        out_rot: ``(m, J + E, 4)`` filled with world rotations (xyzw) if given.
    """
    J = skeleton.num_joints
    order = plan.order
    m = rot.shape[0]
    q = np.empty((4, J, m))
    for c in range(4):
        q[c] = rot[:, :, c].T
    q /= np.sqrt(np.einsum("cjm,cjm->jm", q, q))  # exactly unit: FK of the rotation each one stands for
    g = np.empty_like(q)  # world rotations, in level order
    p = np.empty((3, J, m))  # world positions, in level order
    root = order[0]
    g[:, 0] = q[:, root]
    if trans is None:
        p[:, 0] = out_pos[:, 0].T
        local = skeleton.offsets[order].T[:, :, None]
    else:
        local = np.empty((3, J, m))
        for c in range(3):
            local[c] = trans[:, :, c].T
        local = local[:, order]
        p[:, 0] = local[:, 0]
    for a, b, par in plan.levels:
        gp = g[:, par]
        _rotate_add_into(gp, local[:, a:b], p[:, par], p[:, a:b])
        _quat_mul_into(gp, q[:, order[a:b]], g[:, a:b])
    back = np.empty(J, np.int64)
    back[order] = np.arange(J)
    pj = p[:, back]
    for c in range(3):
        out_pos[:, :J, c] = pj[c].T
    E = skeleton.num_end_sites
    if E:
        sp = plan.site_parents
        ge = g[:, sp]
        site = np.empty((3, E, m))
        _rotate_add_into(ge, skeleton.end_site_offsets.T[:, :, None], p[:, sp], site)
        for c in range(3):
            out_pos[:, J:, c] = site[c].T
    if out_rot is not None:
        gj = g[:, back]
        for c in range(4):
            out_rot[:, :J, c] = gj[c].T
        if E:
            out_rot[:, J:] = out_rot[:, skeleton.end_site_parents]


def _fk(motion: Motion, want_rotations: bool) -> tuple[NDArray, NDArray | None]:
    """World positions ``(F, J + E, 3)`` and, if asked, world rotations ``(F, J + E, 4)`` (xyzw)."""
    sk = motion.skeleton
    F, J, E = motion.num_frames, sk.num_joints, sk.num_end_sites
    out_pos = np.empty((F, J + E, 3))
    out_rot = np.empty((F, J + E, 4)) if want_rotations else None
    moving = sk.translated_joints.size > 0
    if not moving:
        out_pos[:, 0] = motion.root_translation
    plan = _plan(sk.parents.tobytes(), sk.end_site_parents.tobytes())
    step = max(1, _CHUNK_JOINT_FRAMES // J)
    trans = None
    for a in range(0, F, step):
        b = min(F, a + step)
        if moving:
            trans = np.broadcast_to(sk.offsets, (b - a, J, 3)).copy()
            trans[:, 0] = motion.root_translation[a:b]
            trans[:, sk.translated_joints] = motion.joint_translations[a:b]
        _fk_chunk(sk, plan, motion.rotations[a:b], trans, out_pos[a:b], None if out_rot is None else out_rot[a:b])
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
    rot *= np.where(rot[..., 3:] < 0, -1.0, 1.0)  # w >= 0, as matrix_to_quat gives
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
