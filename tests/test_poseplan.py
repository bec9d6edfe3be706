"""motionrep.model.poseplan: one compiled pass from feature columns to poses, checked against scipy's conversions."""

from __future__ import annotations

import copy
import hashlib

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from motionrep.errors import ValidationError
from motionrep.model import poseplan as pp
from motionrep.model.poseplan import (AXIS_ANGLE, EULER, EULER_DEGREES, ORTHO6D, QUAT, WORLD_IDENTITY, WORLD_QUAT,
                                PosePlan, decode_planned)


def _plan(kinds, columns, axes=None, joints=None, J=None, parents=None, tcols=((0, 1, 2),), width=40):
    R = len(kinds)
    cols = np.full((R, 6), -1, np.int64)
    for r, c in enumerate(columns):
        cols[r, :len(c)] = c
    ax = np.full((R, 3), -1, np.int64)
    for r, a in enumerate(axes or [()] * R):
        ax[r, :len(a)] = a
    J = R if J is None else J
    tc = np.array(tcols, np.int64).reshape(-1, 3)
    return PosePlan(width=width, num_joints=J, kinds=np.array(kinds, np.int64), columns=cols, axes=ax,
                    joints=np.arange(R, dtype=np.int64) if joints is None else np.array(joints, np.int64),
                    parents=np.arange(J, dtype=np.int64) - 1 if parents is None else np.array(parents, np.int64),
                    translation_columns=tc, translation_values=np.zeros(tc.shape))


def _decode(plan, features, dtype=np.float64):
    T = features.shape[0]
    rotations = np.empty((T, plan.num_joints, 4), dtype)
    root = np.empty((T, 3))
    moved = np.empty((T, plan.num_translated, 3))
    decode_planned(features, plan, rotations, root, moved)
    return rotations, root, moved


def _canonical(q):
    return np.where(q[..., 3:] < 0, -q, q)


def test_every_kind_matches_scipy_and_joints_without_an_entry_are_the_identity():
    rng = np.random.default_rng(3)
    T = 150  # more than one sub-block of the kernel
    f = rng.normal(size=(T, 40)) * 2
    f[:5, 7:10] *= 1e-5  # rotation vectors near zero: the series
    plan = _plan([QUAT, AXIS_ANGLE, EULER_DEGREES, EULER, ORTHO6D, EULER_DEGREES],
                 [(3, 4, 5, 6), (7, 8, 9), (10, 11, 12), (13, 14), (15, 16, 17, 18, 19, 20), (21,)],
                 axes=[(), (), (2, 0, 1), (1, 2), (), (0,)], joints=[0, 1, 2, 3, 4, 6], J=8,
                 tcols=((0, 1, 2), (22, 23, -1)))
    rot, root, moved = _decode(plan, f)
    expected = {
        0: f[:, 3:7] / np.linalg.norm(f[:, 3:7], axis=1, keepdims=True),
        1: Rotation.from_rotvec(f[:, 7:10]).as_quat(),
        2: Rotation.from_euler("ZXY", f[:, 10:13], degrees=True).as_quat(),
        3: Rotation.from_euler("YZ", f[:, 13:15]).as_quat(),
        4: Rotation.from_matrix(_gram_schmidt(f[:, 15:21])).as_quat(),
        6: Rotation.from_euler("X", f[:, 21:22], degrees=True).as_quat(),
    }
    for j, q in expected.items():
        got = rot[:, j] if j in (0, 1) else _canonical(rot[:, j])
        q = q if j in (0, 1) else _canonical(q)
        np.testing.assert_allclose(got, q, rtol=0, atol=1e-12, err_msg=f"joint {j}")  # float64 ulps
    assert np.array_equal(rot[:, [5, 7]], np.broadcast_to([0.0, 0.0, 0.0, 1.0], (T, 2, 4)))
    assert np.array_equal(root, f[:, :3])
    assert np.array_equal(moved[:, 0, :2], f[:, 22:24]) and np.all(moved[:, 0, 2] == 0.0)
    # a pose decodes to the same bits alone; float32 rotations are the float64 ones rounded
    for i in (0, 77, T - 1):
        assert np.array_equal(_decode(plan, f[i:i + 1])[0][0], rot[i])
    assert np.array_equal(_decode(plan, f, np.float32)[0], rot.astype(np.float32))


def _gram_schmidt(d6):
    a1, a2 = d6[:, :3], d6[:, 3:]
    b1 = a1 / np.linalg.norm(a1, axis=1, keepdims=True)
    u2 = a2 - np.sum(b1 * a2, axis=1, keepdims=True) * b1
    b2 = u2 / np.linalg.norm(u2, axis=1, keepdims=True)
    return np.stack([b1, b2, np.cross(b1, b2)], axis=2)


def test_world_rotations_are_made_local_through_the_parents():
    rng = np.random.default_rng(5)
    f = rng.normal(size=(70, 12))
    parents = [-1, 0, 1]
    plan = _plan([WORLD_QUAT, WORLD_IDENTITY, WORLD_QUAT], [(3, 4, 5, 6), (), (7, 8, 9, 10)], parents=parents,
                 width=12)
    rot, _, _ = _decode(plan, f)
    g0 = Rotation.from_quat(f[:, 3:7])
    g2 = Rotation.from_quat(f[:, 7:11])
    np.testing.assert_allclose(_canonical(rot[:, 0]), _canonical(g0.as_quat()), atol=1e-12)
    np.testing.assert_allclose(_canonical(rot[:, 1]), np.broadcast_to([0, 0, 0, 1.0], (70, 4)), atol=1e-15)
    # joint 1 does not rotate: its world rotation is joint 0's; joint 2's local one is g0* g2
    np.testing.assert_allclose(_canonical(rot[:, 2]), _canonical((g0.inv() * g2).as_quat()), atol=1e-12)


def test_world_rotations_stay_unit_down_a_deep_chain():
    # a world rotation is its own r / |r|, not G_parent (G_parent* r): that product doubled the norm error per
    # level, overflowing by joint 60; every few joints does not rotate (WORLD_IDENTITY: its parent's rotation)
    J = 64
    kinds = [WORLD_IDENTITY if j % 7 == 3 else WORLD_QUAT for j in range(J)]
    columns = [() if k == WORLD_IDENTITY else tuple(range(3 + 4 * j, 7 + 4 * j)) for j, k in enumerate(kinds)]
    f = np.random.default_rng(6).normal(size=(100, 3 + 4 * J))
    rot, _, _ = _decode(_plan(kinds, columns, width=3 + 4 * J), f)
    # tolerance: a few roundings in one normalisation and one product per joint
    np.testing.assert_allclose(np.linalg.norm(rot, axis=-1), 1.0, rtol=0, atol=1e-12)
    world = Rotation.from_quat(f[:, 3:7])
    for j in range(1, J):
        g = world if kinds[j] == WORLD_IDENTITY else Rotation.from_quat(f[:, 3 + 4 * j:7 + 4 * j])
        np.testing.assert_allclose(_canonical(rot[:, j]), _canonical((world.inv() * g).as_quat()), atol=1e-12)
        world = g


@pytest.mark.parametrize("change, message", [
    (dict(kinds=[QUAT], columns=[(0, 1, 2)]), "must read 4 columns"),
    (dict(kinds=[QUAT], columns=[(0, 1, 2, 99)]), "must read 4 columns"),
    (dict(kinds=[9], columns=[(0,)]), "unknown conversion kind"),
    (dict(kinds=[EULER], columns=[(0, 1)], axes=[(0, 3)]), "axis 0-2"),
    (dict(kinds=[QUAT, QUAT], columns=[(0, 1, 2, 3), (4, 5, 6, 7)], joints=[1, 1], J=2), "different joint"),
    (dict(kinds=[WORLD_QUAT], columns=[(0, 1, 2, 3)], J=2), "one entry per joint"),
    (dict(kinds=[QUAT], columns=[(0, 1, 2, 3)], tcols=((0, 1, 40),)), "translation column"),
])
def test_a_plan_that_does_not_fit_is_refused(change, message):
    with pytest.raises(ValidationError, match=message):
        _plan(**change)


def test_bad_features_are_refused():
    plan = _plan([QUAT, ORTHO6D], [(3, 4, 5, 6), (7, 8, 9, 10, 11, 12)], width=13)
    f = np.random.default_rng(0).normal(size=(4, 13))
    with pytest.raises(ValidationError, match="shape"):
        _decode(plan, f[:, :12])
    bad = f.copy()
    bad[2, 5] = np.nan
    with pytest.raises(ValidationError, match="NaN or infinity"):
        _decode(plan, bad)
    bad = f.copy()
    bad[1, 3:7] = 0.0
    with pytest.raises(ValidationError, match="zero or non-finite length"):
        _decode(plan, bad)
    bad = f.copy()
    bad[3, 10:13] = 2 * bad[3, 7:10]  # parallel columns
    with pytest.raises(ValidationError, match="degenerate"):
        _decode(plan, bad)


@pytest.mark.parametrize("T", [1, 7, 8, 9, 16, 21, 64, 67, 130])
def test_nan_or_infinity_anywhere_in_a_planned_column_is_refused_and_nowhere_else(T):
    """The finiteness check (sums of x * 0 in eight lanes, then a compare per value for the last few of a column)
    finds NaN, inf and -inf at every position of every column the plan reads, lane and tail alike; refuses
    nothing for the largest finite values or for NaN in a column no entry reads."""
    rng = np.random.default_rng(T)
    plan = _plan([QUAT, AXIS_ANGLE], [(3, 4, 5, 6), (7, 8, 9)], width=12)
    f = rng.normal(size=(T, 12))
    f[:, 10] = np.nan  # read by nothing
    f[:, 0] = np.where(rng.random(T) < 0.5, 1.7976931348623157e308, -1.7976931348623157e308)  # root translation
    f[:, 7:10] = np.where(rng.random((T, 3)) < 0.3, 1.7976931348623157e308, f[:, 7:10])
    _decode(plan, f)  # (the rotation vectors' rotations are NaN: not finite features, nothing to refuse)
    for column in (0, 1, 2, 3, 6, 7, 9):
        for i in range(T):
            bad = f.copy()
            bad[i, column] = (np.nan, np.inf, -np.inf)[(i + column) % 3]
            with pytest.raises(ValidationError, match="NaN or infinity"):
                _decode(plan, bad)


# ---- the same bits as the numba kernel this C kernel replaced ---------------------------------------------------
# Random plans (every kind, world rotations, translations, parents in any order) and features (edge values, NaN,
# infinity, -0, denormals; batches past the streaming threshold), decoded as float64 and float32 with and without
# the finiteness check: the digest main's numba kernel gave (22eeb6c).  Compared bit for bit on purpose: scalar IEEE
# arithmetic in C compiled without fused multiply-add or fast-math is the same on every x86-64 and aarch64 CPU; NaN
# results are compared as NaN (their sign bit may differ).
NUMBA_DIGEST = "e456d2e32dc6ca5102108981c7ecaf13f7d97c5f606d38da43a5e5f01ffdf466"


def _random_plan(rng, width):
    J = int(rng.integers(1, 9))
    kinds, cols, axes, joints = [], [], [], []
    if rng.random() < 0.2:  # world rotations: one entry per joint
        for j in range(J):
            k = pp.WORLD_QUAT if rng.random() < 0.8 else pp.WORLD_IDENTITY
            c, a = np.full(6, -1), np.full(3, -1)
            if k == pp.WORLD_QUAT:
                c[:4] = rng.choice(width, 4, replace=False)
            kinds.append(k), joints.append(j), cols.append(c), axes.append(a)
    else:
        for j in rng.permutation(J)[:rng.integers(0, J + 1)]:
            k = int(rng.choice([pp.QUAT, pp.AXIS_ANGLE, pp.EULER, pp.EULER_DEGREES, pp.ORTHO6D]))
            c, a = np.full(6, -1), np.full(3, -1)
            n = int(rng.integers(1, 4)) if k in (pp.EULER, pp.EULER_DEGREES) else {0: 4, 1: 3, 4: 6}[k]
            c[:n] = rng.choice(width, n, replace=False)
            if k in (pp.EULER, pp.EULER_DEGREES):
                a[:n] = rng.integers(0, 3, n)
            kinds.append(k), joints.append(int(j)), cols.append(c), axes.append(a)
    P = int(rng.integers(0, 3))
    tc = rng.integers(-1, width, (P + 1, 3)) if rng.random() < 0.8 else np.zeros((0, 3), np.int64)
    parents = np.arange(J) - 1
    if rng.random() < 0.5 and J > 1:
        parents = np.array([-1] + [int(rng.integers(0, j)) for j in range(1, J)])
    R = len(kinds)
    return pp.PosePlan(width=width, num_joints=J, kinds=np.array(kinds, np.int64).reshape(R),
                       columns=np.array(cols, np.int64).reshape(R, 6), axes=np.array(axes, np.int64).reshape(R, 3),
                       joints=np.array(joints, np.int64).reshape(R), parents=parents.astype(np.int64),
                       translation_columns=tc.astype(np.int64), translation_values=rng.normal(size=tc.shape))


def _random_features(rng, T, width):
    kind = rng.integers(0, 6)
    if kind == 0:
        return rng.normal(size=(T, width))
    if kind == 1:
        return rng.normal(size=(T, width)) * 10.0 ** rng.integers(-12, 8, (1, width))
    if kind == 2:
        return rng.choice([0.0, -0.0, 1.0, -1.0, 1e-300, 1e300, 0.5, 720.0, -360.0, 1e-4, 5e-324], size=(T, width))
    if kind == 3:
        return rng.normal(size=(T, width)) * 1e6
    if kind == 4:
        x = rng.normal(size=(T, width))
        x[rng.random((T, width)) < 0.01] = rng.choice([np.nan, np.inf, -np.inf])
        return x
    return np.round(rng.normal(size=(T, width)) * 2) / 2


def _digest(seed, trials):
    rng = np.random.default_rng(seed)
    h = hashlib.sha256()
    for _ in range(trials):
        width = int(rng.integers(6, 30))
        plan = _random_plan(rng, width)
        T = int(rng.integers(8192, 9000) if rng.random() < 0.03 else rng.integers(0, 200))
        X = _random_features(rng, T, width)
        check, keep = bool(rng.random() < 0.5), bool(rng.random() < 0.3)
        N = plan.translation_columns.shape[0]
        for dt in (np.float64, np.float32):
            rot = np.full((T, plan.num_joints, 4), 7.0, dt)
            root, moved = (np.full((T, 3), 7.0), np.full((T, max(N - 1, 0), 3), 7.0)) if N else (None, None)
            try:
                pp.decode_planned(X, plan, rot, root, moved, check_finite=check, keep_unplanned=keep)
                h.update(b"ok")
            except ValidationError as exc:
                h.update(str(exc).encode())
            for a in (rot, root, moved):
                if a is not None:  # NaN compared as NaN, whatever its sign
                    h.update(np.where(np.isnan(a), np.nan, a).tobytes())
    return h.hexdigest()



def test_random_plans_decode_to_the_numba_kernels_bits():
    assert _digest(7, 400) == NUMBA_DIGEST


def test_the_entries_are_checked_at_once_as_one_by_one():
    """The all-at-once check of the entries (``_entries_fit``) passes exactly the plans the entry-by-entry loop
    (``_check_entries``, which names the first entry that does not fit) lets through: random entries of every
    kind, columns and axes in and just out of range, Euler entries of one to three axes, -1 padding broken."""
    rng = np.random.default_rng(11)
    plan = _plan([QUAT], [(0, 1, 2, 3)], width=4)
    seen = {True: 0, False: 0}
    for _ in range(3000):
        R, width = int(rng.integers(1, 5)), int(rng.integers(1, 9))
        kinds = rng.integers(-1 if rng.random() < 0.05 else 0, 8 if rng.random() < 0.05 else 7, size=R)
        cols = np.full((R, 6), -1, np.int64)
        axes = np.full((R, 3), -1, np.int64)
        for r, kind in enumerate(kinds.tolist()):
            euler = kind in (EULER, EULER_DEGREES)
            n = int(rng.integers(1, 4)) if euler else {QUAT: 4, AXIS_ANGLE: 3, ORTHO6D: 6, WORLD_QUAT: 4}.get(kind, 0)
            cols[r, :n] = rng.integers(0, width, size=n)
            if euler:
                axes[r, :n] = rng.integers(0, 3, size=n)
        if rng.random() < 0.7:  # break one thing (or, now and then, nothing)
            a = cols if rng.random() < 0.6 else axes
            a[rng.integers(R), rng.integers(a.shape[1])] = rng.choice([-2, -1, 0, 2, 3, width - 1, width])
        if rng.random() < 0.1:  # an entry that reads nothing (only the identity kind may)
            cols[rng.integers(R)] = -1
        bad = copy.copy(plan)
        for name, value in (("width", width), ("kinds", kinds.astype(np.int64)), ("columns", cols), ("axes", axes)):
            object.__setattr__(bad, name, value)
        try:
            bad._check_entries()
            fits = True
        except ValidationError:
            fits = False
        assert bad._entries_fit() == fits, (kinds, cols, axes, width)
        seen[fits] += 1
    assert min(seen.values()) > 300, seen
