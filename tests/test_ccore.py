"""The compiled core (``motionrep._ccore``, C) against golden values computed here from first principles.

Every kernel of the core is scalar IEEE float64 arithmetic compiled without fused multiply-add and without
fast-math (setup.py), and Python's float operations are IEEE float64 too: a reference that performs the same
operations in the same order, written out below in plain Python, gives the very same bits, on any x86-64 CPU (Intel
or AMD).  So these comparisons are bitwise (``view(np.uint64)``), not within a tolerance.  The references follow the
C sources (``motionrep/_c/mr_rotconv.h``, ``fk.c``, ``rotations.c``) expression by expression; the C was checked
against the numba kernels it replaced on every real clip (``benchmarks/results/ccore_equivalence.md``), and a few
of those values are kept below as hex literals.  Independent checks beside them: sine and cosine within an ulp of
``math``, quaternions of the right rotation (scipy), the writer's text read back by ``float``; and ``euler.c``
against scipy itself, whose operations it repeats.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from motionrep import _ccore
from motionrep.errors import ValidationError
from motionrep.model import rotations as R
from motionrep.model.kinematics import fk_arrays
from motionrep.model.synthetic import humanoid_skeleton, random_unit_quaternions

TWO52 = 4503599627370496.0


def bits(a) -> np.ndarray:
    return np.asarray(a, np.float64).view(np.uint64)


# ------------------------------------------------------------------------------------------------------------------
# the references: the C's operations, in Python floats (finite inputs)
# ------------------------------------------------------------------------------------------------------------------
def ref_floor(x: float) -> float:
    return x if not abs(x) < TWO52 else math.copysign(0.0, x) if math.floor(x) == 0 else float(math.floor(x))


def ref_sincos(x: float) -> tuple[float, float]:
    n = ref_floor(x * 0.6366197723675814 + 0.5)
    r = ((x - n * 1.57079632673412561417e+00) - n * 6.07710050630396597660e-11) - n * 2.02226624871116645580e-21
    z = r * r
    s = r + r * z * (-1.66666666666666324348e-01 + z * (8.33333333332248946124e-03 + z * (
        -1.98412698298579493134e-04 + z * (2.75573137070700676789e-06 + z * (
            -2.50507602534068634195e-08 + z * 1.58969099521155010221e-10)))))
    tail = z * z * (4.16666666666666019037e-02 + z * (-1.38888888888741095749e-03 + z * (
        2.48015872894767294178e-05 + z * (-2.75573143513906633035e-07 + z * (
            2.08757232129817482790e-09 + z * -1.13596475577881948265e-11)))))
    hz = 0.5 * z
    w = 1.0 - hz
    c = w + (((1.0 - w) - hz) + tail)
    quadrant = n - 4.0 * ref_floor(n * 0.25)
    odd = quadrant == 1.0 or quadrant == 3.0
    s1, c1 = (c, -s) if odd else (s, c)
    return (-s1, -c1) if quadrant >= 2.0 else (s1, c1)


def ref_product(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def ref_euler(angles, axes, degrees: bool):
    q = (0.0, 0.0, 0.0, 1.0)
    for angle, axis in zip(angles, axes):
        half = ((angle - 720.0 * ref_floor(angle * (1.0 / 720.0) + 0.5)) * (math.pi / 360.0) if degrees
                else 0.5 * angle)
        s, c = ref_sincos(half)
        e = [1.0 if axis == k else 0.0 for k in range(3)]
        q = ref_product(q, (s * e[0], s * e[1], s * e[2], c))
    return q


def ref_axis_angle(x, y, z):
    theta2 = (x * x + y * y) + z * z
    theta = math.sqrt(theta2)
    s, c = ref_sincos(0.5 * theta)
    k = s / theta if theta > 1e-3 else 0.5 - theta2 / 48.0 + theta2 * theta2 / 3840.0
    return (k * x, k * y, k * z, c)


def ref_normalized(x, y, z, w):
    n = math.sqrt(((x * x + y * y) + z * z) + w * w)
    return (x / n, y / n, z / n, w / n)


def ref_ortho6d(a1x, a1y, a1z, a2x, a2y, a2z):
    n1 = math.sqrt((a1x * a1x + a1y * a1y) + a1z * a1z)
    d = n1 if n1 > 0.0 else 1.0
    b1 = (a1x / d, a1y / d, a1z / d)
    dot = (b1[0] * a2x + b1[1] * a2y) + b1[2] * a2z
    u2 = (a2x - dot * b1[0], a2y - dot * b1[1], a2z - dot * b1[2])
    n2 = math.sqrt((u2[0] * u2[0] + u2[1] * u2[1]) + u2[2] * u2[2])
    b2 = (u2[0] / n2, u2[1] / n2, u2[2] / n2)
    b3 = (b1[1] * b2[2] - b1[2] * b2[1], b1[2] * b2[0] - b1[0] * b2[2], b1[0] * b2[1] - b1[1] * b2[0])
    (m00, m10, m20), (m01, m11, m21), (m02, m12, m22) = b1, b2, b3
    trace = (m00 + m11) + m22
    if trace >= m00 and trace >= m11 and trace >= m22:
        x, y, z, w = m21 - m12, m02 - m20, m10 - m01, 1.0 + trace
    elif m00 >= m11 and m00 >= m22:
        x, y, z, w = 1.0 - trace + 2.0 * m00, m10 + m01, m02 + m20, m21 - m12
    elif m11 >= m22:
        x, y, z, w = m10 + m01, 1.0 - trace + 2.0 * m11, m21 + m12, m02 - m20
    else:
        x, y, z, w = m02 + m20, m21 + m12, 1.0 - trace + 2.0 * m22, m10 - m01
    n = math.sqrt(((x * x + y * y) + z * z) + w * w)
    n = -n if w < 0.0 else n
    q = [x / n, y / n, z / n, w / n]
    if q[3] == 0.0 and (q[0] < 0.0 or (q[0] == 0.0 and (q[1] < 0.0 or (q[1] == 0.0 and q[2] < 0.0)))):
        q = [-q[0], -q[1], -q[2], -q[3]]
    return tuple(q)


def ref_rotate_add(g, v, base):
    qx, qy, qz, qw = g
    vx, vy, vz = v
    tx, ty, tz = 2.0 * (qy * vz - qz * vy), 2.0 * (qz * vx - qx * vz), 2.0 * (qx * vy - qy * vx)
    return (base[0] + vx + qw * tx + (qy * tz - qz * ty), base[1] + vy + qw * ty + (qz * tx - qx * tz),
            base[2] + vz + qw * tz + (qx * ty - qy * tx))


def ref_fk(sk, rot, root, moved):
    """Positions and world rotations (w >= 0) of every joint and end site, frame by frame."""
    F, J, E = rot.shape[0], sk.num_joints, sk.num_end_sites
    pos, out = np.empty((F, J + E, 3)), np.empty((F, J + E, 4))
    local = [tuple(o) for o in sk.offsets.tolist()]
    for f in range(F):
        for k, j in enumerate(sk.translated_joints.tolist()):
            local[j] = tuple(moved[f, k].tolist())
        g = []
        for j in range(J):
            x, y, z, w = (float(c) for c in rot[f, j])
            n = math.sqrt(x * x + y * y + z * z + w * w)
            q = (x / n, y / n, z / n, w / n)
            p = int(sk.parents[j])
            if p < 0:
                g.append(q)
                pos[f, j] = root[f]
                continue
            pos[f, j] = ref_rotate_add(g[p], local[j], pos[f, p])
            g.append(ref_product(g[p], q))
        for e, p in enumerate(sk.end_site_parents.tolist()):
            pos[f, J + e] = ref_rotate_add(g[p], sk.end_site_offsets[e], pos[f, p])
        for i in range(J + E):
            q = g[i] if i < J else g[sk.end_site_parents[i - J]]
            out[f, i] = [(-1.0 if q[3] < 0 else 1.0) * c for c in q]
    return pos, out


# ------------------------------------------------------------------------------------------------------------------
ANGLES = np.concatenate([np.random.default_rng(1).uniform(-400, 400, 1500), np.random.default_rng(2).normal(0, 1e-4, 100),
                         np.random.default_rng(3).uniform(-1e7, 1e7, 100),
                         [0.0, -0.0, 90.0, -90.0, 180.0, -180.0, 270.0, 360.0, 720.0, -540.0, 1e-300, 5e-324, 1e300,
                          -1e300, math.pi, -math.pi / 2, 359.99999999999994, 1080.5]])


def test_sincos_bit_for_bit_and_close_to_math():
    for x in ANGLES.tolist() + (ANGLES / 57.0).tolist():
        s, c = _ccore.sincos(x)
        assert bits([s, c]).tolist() == bits(ref_sincos(x)).tolist(), x
        if abs(x) < 1e5:  # within an ulp, or, near a zero, the reduction's absolute error (below 1e-30 here)
            assert abs(s - math.sin(x)) <= max(math.ulp(math.sin(x)), 1e-30), x
            assert abs(c - math.cos(x)) <= max(math.ulp(math.cos(x)), 1e-30), x
    assert bits(_ccore.sincos(1.0)).tolist() == [0x3FEAED548F090CEE, 0x3FE14A280FB5068C]  # sin 1, cos 1: fdlibm's


ORDERS = [a + b + c for a in "XYZ" for b in "XYZ" for c in "XYZ" if a != b and b != c]
ORDERS = ORDERS + [o.lower() for o in ORDERS] + ["XY", "zx", "YZ", "x", "Y"]


@pytest.mark.parametrize("order", ORDERS)
def test_euler_every_order_bit_for_bit(order):
    rng = np.random.default_rng(len(order) * 100 + ORDERS.index(order))
    angles = rng.choice(ANGLES, (60, len(order)))
    angles = np.where(np.abs(angles) < 1e30, angles, np.copysign(1e30, angles))  # finite in float32 too
    positions, axes = R.euler_columns([order])
    ks = [k for k in positions[0].tolist() if k >= 0]
    for degrees in (True, False):
        want = np.array([ref_euler([a[k] for k in ks], axes[0, :len(ks)].tolist(), degrees)
                         for a in angles.tolist()])
        for dtype in (np.float64, np.float32):
            out = np.full((60, 2, 4), 7.0, dtype)
            feats = (angles if dtype == np.float64 else np.clip(angles, -1e7, 1e7)).astype(dtype)
            R.euler_columns_to_quat(feats, positions, axes, np.array([1]), out, degrees=degrees)
            if dtype == np.float32:  # float32 angles are read as float64, the result rounded to float32
                want32 = np.array([ref_euler([float(a[k]) for k in ks], axes[0, :len(ks)].tolist(), degrees)
                                   for a in feats.astype(np.float64).tolist()]).astype(np.float32)
                assert np.array_equal(out[:, 1].view(np.uint32), want32.view(np.uint32))
            else:
                assert np.array_equal(bits(out[:, 1]), bits(want))
            assert (out[:, 0] == 7.0).all()  # a joint without an entry is left as it is
    # and it is the rotation the order names (scipy's convention), to rounding
    small = rng.uniform(-180, 180, (50, len(order)))
    q = R.euler_to_quat(small, order, degrees=True)
    s = Rotation.from_euler(order, small, degrees=True).as_quat()
    assert np.abs(np.abs(np.sum(q * s, axis=-1)) - 1).max() < 1e-14


def test_golden_hex():
    """Values the numba kernels gave (main at 22eeb6c, before the C core), kept as bits."""
    q = R.euler_to_quat(np.array([[30.0, 45.0, 60.0], [-170.5, 89.999, 0.001], [720.25, -1e-9, 359.0]]), "ZXY",
                        degrees=True)
    assert bits(q).tolist() == [[0x3fc9ac0503920a00, 0x3fe105f1e4a2606e, 0x3fd914f3d52059af, 0x3fe7256a8e4e0ac8],
                                [0x3fadfb8fa1f67ab0, 0xbfe68cab61546ab3, 0xbfe68cc52c492c1d, 0x3fadfbb1eba5df17],
                                [0xbef3f68f9cd2e97c, 0x3f81df34fb03a9e4, 0xbf61df191b4b0819, 0xbfefffab27fde885]]
    q = R.axis_angle_to_quat(np.array([[0.1, -0.2, 0.3], [1e-5, 2e-5, -3e-5], [3.0, 1.0, -2.0]]))
    assert bits(q).tolist() == [[0x3fa9737000cdf4f0, 0xbfb9737000cdf4f0, 0x3fc31694009a77b4, 0x3fef710ec1e04df6],
                                [0x3ed4f8b588de27de, 0x3ee4f8b588de27de, 0xbeef75104d4d3bcc, 0x3fefffffffe7f2bc],
                                [0x3fe882ca3f916fce, 0x3fd057317fb64a89, 0xbfe057317fb64a89, 0xbfd2ea4f46b8358b]]
    q = R.ortho6d_to_quat(np.array([[1.0, 0.2, -0.1, 0.3, 1.0, 0.5], [-1.0, 0.0, 0.0, 0.0, -1.0, 0.0]]))
    assert bits(q).tolist() == [[0x3fd07f342c74bb97, 0x3fb2a7e1bcff341a, 0x3fb50411e68b3843, 0x3feeb7ed37a343d3],
                                [0, 0, 0x3ff0000000000000, 0]]
    v = R.axis_angle_make_continuous(np.array([[[3.0, 0.0, 0.0]], [[-3.0, 0.1, 0.0]], [[0.0, 0.0, 0.0]],
                                               [[6.2, 0.0, 0.1]]]))
    assert bits(v[:, 0]).tolist() == [[0x4008000000000000, 0, 0],
                                      [0x400a3cd21257654d, 0xbfbbfc9bcf4c27ca, 0x8000000000000000],
                                      [0x40191e69092bb2a5, 0xbfcacb1ab472e0b0, 0x8000000000000000],
                                      [0x4018cccccccccccd, 0, 0x3fb9999999999999]]


def test_axis_angle_quaternion_and_6d_bit_for_bit():
    rng = np.random.default_rng(9)
    rv = np.concatenate([rng.normal(size=(300, 3)) * 10.0 ** rng.integers(-8, 2, (300, 1)), np.zeros((1, 3)),
                         [[-0.0, 0.0, -0.0], [1e-300, 0.0, 0.0], [7.0, 7.0, 7.0]]])
    want = np.array([ref_axis_angle(*v) for v in rv.tolist()])
    assert np.array_equal(bits(R.axis_angle_to_quat(rv)), bits(want))
    q = rng.normal(size=(300, 4)) * 10.0 ** rng.integers(-100, 100, (300, 1))
    assert np.array_equal(bits(R.quat_normalize(q)), bits([ref_normalized(*v) for v in q.tolist()]))
    d6 = np.concatenate([rng.normal(size=(300, 6)), R.quat_to_ortho6d(random_unit_quaternions((200,), seed=4)),
                         [[1.0, 0, 0, 0, 1, 0], [-1.0, 0, 0, 0, -1, 0], [0, 0, 1.0, 0, 1, 0], [1.0, 0, 0, 0, 0, -1]]])
    assert np.array_equal(bits(R.ortho6d_to_quat(d6)), bits([ref_ortho6d(*v) for v in d6.tolist()]))
    with pytest.raises(ValidationError, match="zero or non-finite length"):
        R.quat_normalize(np.zeros((2, 4)))
    with pytest.raises(ValidationError, match="degenerate"):
        R.ortho6d_to_quat(np.array([1.0, 0, 0, 2.0, 0, 0]))


def test_continuity_pass_bit_for_bit():
    rng = np.random.default_rng(5)
    v = np.cumsum(rng.normal(size=(200, 3, 3)), axis=0)
    v[50:55] = 0.0  # no rotation: the previous frame's axis is kept
    out = R.axis_angle_make_continuous(v)
    want = v.astype(np.float64).copy()
    theta = np.linalg.norm(v, axis=-1)
    two_pi = 2 * math.pi
    for f in range(1, v.shape[0]):
        for n in range(v.shape[1]):
            p = want[f - 1, n].tolist()
            t = float(theta[f, n])
            a = (v[f, n] / t).tolist() if t > 1e-12 else [0.0, 0.0, 0.0]
            if t <= 1e-12:
                size = math.sqrt((p[0] * p[0] + p[1] * p[1]) + p[2] * p[2])
                a = [c / size for c in p] if size > 1e-12 else [0.0, 0.0, 0.0]
            k = float(round(((a[0] * p[0] + a[1] * p[1]) + a[2] * p[2] - t) / two_pi))
            scale = t + two_pi * k
            want[f, n] = [scale * c for c in a]
    assert np.array_equal(bits(out), bits(want))


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_fk_bit_for_bit(dtype):
    """A humanoid with position channels on two joints besides the root (a joint translation moves them) and its
    end sites; rotations not quite unit (FK normalises them)."""
    sk = humanoid_skeleton()
    chans = list(sk.channels)
    for j in (3, 7):
        chans[j] = ("Xposition", "Yposition", "Zposition") + tuple(c for c in chans[j] if c.endswith("rotation"))
    from motionrep import Skeleton

    sk = Skeleton(sk.names, sk.parents, sk.offsets, tuple(chans), sk.end_site_parents, sk.end_site_offsets)
    assert sk.translated_joints.size == 2 and sk.num_end_sites
    rng = np.random.default_rng(3)
    F = 13  # blocks of frames and a remainder
    rot = (random_unit_quaternions((F, sk.num_joints), seed=2) * rng.uniform(0.999, 1.001, (F, sk.num_joints, 1)))
    rot = rot.astype(dtype)
    root, moved = rng.normal(size=(F, 3)) * 50, rng.normal(size=(F, 2, 3)) * 5
    pos, out = fk_arrays(sk, rot, root, moved, want_rotations=True)
    want_pos, want_rot = ref_fk(sk, rot.astype(np.float64), root, moved)
    assert np.array_equal(bits(pos), bits(want_pos)) and np.array_equal(bits(out), bits(want_rot))
    assert fk_arrays(sk, rot, root, moved)[1] is None


def test_the_avx2_and_baseline_copies_give_the_same_bits():
    """The conversions', FK's and the closed loop's pose's loops are compiled twice (the x86-64 baseline and AVX2, chosen when the module
    loads; ``MOTIONREP_CCORE_BASELINE=1`` forces the baseline): the same IEEE operations, so the same bits."""
    if _ccore.simd == "baseline":
        pytest.skip("this CPU (or build) has only the baseline copy: nothing to compare")
    code = """if True:
        import hashlib, sys
        import numpy as np
        from motionrep import _ccore
        from motionrep.model import rotations as R
        rng = np.random.default_rng(0)
        h = hashlib.sha256()
        a = np.concatenate([rng.uniform(-400, 400, (3000, 3)), rng.uniform(-1e7, 1e7, (200, 3)), np.zeros((7, 3))])
        for order in ("ZXY", "xyz", "YXY", "ZX", "y"):
            for degrees in (True, False):
                for dtype in (np.float64, np.float32):
                    h.update(R.euler_to_quat(a[:, :len(order)].astype(dtype), order, degrees).tobytes())
        h.update(R.axis_angle_to_quat(a).tobytes())
        h.update(R.quat_normalize(np.concatenate([a, a[:, :1] + 0.5], axis=1)).tobytes())
        h.update(R.ortho6d_to_quat(np.concatenate([a + 1.0, a[::-1] - 2.0], axis=1)).tobytes())
        from motionrep.model.kinematics import fk_arrays
        from motionrep.model.synthetic import humanoid_skeleton, random_unit_quaternions
        sk = humanoid_skeleton()
        for F in (1, 3, 4, 5, 203):  # whole blocks of frames and a remainder
            rot = random_unit_quaternions((F, sk.num_joints), seed=F) * 1.0001
            pos, out = fk_arrays(sk, rot, rng.normal(size=(F, 3)), np.zeros((F, 0, 3)), True)
            h.update(pos.tobytes() + out.tobytes())
        for F in (1, 70, 203):  # the closed loop's pose (chain.c): its conversions by blocks of frames
            x, st = rng.normal(size=(F, 11)) * 3.0, np.zeros((2, F, 4))
            x[:1, 4:7] *= 1e-5
            for frames in (None, np.arange(0, F, 3)):
                _ccore.chain_pose(x, np.array([0, 1]), np.array([[0, 1, 2, 3], [4, 5, 6, 0]]), np.array([0, 1]),
                                  np.array([-1, 0]), np.array([[7, 8, 9], [-1, 10, -1]]), np.ones((2, 3)), st,
                                  np.zeros((2, F, 3)), frames)
                h.update(st.tobytes())
            rot = rng.normal(size=(2, F, 4)) * 0.5  # and the closed loop's targets (rotation vectors, levers)
            true_rot, truth = rng.normal(size=(3, F, 4)), rng.normal(size=(3, F, 4)) * 3.0
            true_rot[1, :1] *= 1e-5
            lever = [rng.normal(size=(1, F, 3)) for _ in range(3)]
            out = np.zeros((F, 11))
            assert _ccore.chain_targets(rot, rng.normal(size=(2, F, 3)), np.array([0, 1, 1]), true_rot,
                                        np.array([0, -1, -1]), *lever, np.sqrt(np.sum(lever[2] ** 2, axis=-1)),
                                        np.array([1, 0, 1]), np.array([[0, 1, 2, -1], [3, 4, 5, 6], [7, 8, 9, -1]]),
                                        truth, out, None if F < 100 else np.arange(1, F, 2)) == -1
            h.update(out.tobytes())
        print(_ccore.simd, h.hexdigest())
    """
    runs = []
    for baseline in ("", "1"):
        env = dict(os.environ, MOTIONREP_CCORE_BASELINE=baseline)
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
        assert done.returncode == 0, done.stderr
        runs.append(done.stdout.split())
    assert [r[0] for r in runs] == ["avx2", "baseline"]
    assert runs[0][1] == runs[1][1]


@pytest.mark.parametrize("call", [
    lambda: _ccore.fk(np.zeros((2, 3, 4)), np.zeros((2, 3)), np.zeros((3, 3)), np.array([-1, 0, 5]),
                      np.zeros(0, np.int64), np.zeros((2, 0, 3)), np.zeros(0, np.int64), np.zeros((0, 3)),
                      np.zeros((2, 3, 3)), None),  # a parent after its child
    lambda: _ccore.fk(np.zeros((2, 3, 4)), np.zeros((2, 3)), np.zeros((3, 3)), np.array([-1, 0, 1]),
                      np.zeros(0, np.int64), np.zeros((2, 0, 3)), np.array([7]), np.zeros((1, 3)),
                      np.zeros((2, 4, 3)), None),  # an end site of no joint
    lambda: _ccore.fk(np.zeros((2, 3, 4)), np.zeros((2, 3)), np.zeros((3, 3)), np.array([-1, 0, 1]),
                      np.zeros(0, np.int64), np.zeros((2, 0, 3)), np.zeros(0, np.int64), np.zeros((0, 3)),
                      np.zeros((2, 2, 3)), None),  # too small an output
    lambda: _ccore.columns_to_quat(2, np.zeros((4, 3)), np.array([[0, 1, 3]]), np.zeros((1, 3), np.int64),
                                   np.array([0]), np.zeros((4, 1, 4))),  # a column outside the features
    lambda: _ccore.columns_to_quat(0, np.zeros((4, 4)), np.array([[0, 1, 2, 3]]), None, np.array([1]),
                                   np.zeros((4, 1, 4))),  # a joint outside the output
    lambda: _ccore.quat_to_euler(np.zeros((4, 4)), "xyz", False, np.zeros((3, 3))),  # too small an output
    lambda: _ccore.quat_to_euler(np.zeros((4, 4)), "xYz", False, np.zeros((4, 3))),  # mixed case
    lambda: _ccore.quat_to_euler(np.zeros((4, 4)), "xxz", False, np.zeros((4, 3))),  # an axis twice in a row
    lambda: _ccore.quat_to_euler(np.zeros((4, 4)), "xy", False, np.zeros((4, 3))),  # two axes
    lambda: _ccore.scan(b"1 2 3", 3, 5, True, np.zeros(4), np.zeros((8, 4), np.int64), np.zeros(8, np.int64)),
    lambda: _ccore.format_shortest(np.zeros(10), 2, np.zeros(100, np.uint8), np.zeros((4, 2), np.int64)),
])
def test_the_core_refuses_arrays_that_do_not_fit(call):
    """The last line of defence (the Python callers check first): sizes that would read or write out of bounds
    raise ValueError, a wrong element type TypeError, never a crash."""
    with pytest.raises(ValueError):
        call()


def test_the_core_refuses_wrong_element_types():
    with pytest.raises(TypeError, match="float64"):
        _ccore.format_shortest(np.zeros(3, np.float32), 1, np.zeros(100, np.uint8), np.zeros((4, 2), np.int64))
    with pytest.raises(TypeError, match="int64"):
        _ccore.columns_to_quat(0, np.zeros((4, 4)), np.array([[0, 1, 2, 3]], np.int32), None, np.array([0]),
                               np.zeros((4, 1, 4)))
    with pytest.raises(TypeError, match="writable"):
        out = np.zeros((4, 1, 4))
        out.flags.writeable = False
        _ccore.columns_to_quat(0, np.ones((4, 4)), np.array([[0, 1, 2, 3]]), None, np.array([0]), out)


SEQS = [a + b + c for a in "xyz" for b in "xyz" for c in "xyz" if a != b and b != c]


@pytest.mark.parametrize("seq", SEQS + [o.upper() for o in SEQS])
def test_quaternions_to_euler_angles_are_scipys_bit_for_bit(seq):
    """``euler.c`` does scipy's operations (``Rotation.from_quat(q).as_euler(seq, degrees)``) in the same order with
    the same libm ``atan2`` and ``hypot``: the same bits, here compared bitwise with the scipy installed beside
    it (scipy's x86-64 wheels contract no multiply-add either), on random rotations of every size, edge values
    and rotations at and near gimbal lock; a zero or NaN quaternion is refused by both."""
    rng = np.random.default_rng(sum(map(ord, seq)))
    edges = np.array([0.0, -0.0, 1.0, -1.0, 0.5, -0.5, math.sqrt(0.5), -math.sqrt(0.5), 1e-9, -1e-9, 1e-300, 2.0,
                      np.inf, -np.inf])
    angles = rng.uniform(-np.pi, np.pi, (3000, 3))
    lock = np.pi / 2 if seq[0].lower() != seq[2].lower() else 0.0
    angles[:1000, 1] = lock + rng.normal(size=1000) * 10.0 ** rng.integers(-12, -5, 1000)
    angles[1000:2000, 1] = (-lock if lock else np.pi) + rng.normal(size=1000) * 10.0 ** rng.integers(-12, -5, 1000)
    q = np.concatenate([rng.normal(size=(3000, 4)), rng.normal(size=(500, 4)) * 1e-150,
                        rng.normal(size=(500, 4)) * 1e150, rng.choice(edges, (3000, 4)),
                        Rotation.from_euler(seq, angles).as_quat()])
    norm = np.sqrt(((q[:, 0] * q[:, 0] + q[:, 1] * q[:, 1]) + q[:, 2] * q[:, 2]) + q[:, 3] * q[:, 3])
    refused = (norm == 0) | np.isnan(norm)
    q = np.ascontiguousarray(q[~refused])
    for degrees in (False, True):
        with np.errstate(all="ignore"), pytest.warns(UserWarning, match="Gimbal lock"):
            expected = Rotation.from_quat(q).as_euler(seq, degrees=degrees)
        out = np.empty((len(q), 3))
        assert _ccore.quat_to_euler(q, seq, degrees, out) == -1
        assert np.array_equal(bits(out), bits(expected)) or np.array_equal(out, expected, equal_nan=True)
    for bad in ([0.0, 0.0, 0.0, 0.0], [np.nan, 0.0, 0.0, 1.0], [1e-300, 1e-300, 0.0, 0.0]):
        with pytest.raises(ValueError, match="zero norm"):
            Rotation.from_quat(bad)
        assert _ccore.quat_to_euler(np.array([[0.0, 0.0, 0.0, 1.0], bad]), seq, False, np.empty((2, 3))) == 1
    with pytest.raises(ValueError, match="zero norm"):
        R.quat_to_euler(np.zeros((2, 4)), seq)


def test_quaternions_to_rotation_vectors_are_scipys_bit_for_bit():
    """``rotations.c``'s ``mr_quat_to_axis_angle`` does scipy's operations (``Rotation.from_quat(q).as_rotvec()``)
    in the same order with the same libm ``atan2`` and ``sin``: the same bits, compared bitwise with the scipy
    installed beside it (as the Euler test above), on random rotations of every size and sign of w, angles near 0
    (the series below 1e-3, and on both sides of it), near pi, edge values and overflowing lengths; a zero or NaN
    quaternion is refused by both, and R.quat_to_axis_angle raises scipy's error for it."""
    rng = np.random.default_rng(7)
    edges = np.array([0.0, -0.0, 1.0, -1.0, 0.5, -0.5, math.sqrt(0.5), -math.sqrt(0.5), 1e-9, -1e-9, 1e-300, 2.0,
                      np.inf, -np.inf])
    small = rng.normal(size=(3000, 4))
    small[:, :3] *= 10.0 ** rng.uniform(-12, -2, (3000, 1))  # angles from 1e-12 to about 1e-2
    small[::2, 3] *= -1.0
    near_pi = rng.normal(size=(1000, 4))
    near_pi[:, 3] *= 10.0 ** rng.uniform(-12, -1, 1000)
    q = np.concatenate([rng.normal(size=(5000, 4)), small, near_pi, rng.normal(size=(500, 4)) * 1e-150,
                        rng.normal(size=(500, 4)) * 1e150, rng.normal(size=(200, 4)) * 1e200,
                        rng.choice(edges, (3000, 4))])
    norm = np.sqrt(((q[:, 0] * q[:, 0] + q[:, 1] * q[:, 1]) + q[:, 2] * q[:, 2]) + q[:, 3] * q[:, 3])
    refused = (norm == 0) | np.isnan(norm)
    q = np.ascontiguousarray(q[~refused])
    with np.errstate(all="ignore"):
        expected = Rotation.from_quat(q).as_rotvec()
    out = np.empty((len(q), 3))
    assert _ccore.quat_to_axis_angle(q, out) == -1
    assert np.array_equal(bits(out), bits(expected)) or np.array_equal(out, expected, equal_nan=True)
    assert np.array_equal(bits(R.quat_to_axis_angle(q[:40].reshape(4, 10, 4))), bits(expected[:40]).reshape(4, 10, 3))
    for bad in ([0.0, 0.0, 0.0, 0.0], [np.nan, 0.0, 0.0, 1.0], [1e-300, 1e-300, 0.0, 0.0]):
        with pytest.raises(ValueError, match="zero norm"):
            Rotation.from_quat(bad)
        assert _ccore.quat_to_axis_angle(np.array([[0.0, 0.0, 0.0, 1.0], bad]), np.empty((2, 3))) == 1
        with pytest.raises(ValueError, match="zero norm"):
            R.quat_to_axis_angle(np.array([[0.0, 0.0, 0.0, 1.0], bad]))
    with pytest.raises(ValueError, match="shape"):
        _ccore.quat_to_axis_angle(np.zeros((2, 3)), np.empty((2, 3)))
