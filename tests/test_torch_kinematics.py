"""motionrep.torch forward kinematics against the compiled numpy FK (motionrep.model.kinematics): synthetic skeletons
(position channels on non-root joints, end sites, joints without rotation channels), batch dimensions, dtypes,
gradients, and every real clip of ../shared/data (with the shared L-infinity error against motionrep evaluate's)."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="motionrep.torch needs torch (pip install torch==2.13.0)")
pytest.importorskip("roma", reason="motionrep.torch needs roma (pip install 'motionrep[torch]')")

import motionrep.torch as mt  # noqa: E402
from helpers import real_params  # noqa: E402
from test_torch_losses import check_max_joint_error_equals_evaluate  # noqa: E402
from motionrep.io import read  # noqa: E402
from motionrep.model.kinematics import character_height, forward_kinematics, global_positions  # noqa: E402
from motionrep.errors import ValidationError  # noqa: E402
from motionrep.model.synthetic import humanoid_skeleton, odd_skeleton, spinning_motion, synthetic_motion  # noqa: E402
from motionrep.testing import conformance_motions  # noqa: E402

# float64 FK in torch and in numba round differently (the same formulas, other operation order), so the
# positions agree to a few ulps of the character's size, not bit for bit: 1e-12 of the height.
TOL = 1e-12


def _clips():
    return conformance_motions() + [synthetic_motion(odd_skeleton(), frames=20, seed=7),
                                    spinning_motion(humanoid_skeleton(), frames=30, seed=9)]


def _check_agrees(motion, rtol=TOL):
    sk = motion.skeleton
    root, rot, jt = mt.motion_tensors(motion)
    g, pos = mt.forward_kinematics(sk, root, rot, jt)
    ref = forward_kinematics(motion)
    h = character_height(sk)
    assert pos.shape == (motion.num_frames, sk.num_joints + sk.num_end_sites, 3)
    assert np.abs(pos.numpy() - ref.positions).max() <= rtol * h
    assert np.abs(g.numpy() - ref.rotations[:, :sk.num_joints]).max() <= 1e-12
    assert np.abs(mt.global_positions(sk, root, rot, jt).numpy() - ref.positions).max() <= rtol * h


@pytest.mark.parametrize("i", range(8))
def test_fk_agrees_with_numpy_on_synthetic_skeletons(i):
    _check_agrees(_clips()[i])


def test_position_channels_replace_offsets_and_none_means_offsets():
    m = synthetic_motion(odd_skeleton(), frames=10, seed=1)
    sk = m.skeleton
    assert sk.translated_joints.size  # the odd skeleton has position channels on non-root joints
    root, rot, jt = mt.motion_tensors(m)
    with_offsets = mt.global_positions(sk, root, rot, None)
    expected = global_positions(m.replace(joint_translations=None))
    assert np.abs(with_offsets.numpy() - expected).max() <= TOL * character_height(sk)
    moved = mt.global_positions(sk, root, rot, jt)
    assert np.abs(moved.numpy() - global_positions(m)).max() <= TOL * character_height(sk)
    assert np.abs(moved.numpy() - with_offsets.numpy()).max() > 1e-3  # the channels do move the joints


def test_unnormalised_rotations_are_normalised_as_numpy_does():
    m = synthetic_motion(frames=12, seed=3)
    root, rot, jt = mt.motion_tensors(m)
    scaled = rot * torch.linspace(0.5, 3.0, rot.shape[1], dtype=rot.dtype)[None, :, None]
    assert np.abs(mt.global_positions(m.skeleton, root, scaled, jt).numpy() - global_positions(m)).max() <= \
        TOL * character_height(m.skeleton)


def test_batch_dimensions_and_float32():
    a, b = synthetic_motion(frames=16, seed=0), synthetic_motion(frames=16, seed=1)
    sk = a.skeleton
    ta, tb = mt.motion_tensors(a), mt.motion_tensors(b)
    stacked = [torch.stack([x, y]).reshape((2, 1) + x.shape) for x, y in zip(ta, tb)]
    pos = mt.global_positions(sk, *stacked)
    assert pos.shape == (2, 1, 16, sk.num_joints + sk.num_end_sites, 3)
    assert np.abs(pos[1, 0].numpy() - global_positions(b)).max() <= TOL * character_height(sk)
    p32 = mt.global_positions(sk, *(t.float() for t in ta))
    assert p32.dtype == torch.float32
    # float32 arithmetic: rounding of 1e-7 relative per operation, compounded over a chain of ~8 joints
    assert np.abs(p32.double().numpy() - global_positions(a)).max() <= 1e-5 * character_height(sk)


def test_gradients_are_finite_and_correct():
    m = synthetic_motion(odd_skeleton(), frames=2, seed=5)
    sk = m.skeleton
    root, rot, jt = (t.clone().requires_grad_(True) for t in mt.motion_tensors(m))
    assert torch.autograd.gradcheck(lambda r, q, t: mt.global_positions(sk, r, q, t), (root, rot, jt))
    identity = torch.zeros_like(rot)
    identity[..., 3] = 1.0
    identity.requires_grad_(True)
    mt.global_positions(sk, root, identity, jt).sum().backward()
    assert torch.isfinite(identity.grad).all()


def test_bad_shapes_raise_validation_error():
    m = synthetic_motion(frames=4, seed=0)
    root, rot, jt = mt.motion_tensors(m)
    with pytest.raises(ValidationError, match="rotations must have shape"):
        mt.global_positions(m.skeleton, root, rot[:, :3], jt)
    with pytest.raises(ValidationError, match="root_translation"):
        mt.global_positions(m.skeleton, root[:, :2], rot, jt)
    with pytest.raises(ValidationError, match="tensor"):
        mt.global_positions(m.skeleton, root.numpy(), rot, jt)


@pytest.mark.parametrize("path", real_params())
def test_fk_and_error_agree_with_numpy_on_every_real_clip(path):
    motion = read(path)
    _check_agrees(motion)
    check_max_joint_error_equals_evaluate(motion)
