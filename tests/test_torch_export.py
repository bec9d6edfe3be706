"""Back out of the network: a features tensor becomes a Motion and a BVH, glTF or HDF5 file in one call
(motionrep.torch.features_to_motion, write_features)."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="motionrep.torch needs torch (pip install torch==2.13.0)")
pytest.importorskip("roma", reason="motionrep.torch needs roma (pip install 'motionrep[torch]')")

import motionrep.torch as mt  # noqa: E402
from motionrep.io import read  # noqa: E402
from motionrep.model.kinematics import character_height, global_positions  # noqa: E402
from motionrep.model.synthetic import odd_skeleton, synthetic_motion  # noqa: E402


@pytest.mark.parametrize("name", ["root-quat-axis-angle", "ortho6d", "euler", "dual-quaternion"])
@pytest.mark.parametrize("suffix", [".bvh", ".gltf", ".h5"])
def test_write_features_in_one_call(tmp_path, name, suffix):
    m = synthetic_motion(frames=10, seed=1)
    # a network's output: float32, requiring grad, with a batch entry taken out
    out = mt.encode_features(name, m, dtype=torch.float32)[None].requires_grad_(True)[0]
    path = tmp_path / f"generated{suffix}"
    written = mt.write_features(path, name, out, m.skeleton, m.fps)
    back = read(path)
    assert back.num_frames == 10 and back.skeleton.names == m.skeleton.names
    h = character_height(m.skeleton)
    # float32 features (7 digits) and the file's decimals: positions within 1e-5 of the height
    assert np.abs(global_positions(back) - global_positions(m)).max() <= 1e-5 * h
    assert np.abs(global_positions(written) - global_positions(back)).max() <= 1e-5 * h


@pytest.mark.parametrize("name", ["root-quat-axis-angle", "euler"])
def test_one_and_two_axis_joints_and_partial_position_channels(tmp_path, name):
    m = synthetic_motion(odd_skeleton(), frames=6, seed=3)
    f = mt.encode_features(name, m, dtype=torch.float64 if name != "euler" else torch.float32)
    f = f + 1e-5 * (torch.arange(f.numel(), dtype=f.dtype).reshape(f.shape) % 3)  # a network is never exact
    path = tmp_path / ("odd.bvh" if name == "euler" else "odd.h5")
    mt.write_features(path, name, f, m.skeleton, m.fps)
    assert read(path).num_frames == 6


def test_features_to_motion_is_the_numpy_decoder():
    m = synthetic_motion(frames=7, seed=2)
    f = mt.encode_features("euler", m)
    motion = mt.features_to_motion("euler", f, m.skeleton, m.fps)
    assert motion.euler_branch is not None  # the numpy decoder's hint for BVH writers is kept
    assert np.abs(global_positions(motion) - global_positions(m)).max() <= 1e-9 * character_height(m.skeleton)
