"""The optional torch path of representations (Representation.torch_path): the four shipped ones against their
numpy paths through the conformance suite (synthetic clips and every real clip), a representation without one,
and a third-party one that is wrong (the check must fail)."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="motionrep.torch needs torch (pip install torch==2.13.0)")
pytest.importorskip("roma", reason="motionrep.torch needs roma (pip install 'motionrep[torch]')")

import motionrep.torch as mt  # noqa: E402
from helpers import real_params  # noqa: E402
from motionrep.errors import ValidationError  # noqa: E402
from motionrep.io import read  # noqa: E402
from motionrep.plugin.registry import get_representation  # noqa: E402
from motionrep.model.synthetic import synthetic_motion  # noqa: E402
from motionrep.testing import check_representation, check_torch_path  # noqa: E402
from motionrep_ortho6d import Ortho6D  # noqa: E402

Ortho6DTorch = type(Ortho6D().torch_path())  # the shipped torch path's class, reached through the public interface

SHIPPED = ["root-quat-axis-angle", "ortho6d", "euler", "dual-quaternion"]
#: Frames of each real clip checked (decoding is frame by frame; encoding's continuity is exercised by the prefix).
REAL_FRAMES = 60


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_torch_paths_conform(name):
    rep = get_representation(name)
    assert rep.torch_path() is not None
    check_torch_path(rep)


class _NumpyOnly(Ortho6D):
    name = "numpy-only-6d"


class _Wrong(Ortho6DTorch):
    def decode(self, features, skeleton):
        root, rot, jt = super().decode(features, skeleton)
        return root, rot.flip(-2), jt  # joints swapped


class _WrongRep(Ortho6D):
    name = "wrong-6d"

    def torch_path(self):
        return _Wrong()


class _NumpyOnlyNoTorch(_NumpyOnly):
    def torch_path(self):
        return None


def test_a_representation_without_torch_path_still_works():
    rep = _NumpyOnlyNoTorch()
    check_representation(rep)  # the torch checks are skipped for it
    m = synthetic_motion(frames=8, seed=0)
    f = mt.encode_features(rep, m, dtype=torch.float32)  # through numpy
    assert f.dtype == torch.float32 and np.abs(f.double().numpy() - rep.to_features(m)).max() <= 1e-6
    with pytest.raises(ValidationError, match="has no torch path"):
        mt.decode_features(rep, f, m.skeleton)
    assert mt.features_to_motion(rep, f, m.skeleton, m.fps).num_frames == 8


def test_a_wrong_torch_path_fails_the_check():
    with pytest.raises(AssertionError, match="decoding features differs from decode_poses"):
        check_torch_path(_WrongRep(), [synthetic_motion(frames=6, seed=1)])


def test_decode_features_checks_the_width():
    m = synthetic_motion(frames=4, seed=0)
    with pytest.raises(ValidationError, match="expects a tensor of features of shape"):
        mt.decode_features("ortho6d", torch.zeros(4, 5, dtype=torch.float64), m.skeleton)


@pytest.mark.parametrize("name", SHIPPED)
def test_decoding_keeps_dtype_device_and_batch(name):
    m = synthetic_motion(frames=5, seed=2)
    f = mt.encode_features(name, m, dtype=torch.float32)
    root, rot, jt = mt.decode_features(name, f.expand(3, 2, *f.shape), m.skeleton)
    assert rot.shape == (3, 2, 5, m.skeleton.num_joints, 4) and rot.dtype == torch.float32
    assert root.shape == (3, 2, 5, 3) and jt.shape == (3, 2, 5, 0, 3)


@pytest.mark.parametrize("path", real_params())
def test_torch_paths_agree_with_numpy_on_every_real_clip(path):
    motion = read(path)
    motion = motion.frames(slice(0, REAL_FRAMES))
    for name in SHIPPED:
        check_torch_path(get_representation(name), [motion])
