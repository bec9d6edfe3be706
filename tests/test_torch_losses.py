"""Losses and the shared error in torch: Andreou et al. eq. 14-16 against the numpy dual-quaternion algebra,
fk_position_loss for every shipped representation, max_joint_error equal to motionrep's evaluate."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="motionrep.torch needs torch (pip install torch==2.13.0)")
pytest.importorskip("roma", reason="motionrep.torch needs roma (pip install 'motionrep[torch]')")

import motionrep.torch as mt  # noqa: E402
from motionrep.errors import ValidationError  # noqa: E402
from motionrep.pipeline.evaluate import max_joint_error  # noqa: E402
from motionrep.model.kinematics import global_positions  # noqa: E402
from motionrep.plugin.registry import get_representation  # noqa: E402
from motionrep.model.rotations import quat_normalize  # noqa: E402
from motionrep.model.synthetic import odd_skeleton, synthetic_motion  # noqa: E402
from motionrep_dualquat import (dualquat_conjugate, dualquat_multiply, dualquat_normalize,  # noqa: E402
                                dualquat_to_rotation_translation)

SHIPPED = ["root-quat-axis-angle", "ortho6d", "euler", "dual-quaternion"]
# torch and numpy round differently (same formulas, other operation orders): agreement to 1e-10, not bitwise.
TOL = 1e-10


def _pair(seed=0):
    m = synthetic_motion(frames=20, seed=seed)
    rep = get_representation("dual-quaternion")
    f = rep.to_features(m)
    noisy = f + np.random.default_rng(seed).normal(size=f.shape) * 0.02
    return m.skeleton, f, noisy


def _numpy_local(dq, parents):
    out = dq.copy()
    out[:, 1:] = dualquat_multiply(dualquat_conjugate(dq[:, parents[1:]]), dq[:, 1:])
    return out


def test_andreou_losses_match_the_equations_in_numpy():
    sk, f, noisy = _pair()
    lay = get_representation("dual-quaternion").layout(sk)
    target = lay.rotation_block(f)  # (F, J, 8)
    pred = lay.rotation_block(noisy)
    tp, tt = torch.tensor(pred), torch.tensor(target)
    assert torch.equal(mt.dualquats_of_features(torch.tensor(noisy), sk), tp)
    # eq. 14
    assert abs(mt.dq_mse_loss(tp, tt).item() - np.mean(np.sum((pred - target) ** 2, -1))) <= TOL
    # eq. 15 on local rotations
    pn, tn = dualquat_normalize(pred), dualquat_normalize(target)
    lq = 1 - np.sum(_numpy_local(pn, sk.parents)[..., :4] * _numpy_local(tn, sk.parents)[..., :4], -1)
    assert abs(mt.dq_quat_loss(tp, tt, sk).item() - lq.mean()) <= TOL
    # L_pos: positions of eq. 8 in current coordinates
    lp = np.linalg.norm(dualquat_to_rotation_translation(pn)[1] - dualquat_to_rotation_translation(tn)[1], axis=-1)
    assert abs(mt.dq_pos_loss(tp, tt).item() - lp.mean()) <= TOL
    # L_offset: translations of the local dual quaternions, non-root joints
    lo = np.linalg.norm(dualquat_to_rotation_translation(_numpy_local(pn, sk.parents)[:, 1:])[1]
                        - dualquat_to_rotation_translation(_numpy_local(tn, sk.parents)[:, 1:])[1], axis=-1)
    assert abs(mt.dq_offset_loss(tp, tt, sk).item() - lo.mean()) <= TOL
    # eq. 16 on the raw prediction
    r, d = pred[..., :4], pred[..., 4:]
    lr = (np.sum(r * r, -1) - 1) ** 2 + np.sum(r * d, -1) ** 2
    assert abs(mt.dq_reg_loss(tp).item() - lr.mean()) <= TOL
    assert mt.dq_offset_loss(tp, tt, sk, reduction="none").shape == (20, sk.num_joints - 1)


def test_losses_vanish_at_the_target_with_finite_gradients():
    sk, f, _ = _pair(1)
    target = mt.dualquats_of_features(torch.tensor(f), sk)
    pred = target.clone().requires_grad_(True)
    total = (mt.dq_mse_loss(pred, target) + mt.dq_quat_loss(pred, target, sk) + mt.dq_pos_loss(pred, target)
             + mt.dq_offset_loss(pred, target, sk) + mt.dq_reg_loss(pred))
    assert abs(total.item()) <= 1e-12  # lossless features are unit dual quaternions
    total.backward()
    assert torch.isfinite(pred.grad).all()
    # the offsets of the target are the skeleton's
    offsets = mt.dualquat_to_rotation_translation(
        mt.dualquat_multiply(mt.dualquat_conjugate(target[:, sk.parents[1:].tolist()]), target[:, 1:]))[1]
    assert np.abs(offsets.numpy() - sk.offsets[1:]).max() <= 1e-10


def test_dq_losses_check_their_input():
    with pytest.raises(ValidationError, match=r"\(\.\.\., J, 8\)"):
        mt.dq_mse_loss(torch.zeros(3, 7), torch.zeros(3, 7))
    with pytest.raises(ValidationError, match="differ in shape"):
        mt.dq_pos_loss(torch.zeros(3, 8), torch.zeros(2, 8))
    with pytest.raises(ValidationError, match="reduction"):
        mt.dq_reg_loss(torch.zeros(3, 8), reduction="total")


@pytest.mark.parametrize("name", SHIPPED)
def test_fk_position_loss_for_every_representation(name):
    m = synthetic_motion(odd_skeleton(), frames=12, seed=2)
    sk = m.skeleton
    rep = get_representation(name)
    target = torch.tensor(rep.to_features(m))
    noisy = target + 0.01 * torch.randn(target.shape, dtype=target.dtype, generator=torch.Generator().manual_seed(0))
    pred = noisy.clone().requires_grad_(True)
    loss = mt.fk_position_loss(name, pred, target, sk)
    expected = np.linalg.norm(global_positions(rep.from_features(noisy.numpy(), sk, m.fps)) - global_positions(m),
                              axis=-1).mean()
    assert abs(loss.item() - expected) <= 1e-9 * (1 + expected)
    loss.backward()
    assert torch.isfinite(pred.grad).all() and pred.grad.abs().max() > 0
    exact = target.clone().requires_grad_(True)
    mt.fk_position_loss(name, exact, target, sk).backward()  # zero distance: gradient 0, not NaN
    assert torch.isfinite(exact.grad).all()


def _error_pair(motion, seed=0):
    rng = np.random.default_rng(seed)
    noisy = quat_normalize(motion.rotations + rng.normal(size=motion.rotations.shape) * 0.01)
    return motion.replace(rotations=noisy, root_translation=motion.root_translation + rng.normal(size=(
        motion.num_frames, 3)) * 0.01)


def check_max_joint_error_equals_evaluate(motion):
    """Used here and by the real-data test in test_torch_kinematics.py."""
    cand = _error_pair(motion)
    expected = max_joint_error(motion, cand)
    got = mt.max_joint_error(motion.skeleton, mt.motion_tensors(motion), mt.motion_tensors(cand))
    # the same distances from FK rounded differently in torch and numba: 1e-12 of the height
    assert abs(got.max_error.item() - expected.max_error) <= 1e-12 * expected.height
    assert abs(got.max_error_percent.item() - expected.max_error_percent) <= 1e-10
    assert abs(got.mean_error.item() - expected.mean_error) <= 1e-12 * expected.height
    assert got.height == expected.height
    assert int(got.frame) == expected.frame


@pytest.mark.parametrize("seed", range(3))
def test_max_joint_error_equals_motionrep_evaluate(seed):
    skeleton = odd_skeleton() if seed == 1 else None
    m = synthetic_motion(skeleton, frames=30, seed=seed) if skeleton else synthetic_motion(frames=30, seed=seed)
    check_max_joint_error_equals_evaluate(m)


def test_max_joint_error_keeps_batch_dimensions_and_has_a_gradient():
    m = synthetic_motion(frames=10, seed=4)
    ref = mt.motion_tensors(m)
    cand = mt.motion_tensors(_error_pair(m))
    batch = [torch.stack([a, b]) for a, b in zip(ref, cand)]
    rot = batch[1].clone().requires_grad_(True)
    err = mt.max_joint_error(m.skeleton, [torch.stack([r, r]) for r in ref], (batch[0], rot, batch[2]))
    assert err.max_error.shape == (2,) and err.max_error[0].item() == 0.0 and err.max_error[1].item() > 0
    err.max_error.sum().backward()
    assert torch.isfinite(rot.grad).all()
