"""The compiled kernels of the closed loop (``motionrep._ccore.chain_pose`` / ``chain_targets``, C:
``motionrep/_c/chain.c``) against the numpy code they replace (kept here as the reference; the pose's conversions
against ``motionrep.model.rotations``' column conversions, which chain.py called before the kernel did).

Compared bit for bit: the kernels are scalar IEEE arithmetic compiled without FMA contraction or fast-math
(setup.py), in numpy's operation order (left to right, sums over the last axis ``((x0 + x1) + x2) + x3``), with the
same libm ``sqrt`` / ``rint`` / ``atan2`` (the rotation vector as scipy's, but ``angle / sin(angle / 2)`` taken as
``angle / s``, ``s`` the normalised quaternion's vector length: no libm ``sin``); numpy's elementwise
arithmetic and these sums are IEEE operations in that order too, on any CPU (no BLAS), so equal bits are the
contract, not an accident of this machine."""

from __future__ import annotations

import math

import numpy as np
import pytest

from motionrep._ccore import chain_pose, chain_targets
from motionrep.model.kinematics import forward_kinematics
from motionrep.model.rotations import axis_angle_columns_to_quat, quat_columns_normalized
from motionrep.model.synthetic import chain_skeleton, synthetic_motion
from motionrep.pipeline.evaluate import MotionContext
from motionrep.plugin.registry import get_codec, get_representation


def _cross(a, b):
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def _qmul(a, b):
    ax, ay, az, aw = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bx, by, bz, bw = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = aw * bx + ax * bw + ay * bz - az * by
    out[..., 1] = aw * by - ax * bz + ay * bw + az * bx
    out[..., 2] = aw * bz + ax * by - ay * bx + az * bw
    out[..., 3] = aw * bw - ax * bx - ay * by - az * bz
    return out


def _qapply(q, v):
    u, w = q[..., :3], q[..., 3:]
    t = 2.0 * _cross(u, v)
    return v + w * t + _cross(u, t)


def _rotation_vector(q):
    """The targets' rotation vector of quaternions ``(..., 4)``: scipy's steps (normalised, the canonical sign, angle
    ``2 atan2(s, w)`` with libm's atan2 through Python's math, the series below 1e-3) but ``angle / s`` for
    ``angle / sin(angle / 2)``, ``s`` the length of the normalised x, y, z (chain.c: no libm sin)."""
    n = np.sqrt(((q[..., 0] * q[..., 0] + q[..., 1] * q[..., 1]) + q[..., 2] * q[..., 2]) + q[..., 3] * q[..., 3])
    u = q / n[..., None]
    x, y, z, w = u[..., 0], u[..., 1], u[..., 2], u[..., 3]
    flip = (w < 0) | ((w == 0) & ((x < 0) | ((x == 0) & ((y < 0) | ((y == 0) & (z < 0))))))
    u = np.where(flip[..., None], -u, u)
    s = np.sqrt((u[..., 0] * u[..., 0] + u[..., 1] * u[..., 1]) + u[..., 2] * u[..., 2])
    angle = 2.0 * np.array([math.atan2(a, b) for a, b in zip(s.ravel(), u[..., 3].ravel())]).reshape(s.shape)
    a2 = angle * angle
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(angle <= 1e-3, (2.0 + a2 / 12.0) + 7.0 * a2 * a2 / 2880.0, angle / s)
    return scale[..., None] * u[..., :3]


def _nearest_branch(v, near):
    theta = np.sqrt(np.sum(v * v, axis=-1))
    ok = theta > 1e-12
    n = v / np.where(ok, theta, 1.0)[..., None]
    k = np.rint((np.sum(n * near, axis=-1) - theta) / (2.0 * np.pi))
    return np.where(ok[..., None], n * (theta + 2.0 * np.pi * k)[..., None], 0.0)


def _reference_pose(decoded, local, js, parents, tcols, tvals, rot, pos):
    """chain.py's numpy pose of one depth (before the kernel)."""
    local = local.transpose(1, 0, 2)
    t = np.where(tcols >= 0, decoded[:, np.maximum(tcols, 0)], tvals).transpose(1, 0, 2)
    if parents[0] < 0:
        rot[js], pos[js] = local, t
    else:
        g = rot[parents]
        rot[js] = _qmul(g, local)
        pos[js] = pos[parents] + _qapply(g, t)


def _reference_targets(rot, pos, parents, true_rot, lever, local_offset, true_pos, a, na, kind, at, truth, out):
    """chain.py's numpy targets of one depth (before the kernel)."""
    i = np.flatnonzero(lever >= 0)
    g_parent = rot[parents]
    want = true_rot.copy()
    if i.size:
        here = pos[parents[i]] + _qapply(g_parent[i], local_offset)
        b = a + true_pos - here
        nb = np.sqrt(np.sum(b * b, axis=-1))
        turn = np.concatenate([_cross(a, b), (na * nb + np.sum(a * b, axis=-1))[..., None]], axis=-1)
        size = np.sqrt(np.sum(turn * turn, axis=-1))
        ok = size > 1e-12 * np.maximum(na * nb, 1e-300)
        turn = np.where(ok[..., None], turn / np.where(ok, size, 1.0)[..., None], np.array([0.0, 0.0, 0.0, 1.0]))
        want[i] = _qmul(turn, want[i])
    local = _qmul(g_parent * np.array([-1.0, -1.0, -1.0, 1.0]), want)
    for k in (0, 1):
        rows = np.flatnonzero(kind == k)
        if not rows.size:
            continue
        if k == 0:
            q, near = local[rows], truth[rows]
            v = np.where(np.sum(q * near, axis=2, keepdims=True) < 0, -q, q)
            out[:, at[rows]] = v.transpose(1, 0, 2)
        else:
            v = _nearest_branch(_rotation_vector(local[rows]), truth[rows, :, :3])
            out[:, at[rows, :3]] = v.transpose(1, 0, 2)


def _unit(rng, shape):
    q = rng.normal(size=shape + (4,))
    return q / np.sqrt(np.sum(q * q, axis=-1, keepdims=True))


def _depth(rng, F=37, J=7, n=5):
    """A random state of J joints, a depth of n joints (the last two of them rotation vectors) whose first three
    have levers, in their first 5 frames (parents unrotated, integer coordinates: exact arithmetic) one of zero
    length, one whose joint sits on its true point (a zero vector to point along), one pointing straight back (the
    half-way quaternion is zero): each of those keeps its true rotation there."""
    rot, pos = _unit(rng, (J, F)), rng.normal(size=(J, F, 3)) * 20
    parents = np.concatenate([[0, 1, 2], rng.integers(0, J, n - 3)])
    lever = np.array([0, 1, 2, -1, -1], np.int64)
    local_offset, true_pos, a = (rng.normal(size=(3, F, 3)) * 10 for _ in range(3))
    rot[:3, :5] = [0.0, 0.0, 0.0, 1.0]
    pos[:3, :5] = rng.integers(-9, 9, (3, 5, 3))
    local_offset[:, :5] = rng.integers(-9, 9, (3, 5, 3))
    a[0, :5], a[1:, :5] = 0.0, [3.0, 4.0, 0.0]
    here = pos[:3, :5] + local_offset[:, :5]
    true_pos[1, :5] = here[1] - a[1, :5]  # b = 0
    true_pos[2, :5] = here[2] - 3.0 * a[2, :5]  # b = -2 a
    na = np.sqrt(np.sum(a * a, axis=-1))
    kind = np.array([0, 0, 0, 1, 1], np.int64)
    at = np.array([[0, 1, 2, 3], [4, 5, 6, 7], [8, 9, 10, 11], [12, 13, 14, -1], [15, 16, 17, -1]], np.int64)
    truth = rng.normal(size=(n, F, 4)) * 3
    return (rot, pos, parents, _unit(rng, (n, F)), lever, local_offset, true_pos, a, na, kind, at, truth)


def test_targets_kernel_is_the_numpy_code_bit_for_bit():
    """Clips of 37 frames, 150 (blocks of 64 frames and a remainder) and one; the degenerate levers."""
    rng = np.random.default_rng(5)
    for F in (37, 150, 5, 37):
        args = _depth(rng, F)
        F = args[0].shape[1]
        got, want = np.full((F, 18), 7.0), np.full((F, 18), 7.0)
        assert chain_targets(*args, got) == -1
        _reference_targets(*args, want)
        np.testing.assert_array_equal(got.view(np.int64), want.view(np.int64))
    # the degenerate levers' first frames: no turn, as without a lever; the others turned
    plain, unturned = list(args), np.full((F, 18), 7.0)
    plain[4] = np.full(5, -1, np.int64)
    chain_targets(*plain, unturned)
    np.testing.assert_array_equal(got[:5, :12], unturned[:5, :12])
    assert np.all(got[5:, :12] != unturned[5:, :12])
    one = [x[:, :1] if k in (0, 1, 3, 5, 6, 7, 8, 11) else x for k, x in enumerate(_depth(rng, 150))]
    one = [np.ascontiguousarray(x) for x in one]
    got, want = np.full((1, 18), 7.0), np.full((1, 18), 7.0)
    assert chain_targets(*one, got) == -1
    _reference_targets(*one, want)
    np.testing.assert_array_equal(got.view(np.int64), want.view(np.int64))


def test_targets_kernel_finds_the_first_local_rotation_of_zero_length():
    """A rotation vector's local rotation of zero length (its true rotation zero) returns ``i F + f`` of the first
    (joints in turn, frames in order, across blocks of frames and with a frames index)."""
    rng = np.random.default_rng(9)
    F = 150
    args = list(_depth(rng, F))
    true_rot = args[3].copy()
    true_rot[4, [100, 7]] = 0.0
    true_rot[3, 130] = 0.0
    args[3] = true_rot
    out = np.zeros((F, 18))
    assert chain_targets(*args, out) == 3 * F + 130
    assert chain_targets(*args, out, np.array([7, 100, 120], np.int64)) == 4 * F + 7
    assert chain_targets(*args, out, np.array([8, 99], np.int64)) == -1
    true_rot[3, 130], true_rot[4, [100, 7]] = 0.5, 0.5
    true_rot[0, 3] = 0.0  # a quaternion target of zero length is no error: it is written as it is
    assert chain_targets(*args, out) == -1 and np.all(out[3, :4] == 0.0)


def _reference_local(decoded, kinds, rcols):
    """``(F, n, 4)`` the local rotations chain.py converted before the kernel did: motionrep.model.rotations'
    column conversions (their own compiled loops), the identity for a joint without an entry."""
    local = np.zeros((decoded.shape[0], kinds.size, 4))
    local[..., 3] = 1.0
    for kind, width, convert in ((0, 4, quat_columns_normalized), (1, 3, axis_angle_columns_to_quat)):
        i = np.flatnonzero(kinds == kind)
        if i.size:
            convert(decoded, rcols[i, :width], i, local)
    return local


def test_pose_kernel_is_the_numpy_code_bit_for_bit():
    """The conversions (mr_rotconv.h in chain.c's loop) against motionrep.model.rotations' (rotations.c's loop),
    the pose against numpy; every frame, a subset of frames (only those written), one frame; both compiled copies
    of the kernel where the CPU has AVX2 (test_ccore runs the module under MOTIONREP_CCORE_BASELINE too)."""
    rng = np.random.default_rng(6)
    F, J, D = 131, 9, 20
    decoded = rng.normal(size=(F, D)) * 2.0
    decoded[:7, 10:13] *= 1e-4  # rotation vectors below 1e-3 rad: the series
    rot, pos = _unit(rng, (J, F)), rng.normal(size=(J, F, 3))
    depths = ((np.array([0]), np.array([-1]), np.array([0]), np.array([[6, 7, 8, 9]])),
              (np.array([3, 5, 6, 8]), np.array([0, 0, 1, 1]), np.array([1, 0, -1, 1]),
               np.array([[10, 11, 12, 0], [14, 15, 16, 17], [0, 0, 0, 0], [17, 18, 19, 0]])))
    for js, parents, kinds, rcols in depths:
        tcols = np.array([[0, 1, 2], [-1, -1, -1], [4, -1, 5], [-1, 3, -1]][:js.size], np.int64)
        tvals = rng.normal(size=(js.size, 3))
        got_r, got_p, want_r, want_p = rot.copy(), pos.copy(), rot.copy(), pos.copy()
        assert chain_pose(decoded, kinds, rcols, js, parents, tcols, tvals, got_r, got_p) == 0
        local = _reference_local(decoded, kinds, rcols)
        _reference_pose(decoded, local, js, parents, tcols, tvals, want_r, want_p)
        np.testing.assert_array_equal(got_r.view(np.int64), want_r.view(np.int64))
        np.testing.assert_array_equal(got_p.view(np.int64), want_p.view(np.int64))
        for frames in (np.array([0, 5, 64, 65, 130], np.int64), np.array([77], np.int64)):
            sub_r, sub_p = np.full_like(rot, 9.0), np.full_like(pos, 9.0)
            sub_r[parents[parents >= 0]], sub_p[parents[parents >= 0]] = rot[parents[parents >= 0]], pos[
                parents[parents >= 0]]
            assert chain_pose(decoded, kinds, rcols, js, parents, tcols, tvals, sub_r, sub_p, frames) == 0
            np.testing.assert_array_equal(sub_r[js][:, frames].view(np.int64), want_r[js][:, frames].view(np.int64))
            np.testing.assert_array_equal(sub_p[js][:, frames].view(np.int64), want_p[js][:, frames].view(np.int64))
            assert np.all(np.delete(sub_r[js], frames, axis=1) == 9.0)
        one_r, one_p = rot[:, :1].copy(), pos[:, :1].copy()  # a clip of one frame
        chain_pose(decoded[:1], kinds, rcols, js, parents, tcols, tvals, one_r, one_p)
        np.testing.assert_array_equal(one_r[js].view(np.int64), want_r[js][:, :1].view(np.int64))
        rot, pos = got_r, got_p


def test_pose_kernel_counts_quaternions_of_zero_length():
    rng = np.random.default_rng(8)
    F, J = 70, 3
    decoded = rng.normal(size=(F, 8))
    decoded[[2, 66], 0:4] = 0.0
    decoded[40, 4:8] = 0.0
    rot, pos = np.zeros((J, F, 4)), np.zeros((J, F, 3))
    args = (np.array([0, 0]), np.array([[0, 1, 2, 3], [4, 5, 6, 7]]), np.array([0, 1]), np.array([-1, -1]),
            np.full((2, 3), -1), np.zeros((2, 3)), rot, pos)
    assert chain_pose(decoded, *args) == 3
    assert chain_pose(decoded, *args, np.array([1, 40, 41], np.int64)) == 1
    assert chain_pose(decoded, *args, np.array([1, 41], np.int64)) == 0


def test_kernels_refuse_wrong_shapes_and_indices():
    rng = np.random.default_rng(7)
    args = list(_depth(rng))
    out = np.zeros((args[0].shape[1], 18))
    with pytest.raises(ValueError):
        chain_targets(*args, np.zeros((out.shape[0], 10)))  # at outside out
    bad = list(args)
    bad[2] = np.array([0, 1, 2, 3, 99])  # a parent outside the state
    with pytest.raises(ValueError):
        chain_targets(*bad, out)
    with pytest.raises(TypeError):
        chain_targets(*args[:-1], args[-1].astype(np.float32), out)
    F = 4
    with pytest.raises(ValueError):
        chain_pose(np.zeros((F, 3)), np.array([-1]), np.zeros((1, 4), np.int64), np.array([0]), np.array([-1]),
                   np.array([[0, 1, 5]]), np.zeros((1, 3)), np.zeros((2, F, 4)), np.zeros((2, F, 3)))  # a column
    with pytest.raises(ValueError):  # a rotation column outside decoded
        chain_pose(np.zeros((F, 3)), np.array([1]), np.array([[0, 1, 3, 0]]), np.array([0]), np.array([-1]),
                   np.full((1, 3), -1), np.zeros((1, 3)), np.zeros((2, F, 4)), np.zeros((2, F, 3)))


def test_a_165_joint_chain_closes_the_loop():
    """A deep skeleton (165 joints in one chain: every joint position feedback, 164 depths): decoded with every
    rotation off, each depth decoded as its targets puts every point where it belongs."""
    sk = chain_skeleton(165, bone=1.0)
    m = synthetic_motion(sk, frames=12, fps=30, seed=4)
    rep, codec = get_representation("root-quat-axis-angle"), get_codec("transform")
    ctx = MotionContext(m, rep, codec, codec.parse_params({}), 1.0, 0, None)
    f = rep.to_features(m)
    chain = ctx.feature_chain(f)
    assert len(chain.groups) == 165
    out = f + np.random.default_rng(1).normal(0.0, 0.01, f.shape)
    for g, cols in enumerate(chain.groups):
        out[:, cols] = chain.targets(g, out)
    got = forward_kinematics(rep.from_features(out, sk, m.fps)).positions
    np.testing.assert_allclose(got, forward_kinematics(m).positions, atol=1e-6)
