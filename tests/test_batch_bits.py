"""Batched runtime decoding (``motionrep.open(...).poses``, the path of issue 24's speed target) gives the bits of
the decoders it was made faster from (issue 24: svd batched decode; the encoder measured its bound with those
decoders, so every old payload must decode to what was measured).

Two checks, both bit for bit on purpose: decoding is scalar IEEE C compiled without fused multiply-add or fast-math
(setup.py), plus numpy element-wise arithmetic, no BLAS, so its values are the same on any x86-64 or aarch64 CPU,
vectorised or not, whatever the batch.

* The stored files of tests/data/golden decoded in batches of 8192 poses and more (rotations streamed past the
  cache in that case, with a last block of any size) to values whose SHA-256 main's decoders gave at f38dd8d,
  before the svd batch path was rewritten; the svd files' since the svd decoder blends the frames it decodes
  (2026-12-07: between frames the last bits of float32 changed, each frame kept its bits: tests/data/golden's
  ``remade``).
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
#: decoders gave them at f38dd8d (svd: as the svd decoder blending its frames gives them, 2026-12-07).
WANT = {
    "svd": "5fb391a741f573d7",
    "svd-float16-euler": "9c426c8f5910aa6e",
    "svd-v1": "443a191b7a0b83ab",
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


def test_rotation_vectors_about_the_first_quadrant_of_sincos_decode_to_the_one_value_conversion():
    """The pose plan converts a sub-block's rotation vectors whose half angles all lie in ``mr_sincos``'s first
    quadrant with its kernels alone (``mr_sincos_first``); every other sub-block, with the whole of ``mr_sincos``.
    Both give the bits of the core's one-value conversion (``axis_angle_to_quat``), batch by batch: entries always
    inside, always outside, mixed within a sub-block, and half angles one ulp either side of the quadrant's edge,
    zero, -0.0, below the series' 1e-3, and several turns; in small batches and in batches streamed past the cache.
    Bit for bit on purpose (scalar IEEE C without fused multiply-add or fast-math: the same on any x86-64 or aarch64
    CPU, in a vector lane or alone)."""
    from motionrep.model.poseplan import AXIS_ANGLE, PosePlan, decode_planned
    from motionrep.model.rotations import axis_angle_to_quat

    edge = 2 * (0.5 / 0.6366197723675814)  # theta whose half angle is about the quadrant's edge
    at = [edge]
    for _ in range(40):  # the largest theta still inside, by the kernel's own arithmetic, and its neighbours
        inside = (0.5 * np.array(at)) * 0.6366197723675814 + 0.5 < 1.0
        at.append(np.nextafter(at[-1], np.inf if inside[-1] else -np.inf))
    edges = np.unique(np.concatenate([at, np.nextafter(at, np.inf), np.nextafter(at, -np.inf)]))
    inside = (0.5 * edges) * 0.6366197723675814 + 0.5 < 1.0
    assert inside.any() and not inside.all()  # both sides of the edge are there
    rng = np.random.default_rng(24)
    J = 5
    plan = PosePlan(width=3 * J, num_joints=J, kinds=np.full(J, AXIS_ANGLE, np.int64),
                    columns=np.concatenate([np.arange(3 * J).reshape(J, 3), np.full((J, 3), -1)], axis=1),
                    axes=np.full((J, 3), -1, np.int64), joints=np.arange(J, dtype=np.int64),
                    parents=np.arange(J, dtype=np.int64) - 1, translation_columns=np.zeros((0, 3), np.int64),
                    translation_values=np.zeros((0, 3)))
    for T in (1, 2, 3, 63, 64, 65, 200, 8192 + 77):
        direction = rng.normal(size=(T, J, 3))
        direction /= np.linalg.norm(direction, axis=2, keepdims=True)
        theta = np.empty((T, J))
        theta[:, 0] = rng.random(T) * 0.9 * edge  # always inside
        theta[:, 1] = edge + rng.random(T) * 20.0  # always outside (several turns too)
        theta[:, 2] = np.where(rng.random(T) < 0.02, edge * 1.5, rng.random(T) * edge)  # now and then outside
        theta[:, 3] = rng.choice(edges, T)  # at the edge
        theta[:, 4] = rng.choice([0.0, 1e-9, 5e-4, 1e-3, 0.3, edge], T)  # zero, the series, inside
        f = (direction * theta[..., None]).reshape(T, 3 * J)
        f[::7, 12:15] = 0.0
        f[3::11, 12] = -0.0
        f[:, 9] = np.where(theta[:, 3] > 0, theta[:, 3], f[:, 9])  # exactly theta along x: |v| is theta
        f[:, 10:12] = np.where(theta[:, 3:4] > 0, 0.0, f[:, 10:12])
        want = axis_angle_to_quat(f.reshape(T, J, 3))
        got = np.empty((T, J, 4))
        decode_planned(f, plan, got, None, None)
        assert got.tobytes() == want.tobytes(), T
