"""motionrep.torch.rotations against motionrep.model.rotations (same names, xyzw, 6D columns, Euler orders), and finite,
correct gradients at the identity and at 180 degrees."""

from __future__ import annotations

import math

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="motionrep.torch needs torch (pip install torch==2.13.0)")
pytest.importorskip("roma", reason="motionrep.torch needs roma (pip install 'motionrep[torch]')")

import motionrep.model.rotations as R  # noqa: E402
import motionrep.torch.rotations as T  # noqa: E402

# torch and numpy/scipy/numba evaluate the same formulas in different operation orders (and scipy's Euler
# extraction differs in its branch arithmetic), so results agree to rounding, not bit for bit.
TOL = 1e-12
ORDERS = ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX", "ZXZ", "XYX", "zxy", "xyz", "XZ", "ZY", "Y", "x"]


def _quats(n=64, seed=0):
    q = np.random.default_rng(seed).normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def _close(a, b, tol=TOL):
    assert np.abs(np.asarray(a) - b.detach().numpy()).max() <= tol


def test_same_public_names_as_numpy_where_they_apply():
    numpy_only = {"quat_to_euler_continuous", "euler_branch", "axis_angle_make_continuous", "quat_columns_normalized",
                  "axis_angle_columns_to_quat", "euler_columns", "euler_columns_to_quat", "ortho6d_columns_to_quat"}
    assert set(T.__all__) == set(R.__all__) - numpy_only
    assert T.__doc__ and "numpy" in T.__doc__  # the module says why those are left out


def test_conversions_agree_with_numpy():
    q = _quats()
    t = torch.tensor(q)
    _close(R.quat_to_matrix(q), T.quat_to_matrix(t))
    _close(R.matrix_to_quat(R.quat_to_matrix(q)), T.matrix_to_quat(T.quat_to_matrix(t)))
    _close(R.quat_to_axis_angle(q), T.quat_to_axis_angle(t))
    v = R.quat_to_axis_angle(q) * 1.9  # angles beyond pi: w < 0 in both
    _close(R.axis_angle_to_quat(v), T.axis_angle_to_quat(torch.tensor(v)))
    _close(R.quat_multiply(q, q[::-1]), T.quat_multiply(t, t.flip(0)))
    _close(R.quat_apply(q, v), T.quat_apply(t, torch.tensor(v)))
    _close(R.quat_conjugate(q), T.quat_conjugate(t))
    _close(R.quat_normalize(3 * q), T.quat_normalize(3 * t))
    _close(R.quat_make_continuous(q), T.quat_make_continuous(t))
    _close(R.quat_slerp(q, q[::-1], 0.3), T.quat_slerp(t, t.flip(0), 0.3))
    _close(R.quat_xyzw_to_wxyz(q), T.quat_xyzw_to_wxyz(t))
    _close(R.quat_wxyz_to_xyzw(q), T.quat_wxyz_to_xyzw(t))
    _close(R.quat_identity((2, 3)), T.quat_identity((2, 3), dtype=torch.float64))


def test_6d_is_the_first_two_columns():
    q = _quats(8)
    m = R.quat_to_matrix(q)
    six = T.quat_to_ortho6d(torch.tensor(q)).numpy()
    assert np.abs(six - np.concatenate([m[:, :, 0], m[:, :, 1]], axis=-1)).max() <= TOL  # columns (Zhou)
    noisy = six + np.random.default_rng(1).normal(size=six.shape) * 0.1
    _close(R.ortho6d_to_matrix(noisy), T.ortho6d_to_matrix(torch.tensor(noisy)))
    _close(R.ortho6d_to_quat(noisy), T.ortho6d_to_quat(torch.tensor(noisy)))


@pytest.mark.parametrize("order", ORDERS)
def test_euler_in_any_order(order):
    rng = np.random.default_rng(len(order))
    e = R.quat_to_euler(R.euler_to_quat(rng.uniform(-3, 3, size=(64, len(order))), order), order)
    q = R.euler_to_quat(e, order)
    _close(q, T.euler_to_quat(torch.tensor(e), order))
    _close(R.euler_to_matrix(e, order), T.euler_to_matrix(torch.tensor(e), order))
    # scipy's and roma's extraction differ in rounding (atan2 of differently rounded terms): 1e-11 rad
    _close(e, T.quat_to_euler(torch.tensor(q), order), 1e-11)
    _close(R.euler_to_quat(e * 200, order, degrees=True), T.euler_to_quat(torch.tensor(e * 200), order, degrees=True))


def _rotations_at(angle):
    """Unit quaternions of ``angle`` about a few axes (float64, requiring grad)."""
    axes = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [1.0, 2.0, -2.0]])
    axes /= np.linalg.norm(axes, axis=-1, keepdims=True)
    q = np.concatenate([np.sin(angle / 2) * axes, np.full((4, 1), np.cos(angle / 2))], axis=-1)
    return torch.tensor(q, requires_grad=True), torch.tensor(angle * axes, requires_grad=True)


@pytest.mark.parametrize("angle", [0.0, math.pi], ids=["identity", "180-degrees"])
def test_gradcheck_at_identity_and_180_degrees(angle):
    q, v = _rotations_at(angle)
    grad = torch.autograd.gradcheck
    assert grad(T.axis_angle_to_quat, (v,))
    assert grad(T.quat_to_matrix, (q,))
    assert grad(lambda x: T.quat_apply(T.quat_normalize(x), torch.ones(3, dtype=x.dtype)), (q,))
    assert grad(lambda x: T.euler_to_quat(x, "ZXY"), (v,))
    assert grad(lambda x: T.ortho6d_to_matrix(x), (T.quat_to_ortho6d(q).detach().requires_grad_(True),))
    # Maps that choose a hemisphere (w >= 0) jump where w = 0 (180 degrees); through any hemisphere-invariant
    # use they are smooth, and gradcheck passes there too.
    assert grad(lambda x: T.quat_to_matrix(T.axis_angle_to_quat(T.quat_to_axis_angle(x))), (q,))
    assert grad(lambda x: T.quat_to_matrix(T.ortho6d_to_quat(x)), (T.quat_to_ortho6d(q).detach().requires_grad_(True),))
    assert grad(lambda x: T.quat_to_matrix(T.matrix_to_quat(T.quat_to_matrix(x))), (q,))
    if angle == 0.0:  # away from w = 0 the hemisphere maps are smooth themselves
        assert grad(T.quat_to_axis_angle, (q,))
        assert grad(lambda x: T.matrix_to_quat(T.quat_to_matrix(x)), (q,))
        assert grad(lambda x: T.quat_to_euler(x, "ZXY"), (q,))


def test_explicit_gradients_at_identity():
    # d(axis-angle)/dq at the identity is 2 I on the vector part (v = 2 u / w to first order) and 0 in w.
    q = torch.tensor([0.0, 0.0, 0.0, 1.0], dtype=torch.float64, requires_grad=True)
    jac = torch.autograd.functional.jacobian(T.quat_to_axis_angle, q)
    expected = torch.zeros(3, 4, dtype=torch.float64)
    expected[:, :3] = 2 * torch.eye(3, dtype=torch.float64)
    assert torch.allclose(jac, expected, atol=1e-12)
    # d q / d v at v = 0 is 1/2 I on the vector part, 0 in w.
    jac = torch.autograd.functional.jacobian(T.axis_angle_to_quat, torch.zeros(3, dtype=torch.float64))
    assert torch.allclose(jac[:3], 0.5 * torch.eye(3, dtype=torch.float64), atol=1e-12)
    assert torch.allclose(jac[3], torch.zeros(3, dtype=torch.float64), atol=1e-12)


def test_explicit_gradients_at_180_degrees_are_one_sided_and_finite():
    q = torch.tensor([0.0, 0.0, 1.0, 0.0], dtype=torch.float64, requires_grad=True)  # 180 degrees about z, w = 0
    jac = torch.autograd.functional.jacobian(T.quat_to_axis_angle, q)
    assert torch.isfinite(jac).all()
    h = 1e-7  # the derivative from the side w > 0, where the hemisphere rule keeps q
    for k in range(4):
        step = torch.zeros(4, dtype=torch.float64)
        step[k] = h
        plus = q.detach() + step
        minus = q.detach() - step if k != 3 else q.detach()
        fd = (T.quat_to_axis_angle(plus) - T.quat_to_axis_angle(minus)) / (h if k == 3 else 2 * h)
        assert torch.allclose(jac[:, k], fd, atol=1e-5), k
    # axis-angle of 180 degrees to a quaternion: w = cos(theta / 2) has derivative -1/2 along the axis
    v = torch.tensor([0.0, 0.0, math.pi], dtype=torch.float64)
    jac = torch.autograd.functional.jacobian(T.axis_angle_to_quat, v)
    assert torch.allclose(jac[3], torch.tensor([0.0, 0.0, -0.5], dtype=torch.float64), atol=1e-12)


def test_hemisphere_rule():
    q = torch.tensor(_quats(32, 3))
    assert (T.matrix_to_quat(T.quat_to_matrix(q))[:, 3] >= 0).all()
    assert (T.ortho6d_to_quat(T.quat_to_ortho6d(q))[:, 3] >= 0).all()
    aa = T.quat_to_axis_angle(-q)  # read with w >= 0: the same vectors for q and -q, angles in [0, pi]
    assert torch.allclose(aa, T.quat_to_axis_angle(q), atol=1e-12)
    assert (torch.linalg.vector_norm(aa, dim=-1) <= math.pi + 1e-12).all()
