"""Rotation conversions against scipy: all 12 Euler orders, corner cases at angle pi, continuity helpers,
6D, slerp, batch shapes and float32 input."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from motionrep.errors import ValidationError
from motionrep.model.rotations import (
    axis_angle_make_continuous,
    axis_angle_to_quat,
    euler_branch,
    euler_to_matrix,
    euler_to_quat,
    matrix_to_quat,
    ortho6d_to_matrix,
    ortho6d_to_quat,
    quat_apply,
    quat_conjugate,
    quat_identity,
    quat_make_continuous,
    quat_multiply,
    quat_normalize,
    quat_slerp,
    quat_to_axis_angle,
    quat_to_euler,
    quat_to_euler_continuous,
    quat_to_matrix,
    quat_to_ortho6d,
    quat_wxyz_to_xyzw,
    quat_xyzw_to_wxyz,
)
from motionrep.model.synthetic import random_unit_quaternions

TAIT_BRYAN = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")
PROPER = ("XYX", "XZX", "YXY", "YZY", "ZXZ", "ZYZ")
ALL_12 = [o for o in TAIT_BRYAN + PROPER] + [o.lower() for o in TAIT_BRYAN + PROPER]
SHORT_ORDERS = [o for n in (1, 2) for o in map("".join, itertools.product("XYZ", repeat=n)) if len(set(o)) == n]


def same_rotation(q1, q2, atol=1e-12) -> bool:
    """q and -q are the same rotation."""
    q1, q2 = np.asarray(q1), np.asarray(q2)
    d = np.minimum(np.abs(q1 - q2).max(axis=-1), np.abs(q1 + q2).max(axis=-1))
    return bool(np.all(d <= atol))


def random_angles(n, k, seed=0, degrees=True, spread=None):
    rng = np.random.default_rng(seed)
    half = 180.0 if degrees else np.pi
    return rng.uniform(-(spread or half), spread or half, (n, k))


# ---- Euler angles --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("order", ALL_12)
@pytest.mark.parametrize("degrees", [True, False])
def test_euler_to_quat_and_matrix_match_scipy(order, degrees):
    angles = random_angles(500, 3, seed=len(order) + ord(order[0]), degrees=degrees) * 2.2  # beyond one turn too
    want = Rotation.from_euler(order, angles, degrees=degrees)
    assert same_rotation(euler_to_quat(angles, order, degrees=degrees), want.as_quat(), atol=2e-15)
    np.testing.assert_allclose(euler_to_matrix(angles, order, degrees=degrees), want.as_matrix(), atol=2e-15)


@pytest.mark.parametrize("order", ALL_12)
def test_quat_to_euler_matches_scipy_and_round_trips(order):
    q = random_unit_quaternions((400,), seed=3)
    got = quat_to_euler(q, order, degrees=True)
    with np.errstate(all="ignore"):
        want = Rotation.from_quat(q).as_euler(order, degrees=True)
    np.testing.assert_allclose(got, want, atol=1e-9)  # the first solution, as scipy
    assert same_rotation(euler_to_quat(got, order, degrees=True), q, atol=1e-12)
    # the first solution: middle angle in [-90, 90] (Tait-Bryan) or [0, 180] (proper)
    middle = got[:, 1]
    if order[0].upper() == order[2].upper():
        assert np.all((middle >= -1e-9) & (middle <= 180 + 1e-9))
        assert not euler_branch(got, order, degrees=True).any()
    else:
        assert np.all(np.abs(middle) <= 90 + 1e-9)
        assert not euler_branch(got, order, degrees=True).any()
    assert np.all((got >= -180) & (got < 180))


@pytest.mark.parametrize("order", SHORT_ORDERS + [o.lower() for o in SHORT_ORDERS])
def test_one_and_two_axis_orders(order):
    angles = random_angles(200, len(order), seed=7, spread=170.0)
    q = euler_to_quat(angles, order, degrees=True)
    assert same_rotation(q, Rotation.from_euler(order, angles, degrees=True).as_quat(), atol=2e-15)
    back = quat_to_euler(q, order, degrees=True)
    np.testing.assert_allclose(back, angles, atol=1e-9)
    assert not euler_branch(angles, order, degrees=True).any()
    # a rotation about another axis cannot be expressed
    other = [a for a in "XYZ" if a not in order.upper()][0]
    with pytest.raises(ValidationError, match="not expressible"):
        quat_to_euler(euler_to_quat([[30.0]], other, degrees=True), order, degrees=True)


def test_euler_known_values():
    # a 90 degree turn about Z maps x to y
    q = euler_to_quat([0.0, 0.0, 90.0], "XYZ", degrees=True)
    np.testing.assert_allclose(q, [0, 0, np.sqrt(0.5), np.sqrt(0.5)], atol=1e-16)
    np.testing.assert_allclose(quat_apply(q, [1.0, 0, 0]), [0, 1, 0], atol=1e-15)
    # intrinsic ZXY = Rz @ Rx @ Ry; extrinsic zxy = Ry @ Rx @ Rz
    a = np.array([10.0, 20.0, 30.0])
    rz, rx, ry = (euler_to_matrix([v], ax, degrees=True) for v, ax in zip(a, "ZXY"))
    np.testing.assert_allclose(euler_to_matrix(a, "ZXY", degrees=True), rz @ rx @ ry, atol=1e-15)
    np.testing.assert_allclose(euler_to_matrix(a, "zxy", degrees=True), ry @ rx @ rz, atol=1e-15)


@pytest.mark.parametrize("order", ["XYZ", "ZXY", "zyx", "ZXZ", "yzy"])
def test_gimbal_lock_still_gives_the_same_rotation(order):
    proper = order[0].upper() == order[2].upper()
    middles = [0.0, 180.0] if proper else [90.0, -90.0]
    for middle in middles:
        angles = np.array([[25.0, middle, -40.0], [-170.0, middle, 170.0]])
        q = euler_to_quat(angles, order, degrees=True)
        back = quat_to_euler(q, order, degrees=True)
        assert same_rotation(euler_to_quat(back, order, degrees=True), q, atol=1e-9)
        cont = quat_to_euler_continuous(q, order, degrees=True)
        assert same_rotation(euler_to_quat(cont, order, degrees=True), q, atol=1e-9)


@pytest.mark.parametrize("bad", ["", "XXY", "XYZX", "xY", "ABC", "X Y", 3, "XX"])
def test_invalid_orders_rejected(bad):
    with pytest.raises(ValidationError, match="invalid Euler order"):
        euler_to_quat([0.0, 0.0, 0.0], bad)


def test_shape_errors():
    with pytest.raises(ValidationError, match=r"angles must have shape \(\.\.\., 3\), got \(5, 2\)"):
        euler_to_quat(np.zeros((5, 2)), "XYZ")
    with pytest.raises(ValidationError, match=r"q must have shape \(\.\.\., 4\)"):
        quat_to_matrix(np.zeros((2, 3)))
    with pytest.raises(ValidationError, match=r"m must have shape \(\.\.\., 3, 3\)"):
        matrix_to_quat(np.zeros((2, 3)))
    with pytest.raises(ValidationError, match=r"frames, \.\.\., 4"):
        quat_to_euler_continuous(np.array([0, 0, 0, 1.0]), "XYZ")
    with pytest.raises(ValidationError, match=r"branch must have shape \(3,\), got \(2,\)"):
        quat_to_euler_continuous(quat_identity((3,)), "XYZ", branch=[True, False])


# ---- continuity ----------------------------------------------------------------------------------------------
def test_quat_to_euler_continuous_passes_through_the_middle_limit():
    # middle angle rises smoothly from 60 to 120 degrees: frame-wise conversion jumps, the continuous one does not
    middle = np.linspace(60.0, 120.0, 61)
    angles = np.stack([np.full_like(middle, 10.0), middle, np.full_like(middle, -20.0)], axis=-1)
    q = euler_to_quat(angles, "ZXY", degrees=True)
    framewise = quat_to_euler(q, "ZXY", degrees=True)
    assert np.abs(np.diff(framewise, axis=0)).max() > 100  # the solution switches at 90 degrees
    cont = quat_to_euler_continuous(q, "ZXY", degrees=True)
    np.testing.assert_allclose(cont, angles, atol=1e-7)
    assert np.abs(np.diff(cont, axis=0)).max() < 1.01


def test_quat_to_euler_continuous_unwraps_full_turns():
    a = np.linspace(0.0, 900.0, 181)  # two and a half turns about Z
    angles = np.stack([a, 5 * np.sin(a / 50), np.zeros_like(a)], axis=-1)
    q = euler_to_quat(angles, "ZXY", degrees=True)
    cont = quat_to_euler_continuous(q, "ZXY", degrees=True)
    np.testing.assert_allclose(cont, angles, atol=1e-9)
    rad = quat_to_euler_continuous(q, "ZXY")
    np.testing.assert_allclose(rad, np.deg2rad(angles), atol=1e-11)


@pytest.mark.parametrize("order", ["ZXY", "XYZ", "yxz", "ZXZ", "XYX"])
def test_branch_hint_reproduces_the_given_solution(order):
    rng = np.random.default_rng(11)
    F = 50
    proper = order[0].upper() == order[2].upper()
    t = np.linspace(0, 1, F)
    first = -150 + 40 * t + rng.uniform(-1, 1, F)
    third = 100 - 60 * t
    # the second solution: middle in (90, 180) or (-180, -90) for Tait-Bryan, (-180, 0) for proper orders
    middle = (-100 - 50 * t) if proper else 120 + 40 * t
    angles = np.stack([first, middle, third], axis=-1)
    branch = euler_branch(angles, order, degrees=True)
    assert branch.all()
    q = euler_to_quat(angles, order, degrees=True)
    got = quat_to_euler_continuous(q, order, degrees=True, branch=branch)
    np.testing.assert_allclose(got, angles, atol=1e-8)
    # without the hint the first frame takes the first solution: the same rotations, other numbers
    plain = quat_to_euler_continuous(q, order, degrees=True)
    assert np.abs(plain - angles).max() > 10
    assert same_rotation(euler_to_quat(plain, order, degrees=True), q, atol=1e-9)
    # a mixed hint, frame by frame
    mixed = branch.copy()
    mixed[::2] = False
    got = quat_to_euler_continuous(q, order, degrees=True, branch=mixed)
    assert same_rotation(euler_to_quat(got, order, degrees=True), q, atol=1e-9)
    assert np.abs(np.diff(got, axis=0)).max() <= 180  # unwrapped: no jump of a full turn
    wrapped = (got[1::2] - angles[1::2] + 180.0) % 360.0 - 180.0  # the hinted frames: the same numbers mod 360
    np.testing.assert_allclose(wrapped, 0.0, atol=1e-8)
    assert not euler_branch(got[::2], order, degrees=True).any()


def test_euler_branch_values():
    assert euler_branch([[0.0, 100.0, 0.0], [0.0, 80.0, 0.0], [0.0, -91.0, 0.0], [0.0, 270.0, 0.0]], "ZXY",
                        degrees=True).tolist() == [True, False, True, False]
    assert euler_branch([[0.0, -30.0, 0.0], [0.0, 30.0, 0.0]], "ZXZ", degrees=True).tolist() == [True, False]
    assert euler_branch([[0.0, 2.0, 0.0]], "XYZ").tolist() == [True]  # radians
    assert euler_branch([[10.0, 100.0]], "ZX", degrees=True).tolist() == [False]


def test_axis_angle_make_continuous():
    theta = np.linspace(0.0, 4 * np.pi, 200)  # two full turns about a fixed axis
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    q = axis_angle_to_quat(theta[:, None] * axis)
    raw = quat_to_axis_angle(q)
    assert np.linalg.norm(raw, axis=-1).max() <= np.pi + 1e-12
    assert np.abs(np.diff(raw, axis=0)).max() > 1.0  # wraps
    cont = axis_angle_make_continuous(raw)
    np.testing.assert_allclose(cont, theta[:, None] * axis, atol=1e-9)
    assert same_rotation(axis_angle_to_quat(cont), q, atol=1e-12)
    # batch dims after frames
    two = axis_angle_make_continuous(np.stack([raw, -raw], axis=1))
    assert two.shape == (200, 2, 3)
    np.testing.assert_allclose(two[:, 0], cont, atol=1e-12)
    with pytest.raises(ValidationError):
        axis_angle_make_continuous(np.zeros(3))


def test_axis_angle_make_continuous_frame_by_frame():
    """The compiled loop against the definition, written out: each frame takes the whole number of turns that
    brings it closest to the previous output; a frame without rotation takes the previous output's axis."""
    rng = np.random.default_rng(11)
    v = rng.normal(size=(300, 5, 3)) * 3.0
    v[rng.random((300, 5)) < 0.1] = 0.0  # frames without rotation
    v[0, 1] = 0.0
    v[1:4, 1] = 0.0  # ... several in a row, from the first frame on

    want = v.copy()
    for f in range(1, v.shape[0]):
        for n in range(v.shape[1]):
            theta = np.linalg.norm(v[f, n])
            prev = want[f - 1, n]
            if theta > 1e-12:
                axis = v[f, n] / theta
            else:
                size = np.linalg.norm(prev)
                axis = prev / size if size > 1e-12 else np.zeros(3)
            k = np.round((axis @ prev - theta) / (2 * np.pi))
            want[f, n] = (theta + 2 * np.pi * k) * axis
    got = axis_angle_make_continuous(v)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)  # the same arithmetic up to the order of the sums
    assert same_rotation(axis_angle_to_quat(got), axis_angle_to_quat(v), atol=1e-9)
    # one joint alone gives what it gives in the batch
    assert np.array_equal(axis_angle_make_continuous(v[:, 2]), got[:, 2])


def test_quat_make_continuous():
    rng = np.random.default_rng(5)
    angles = np.cumsum(rng.uniform(-5, 5, (100, 3, 3)), axis=0)
    q = euler_to_quat(angles, "ZXY", degrees=True)
    flips = np.where(rng.random((100, 3)) < 0.4, -1.0, 1.0)
    noisy = q * flips[..., None]
    out = quat_make_continuous(noisy)
    assert np.all(np.sum(out[1:] * out[:-1], axis=-1) >= 0)
    assert np.all(np.abs(np.abs(out) - np.abs(q)) < 1e-15)
    assert np.array_equal(out[0], noisy[0])
    assert quat_make_continuous(noisy[:1]).shape == (1, 3, 4)
    with pytest.raises(ValidationError):
        quat_make_continuous(np.array([0, 0, 0, 1.0]))


# ---- angle pi and other corners ------------------------------------------------------------------------------
def test_angle_pi_corner_cases():
    for axis in np.eye(3).tolist() + [[1 / np.sqrt(2), 1 / np.sqrt(2), 0.0]]:
        v = np.pi * np.array(axis)
        q = axis_angle_to_quat(v)
        np.testing.assert_allclose(q[3], 0.0, atol=1e-16)
        back = quat_to_axis_angle(q)
        assert np.linalg.norm(back) == pytest.approx(np.pi)
        assert same_rotation(axis_angle_to_quat(back), q)
        m = quat_to_matrix(q)
        np.testing.assert_allclose(m, Rotation.from_rotvec(v).as_matrix(), atol=1e-15)
        assert same_rotation(matrix_to_quat(m), q, atol=1e-15)
    # half turns as matrices: diag(1, -1, -1) is 180 degrees about x
    q = matrix_to_quat(np.diag([1.0, -1.0, -1.0]))
    assert same_rotation(q, [1, 0, 0, 0])
    # 180-degree Euler angles
    for order in ["XYZ", "ZXZ"]:
        q = euler_to_quat([180.0, 0.0, 0.0], order, degrees=True)
        assert same_rotation(q, Rotation.from_euler(order, [180.0, 0, 0], degrees=True).as_quat())
    # slerp between a rotation and its negative is constant
    q0 = random_unit_quaternions((1,), seed=1)[0]
    mid = quat_slerp(q0, -q0, 0.5)
    assert same_rotation(mid, q0)


def test_matrix_to_quat_is_canonical_and_projects():
    q = random_unit_quaternions((50,), seed=2)
    m = quat_to_matrix(q)
    out = matrix_to_quat(m)
    assert np.all(out[:, 3] >= 0)
    assert same_rotation(out, q, atol=1e-14)
    noisy = m + 1e-9 * np.random.default_rng(0).normal(size=m.shape)
    assert same_rotation(matrix_to_quat(noisy), q, atol=1e-8)


# ---- algebra ---------------------------------------------------------------------------------------------------
def test_quaternion_algebra_matches_scipy():
    a = random_unit_quaternions((30,), seed=1)
    b = random_unit_quaternions((30,), seed=2)
    v = np.random.default_rng(3).normal(size=(30, 3))
    ra, rb = Rotation.from_quat(a), Rotation.from_quat(b)
    assert same_rotation(quat_multiply(a, b), (ra * rb).as_quat(), atol=1e-15)
    np.testing.assert_allclose(quat_apply(a, v), ra.apply(v), atol=1e-14)
    assert same_rotation(quat_multiply(a, quat_conjugate(a)), quat_identity((30,)), atol=1e-15)
    np.testing.assert_allclose(quat_to_matrix(a), ra.as_matrix(), atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(quat_normalize(a * 3.0), axis=-1), 1.0, atol=1e-15)
    with pytest.raises(ValidationError, match="zero or non-finite"):
        quat_normalize([0.0, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(quat_wxyz_to_xyzw(quat_xyzw_to_wxyz(a)), a)
    assert quat_xyzw_to_wxyz([1.0, 2.0, 3.0, 4.0]).tolist() == [4.0, 1.0, 2.0, 3.0]
    assert same_rotation(axis_angle_to_quat(quat_to_axis_angle(a)), a, atol=1e-14)
    np.testing.assert_allclose(quat_to_axis_angle(a), ra.as_rotvec(), atol=1e-14)


def test_ortho6d_round_trip_and_gram_schmidt():
    q = random_unit_quaternions((100,), seed=4)
    d6 = quat_to_ortho6d(q)
    m = quat_to_matrix(q)
    np.testing.assert_array_equal(d6, np.concatenate([m[:, :, 0], m[:, :, 1]], axis=-1))
    assert same_rotation(ortho6d_to_quat(d6), q, atol=1e-14)
    # a scaled, skewed encoding: Gram-Schmidt keeps the first column's direction
    rng = np.random.default_rng(0)
    raw = d6 * 3.0 + 0.1 * rng.normal(size=d6.shape)
    r = ortho6d_to_matrix(raw)
    np.testing.assert_allclose(r @ np.swapaxes(r, -1, -2), np.broadcast_to(np.eye(3), r.shape), atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(r), 1.0, atol=1e-14)
    first = raw[:, :3] / np.linalg.norm(raw[:, :3], axis=-1, keepdims=True)
    np.testing.assert_allclose(r[:, :, 0], first, atol=1e-15)
    with pytest.raises(ValidationError, match="degenerate"):
        ortho6d_to_matrix([1.0, 0, 0, 2.0, 0, 0])
    with pytest.raises(ValidationError, match="degenerate"):
        ortho6d_to_matrix([0.0, 0, 0, 0, 1, 0])


def test_slerp():
    q0 = quat_identity()
    q1 = euler_to_quat([90.0], "Z", degrees=True)
    mid = quat_slerp(q0, q1, 0.5)
    assert same_rotation(mid, euler_to_quat([45.0], "Z", degrees=True), atol=1e-15)
    assert same_rotation(quat_slerp(q0, q1, 0.0), q0) and same_rotation(quat_slerp(q0, q1, 1.0), q1)
    # shorter arc: the sign of q1 does not matter
    assert same_rotation(quat_slerp(q0, -q1, 0.25), euler_to_quat([22.5], "Z", degrees=True), atol=1e-15)
    # nearly equal endpoints (the linear branch) stay unit
    q2 = euler_to_quat([1e-8], "X", degrees=True)
    out = quat_slerp(q0, q2, np.linspace(0, 1, 5))
    np.testing.assert_allclose(np.linalg.norm(out, axis=-1), 1.0, atol=1e-15)
    # against scipy on random pairs, t broadcast over a batch
    a = random_unit_quaternions((20,), seed=8)
    b = random_unit_quaternions((20,), seed=9)
    t = np.linspace(0, 1, 20)
    got = quat_slerp(a, b, t)
    for i in range(20):
        want = Slerp([0, 1], Rotation.from_quat([a[i], b[i]]))([t[i]]).as_quat()[0]
        assert same_rotation(got[i], want, atol=1e-12)


# ---- batch shapes and dtypes ---------------------------------------------------------------------------------
def test_batch_shapes_and_float32():
    q = random_unit_quaternions((2, 3, 5), seed=1)
    q32 = q.astype(np.float32)
    angles = quat_to_euler(q, "ZXY")
    assert angles.shape == (2, 3, 5, 3)
    assert quat_to_euler_continuous(q, "ZXY").shape == (2, 3, 5, 3)
    assert quat_to_euler_continuous(q, "ZXY", branch=np.zeros((2, 3, 5), bool)).shape == (2, 3, 5, 3)
    outputs = {
        "euler_to_quat": euler_to_quat(angles.astype(np.float32), "ZXY"),
        "euler_to_matrix": euler_to_matrix(angles.astype(np.float32), "ZXY"),
        "quat_to_matrix": quat_to_matrix(q32),
        "matrix_to_quat": matrix_to_quat(quat_to_matrix(q32).astype(np.float32)),
        "quat_to_axis_angle": quat_to_axis_angle(q32),
        "axis_angle_to_quat": axis_angle_to_quat(quat_to_axis_angle(q).astype(np.float32)),
        "quat_to_ortho6d": quat_to_ortho6d(q32),
        "ortho6d_to_quat": ortho6d_to_quat(quat_to_ortho6d(q).astype(np.float32)),
        "quat_multiply": quat_multiply(q32, q32),
        "quat_apply": quat_apply(q32, np.ones((2, 3, 5, 3), np.float32)),
        "quat_slerp": quat_slerp(q32, q32[::-1], 0.3),
        "quat_make_continuous": quat_make_continuous(q32),
        "axis_angle_make_continuous": axis_angle_make_continuous(quat_to_axis_angle(q32).astype(np.float32)),
        "quat_normalize": quat_normalize(q32),
    }
    expected_tail = {"euler_to_matrix": (3, 3), "quat_to_matrix": (3, 3), "quat_to_axis_angle": (3,),
                     "quat_to_ortho6d": (6,), "quat_apply": (3,), "axis_angle_make_continuous": (3,)}
    for name, out in outputs.items():
        assert out.dtype == np.float64, name
        assert out.shape == (2, 3, 5) + expected_tail.get(name, (4,)), name
    assert same_rotation(outputs["euler_to_quat"], q, atol=1e-6)  # float32 angles: float32 precision
    # empty batches
    assert euler_to_quat(np.zeros((0, 3)), "XYZ").shape == (0, 4)
    assert quat_to_matrix(np.zeros((0, 4))).shape == (0, 3, 3)
    assert quat_to_euler(np.zeros((0, 4)), "XYZ").shape == (0, 3)
    assert matrix_to_quat(np.zeros((0, 3, 3))).shape == (0, 4)
    assert quat_identity((2,)).tolist() == [[0, 0, 0, 1], [0, 0, 0, 1]]
