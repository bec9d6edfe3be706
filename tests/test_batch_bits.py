"""Batched runtime decoding (``motionrep.open(...).poses``, the path of issue 24's speed target) gives the bits of
the decoders it was made faster from (issue 24: svd batched decode; the encoder measured its bound with those
decoders, so every old payload must decode to what was measured).

Two checks, both bit for bit on purpose: decoding is scalar IEEE C compiled without fused multiply-add or fast-math
(setup.py), plus numpy element-wise arithmetic, no BLAS, so its values are the same on any x86-64 or aarch64 CPU,
vectorised or not, whatever the batch.

* The stored files of tests/data/golden decoded in batches of 8192 poses and more (rotations streamed past the
  cache in that case, with a last block of any size) to values whose SHA-256 main's decoders gave at f38dd8d,
  before the svd batch path was rewritten.
* Real clips (skipped without ../shared/data): svd payloads made here (the SVD itself, LAPACK, may differ between
  machines; its decoding may not) decoded in a large batch, against the arithmetic written out independently: the
  svd decoder's sums in numpy, one IEEE operation at a time in the C code's order, and each entry's rotation by the
  core's one-value conversions (``motionrep.model.rotations``), not the pose plan's loops.
"""

from __future__ import annotations

import hashlib
import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import real_params

import motionrep

GOLDEN = Path(__file__).resolve().parent / "data" / "golden"
#: SHA-256 (first 16 hex digits) of the batches of :func:`_batches`, float64 then float32 rotations, as main's
#: decoders gave them at f38dd8d.
WANT = {
    "svd": "2b71bea520629697",
    "svd-float16-euler": "dc6c80670df8d47a",
    "svd-v1": "f1cb6f1be5c03c37",
    "transform-dual-quaternion": "f8d0a90e88a97d63",
    "transform-euler": "6176a36090f87d06",
    "transform-ortho6d": "d90605c98641de2d",
    "transform-root-quat-axis-angle": "3cf9147aca4b7287",
}


def _batches(data: bytes) -> str:
    """The digest of large batches of one file: 20,000 random times, then 8192 + 1, 8192 + 2, 8192 + 3 and
    8192 + 65 of them (the last block of every size the kernels treat apart), float64 and float32 rotations."""
    clip = motionrep.open(data)
    rng = np.random.default_rng(24)
    t = np.concatenate([[0.0, clip.duration, -1.0, clip.duration + 5.0], rng.random(19996) * clip.duration])
    h = hashlib.sha256()
    for dtype in (np.float64, np.float32):
        for n in (t.size, 8193, 8194, 8195, 8257):
            p = clip.poses(t[:n], dtype=dtype)
            for a in (p.rotations, p.root_translation, p.joint_translations):
                h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


@pytest.mark.parametrize("name", sorted(WANT))
def test_large_batches_decode_to_the_bits_of_before(name):
    assert _batches((GOLDEN / f"{name}.mrc").read_bytes()) == WANT[name]


def _svd_features(arrays, u):
    """The svd decoder's features at normalised times u, written out in numpy (plugins/motionrep_svd/tests)."""
    here = Path(__file__).resolve().parent.parent / "plugins" / "motionrep_svd" / "tests" / "test_svd_internals.py"
    spec = importlib.util.spec_from_file_location("svd_internals", here)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module._reference(arrays["coefficients"], arrays["mean"], arrays["basis"], u)


def _rotations(plan, f):
    """Each plan entry's rotation from the features f (T, D) by the core's one-value conversions."""
    from motionrep.model import poseplan as pp
    from motionrep.model.rotations import axis_angle_to_quat, euler_to_quat, ortho6d_to_quat

    def normalized(x):  # mr_normalized: each operation in its order
        n = np.sqrt(((x[:, 0] * x[:, 0] + x[:, 1] * x[:, 1]) + x[:, 2] * x[:, 2]) + x[:, 3] * x[:, 3])
        return x / n[:, None]

    def product(a, b):  # mr_product: each operation in its order
        (ax, ay, az, aw), (bx, by, bz, bw) = a.T, b.T
        return np.stack([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                         aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz], axis=1)

    out = np.zeros((f.shape[0], plan.num_joints, 4))
    out[..., 3] = 1.0
    world = out.copy()  # world rotations (world plans: entry j is joint j)
    for kind, cols, axes, joint in zip(plan.kinds, plan.columns, plan.axes, plan.joints):
        x = f[:, cols[cols >= 0]]
        parent = plan.parents[joint]
        if kind == pp.QUAT:
            out[:, joint] = normalized(x)
        elif kind == pp.WORLD_QUAT:  # local = conj(G_parent) G_joint
            world[:, joint] = normalized(x)
            if parent >= 0:
                g = world[:, parent]
                out[:, joint] = product(np.concatenate([-g[:, :3], g[:, 3:]], axis=1), world[:, joint])
            else:
                out[:, joint] = world[:, joint]
        elif kind == pp.WORLD_IDENTITY:
            world[:, joint] = world[:, parent] if parent >= 0 else world[:, joint]
        elif kind == pp.AXIS_ANGLE:
            out[:, joint] = axis_angle_to_quat(x)
        elif kind == pp.ORTHO6D:
            out[:, joint] = ortho6d_to_quat(x)
        elif kind in (pp.EULER, pp.EULER_DEGREES):
            order = "".join("XYZ"[a] for a in axes[cols[:3] >= 0])
            out[:, joint] = euler_to_quat(x, order, degrees=kind == pp.EULER_DEGREES)
        else:
            raise AssertionError(f"no reference for kind {kind}")
    return out


@pytest.mark.parametrize("representation", ["root-quat-axis-angle", "euler", "ortho6d", "dual-quaternion"])
@pytest.mark.parametrize("path", real_params("cmu/bvh11")[:1] + real_params("cmu/pybvh")[:1])
def test_real_svd_payloads_decode_in_batches_to_the_arithmetic_written_out(path, representation):
    from motionrep.io import read
    from motionrep.pipeline.compress import compress_motion

    motion = read(path)
    result = compress_motion(motion, "svd", representation=representation, seed=0, max_error="2%")
    clip = motionrep.open(result.data)
    t = np.random.default_rng(7).random(20_000) * clip.duration
    got = clip.poses(t)
    f = _svd_features(result.container.arrays, clip.normalized_times(t))
    plan = clip._rep.pose_plan(clip.skeleton)
    want = _rotations(plan, f)
    assert got.rotations.tobytes() == want.tobytes()
    tc = plan.translation_columns[0]
    assert got.root_translation[:, tc >= 0].tobytes() == f[:, tc[tc >= 0]].tobytes()
