"""The compiled core (``motionrep._ccore``, C) against the numba kernels it replaced, bit for bit.

Runs the same computations in two processes, one on this checkout and one on a base revision whose kernels are
numba's (``--base``, default ``22eeb6c``: main before the C core; ``git archive`` of its ``motionrep/`` and
``plugins/`` put first on ``PYTHONPATH``, run by this interpreter, which has numba), and compares SHA-256 digests
of every result's bytes:

* ``read``: ``parse_bvh`` of every BVH file under the data directory (``edge/malformed`` included: there the error
  message, file and line); every array of the Motion.  The base reads by its compiled path (numba); its numpy path
  is compared too (``read-numpy``).
* ``scan``: the number scan of each file's whole text (every token, header words left to ``float``) and of its frame
  block by lines, every field of the result; and 200,020 generated tokens of every shape, whose values are also
  compared with Python's ``float`` in each process (``scan-float``).
* ``fk``: ``fk_arrays`` (positions and world rotations) of every clip, rotations float64 and float32.
* ``euler``: the BVH reader's Euler conversion of every clip (degrees), float64 and float32 features and outputs;
  random angles for every order of one, two and three axes, intrinsic and extrinsic, radians and degrees, with
  multiples of 90 degrees, signed zeros, huge, tiny and non-finite values.
* ``quat``, ``axis-angle``, ``ortho6d``: the other column conversions on every clip's rotations (as quaternions
  scaled, rotation vectors, 6D) and on random and degenerate inputs (the error text where one is raised).
* ``continuous``: ``axis_angle_make_continuous`` of every clip's rotation vectors and of random ones.
* ``writer``: the shortest-decimal BVH writer on ``--hostile`` hostile values (every magnitude, ties, powers of two
  and ten and their neighbours, signed zeros, subnormals, random bit patterns) and on every clip's channel values,
  the file's own angles and angles computed from its rotations (17-digit values).  The inputs are digested too
  (``writer-input``), so that a difference is the writer's, not its input's.

Usage::

    python benchmarks/ccore_equivalence.py [--base REV] [--data DIR] [--hostile 500000]

Prints one line per group (cases, identical, different) and the first differences; exit status 1 if any differs.
"""

from __future__ import annotations

import argparse
import hashlib
import inspect
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
#: main before the compiled core: every kernel numba's
DEFAULT_BASE = "22eeb6c"
ORDERS3 = [a + b + c for a in "XYZ" for b in "XYZ" for c in "XYZ" if a != b and b != c]
ORDERS = ORDERS3 + [o.lower() for o in ORDERS3] + ["XY", "ZX", "yz", "xz", "X", "y", "Z"]


def digest(*parts) -> str:
    """``exact|canonical``: SHA-256 of the parts' bytes (arrays) or reprs, as they are and with every NaN of a float
    array counted as one NaN.  IEEE leaves the sign and payload of a NaN result open, and a compiler orders the
    operands of ``a * b`` as it pleases: where an input is NaN or infinite, both sides give NaN, not always with the
    same sign bit.  The comparison counts the canonical digest, and says where only NaN bits differ."""
    exact, canonical = hashlib.sha256(), hashlib.sha256()
    for p in parts:
        for h, q in ((exact, p), (canonical, p)):
            if h is canonical and hasattr(q, "dtype") and q.dtype.kind == "f" and np.isnan(q).any():
                q = np.where(np.isnan(q), np.nan, q)
            if hasattr(q, "tobytes"):
                h.update(str(q.dtype).encode() + str(q.shape).encode())
                h.update(q.tobytes())
            else:
                h.update(repr(q).encode())
    return f"{exact.hexdigest()}|{canonical.hexdigest()}"


# ------------------------------------------------------------------------------------------------------------------
# one side: runs in its own process, on the motionrep first on PYTHONPATH
# ------------------------------------------------------------------------------------------------------------------
def _call(fn, *args, **kwargs):
    """``fn``'s result, or ``("error", type, text)`` when it raises (that is compared too)."""
    try:
        return fn(*args, **kwargs)
    except Exception as exc:  # noqa: BLE001 - every outcome is a result here
        return ("error", type(exc).__name__, str(exc))


def _compiled(fn):
    """``fn`` with ``compiled=True`` where it still takes that argument (the base's two paths)."""
    if "compiled" in inspect.signature(fn).parameters:
        return lambda *a, **k: fn(*a, compiled=True, **k)
    return fn


def _motion_digest(m) -> str:
    if isinstance(m, tuple):
        return digest(*m)
    return digest(m.root_translation, m.rotations, m.joint_translations, m.euler_angles, m.euler_branch, m.fps,
                  m.skeleton.offsets, m.skeleton.end_site_offsets, m.skeleton.channels, m.skeleton.names)


def _hostile(seed: int, n: int):
    import numpy as np

    rng = np.random.default_rng(seed)
    bits = rng.integers(0, 2 ** 64, size=n, dtype=np.uint64).view(np.float64)
    parts = [bits[np.isfinite(bits)], rng.uniform(-400, 400, n), rng.normal(size=n) * 10.0 ** rng.integers(-8, 19, n),
             rng.uniform(0.00099, 0.0011, n), rng.integers(-2 ** 53, 2 ** 53, n) / 10.0 ** rng.integers(0, 20, n),
             np.round(rng.uniform(-400, 400, n), 6), np.round(rng.uniform(-400, 400, n) * 3, 2) / 3]
    parts += [np.round(rng.uniform(-400, 400, n // 40), k) for k in range(18)]
    for k in range(-12, 19):
        for base in (10.0 ** k, 2.0 ** (3 * k), 5.0 * 10.0 ** k):
            parts.append(base * (1 + np.arange(-60, 61) * 2.0 ** -52))
    parts.append(np.array([0.0, -0.0, 5e-324, 2.2250738585072014e-308, 1e-4, 1e-3, 2.0 ** 52, 2.0 ** 52 + 0.5,
                           2.0 ** 53, 1.7976931348623157e308, 0.1, 0.3, 1 / 3, 123456789012345.6, 4503599627370495.5]))
    v = np.concatenate(parts)
    return np.concatenate([v, -v])


def _tokens(seed: int, n: int) -> list[str]:
    """Decimal tokens of every shape: signs, leading zeros, no integer or no fraction part, 1-20 significant digits,
    exponents down to subnormals and past the largest double, nan/inf spellings, junk."""
    import numpy as np

    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        sign = rng.choice(["", "", "-", "+"])
        whole = "".join(rng.choice(list("0123456789"), int(rng.integers(0, 11))))
        frac = "".join(rng.choice(list("0123456789"), int(rng.integers(0, 11))))
        if not whole and not frac:
            whole = "7"
        text = sign + whole + ("." + frac if rng.random() < 0.8 else frac)
        if rng.random() < 0.1:
            text += rng.choice(["e", "E"]) + rng.choice(["", "-", "+"]) + str(int(rng.integers(0, 330)))
        out.append(text)
    out += ["nan", "-inf", "Infinity", "1e400", "-1e-400", "4.9e-324", "1_000", "0x10", "1e", ".", "-", "+.",
            "1.2.3", "--1", "1-2", "12a", "9007199254740993", "123456789012345678901234567890", "0.30000000000000004",
            "2.2250738585072011e-308"]
    return out


def side(data: Path, hostile: int) -> dict[str, str]:
    import numpy as np

    from motionrep import Motion
    from motionrep.errors import ValidationError
    from motionrep.io import _shortest, parse_bvh
    from motionrep.io._bvh import channel_values
    from motionrep.io._numbers import scan_block
    from motionrep.model import rotations as R
    from motionrep.model.kinematics import fk_arrays

    np.seterr(over="ignore")  # float32 copies of the huge inputs are inf: intended
    write = getattr(_shortest, "format_shortest", None) or _shortest.format_shortest_compiled
    scan = _compiled(scan_block)
    euler = _compiled(R.euler_columns_to_quat)
    out: dict[str, str] = {}

    def scan_digest(s):
        return digest(s.values, s.rows, s.first_wrong_line, s.wrong_count, s.last_data_line, s.first_data_line,
                      s.extra_line, s.bad, s.nonfinite)

    def convert(fn, features, columns, joints, J, dtype, *extra):
        o = np.full((features.shape[0], J, 4), 7.0, dtype)
        r = _call(fn, features, columns, *extra[:1], joints, o, *extra[1:])
        return digest(o) if not isinstance(r, tuple) else digest(r, o)

    files = sorted(data.rglob("*.bvh"))
    rng = np.random.default_rng(2024)
    for path in files:
        name = str(path.relative_to(data))
        raw = path.read_bytes()
        m = _call(_compiled(parse_bvh), raw, str(path))
        out[f"read/{name}"] = _motion_digest(m)
        if "compiled" in inspect.signature(parse_bvh).parameters:
            out[f"read-numpy/{name}"] = _motion_digest(_call(parse_bvh, raw, str(path), compiled=False))
        u = np.frombuffer(raw, np.uint8)
        out[f"scan/{name}/tokens"] = scan_digest(scan(u, by_line=False))
        at = raw.find(b"Frame Time")
        if at >= 0 and not isinstance(m, tuple):
            block = u[raw.index(b"\n", at) + 1:] if b"\n" in raw[at:] else u[:0]
            C = m.skeleton.num_channels
            out[f"scan/{name}/block"] = scan_digest(scan(block, C, m.num_frames, True))
        if isinstance(m, tuple):
            continue
        sk = m.skeleton
        for dtype in (np.float64, np.float32):
            pos, rot = fk_arrays(sk, m.rotations.astype(dtype), m.root_translation, m.joint_translations, True)
            out[f"fk/{name}/{np.dtype(dtype).name}"] = digest(pos, rot)
        # the reader's own Euler conversion, every joint with rotation channels
        values = np.ascontiguousarray(channel_values(m))
        cols, joints, orders, col = [], [], [], 0
        for j, chans in enumerate(sk.channels):
            rc = [col + k for k, c in enumerate(chans) if c.endswith("rotation")]
            col += len(chans)
            if rc:
                orders.append(sk.rotation_orders[j])
                cols.append(rc)
                joints.append(j)
        if joints:
            positions, axes = R.euler_columns(orders)
            columns = np.array([[c[k] if k >= 0 else -1 for k in ks] for c, ks in zip(cols, positions.tolist())],
                               np.int64)
            J, jo = sk.num_joints, np.array(joints, np.int64)
            for dtype in (np.float64, np.float32):
                feats = values.astype(dtype)
                out[f"euler/{name}/{np.dtype(dtype).name}"] = convert(euler, feats, columns, jo, J, dtype, axes, True)
        q = m.rotations.reshape(-1, 4)
        scaled = q * rng.uniform(0.5, 2.0, (q.shape[0], 1))
        out[f"quat/{name}"] = convert(R.quat_columns_normalized, scaled, np.arange(4).reshape(1, 4),
                                      np.zeros(1, np.int64), 1, np.float64)
        rv = R.quat_to_axis_angle(q)
        out[f"axis-angle/{name}"] = convert(R.axis_angle_columns_to_quat, rv, np.arange(3).reshape(1, 3),
                                            np.zeros(1, np.int64), 1, np.float64)
        out[f"ortho6d/{name}"] = convert(R.ortho6d_columns_to_quat, R.quat_to_ortho6d(q), np.arange(6).reshape(1, 6),
                                         np.zeros(1, np.int64), 1, np.float64)
        out[f"continuous/{name}"] = digest(R.axis_angle_make_continuous(R.quat_to_axis_angle(m.rotations)))
        computed = Motion(sk, m.fps, m.root_translation, m.rotations, m.joint_translations)
        for label, motion in (("angles", m), ("computed", computed)):
            try:
                v = channel_values(motion)
            except ValidationError:
                continue
            if v.shape[1]:
                out[f"writer-input/{name}/{label}"] = digest(v)
                out[f"writer/{name}/{label}"] = digest(write(v))
    # random and hostile inputs
    rng = np.random.default_rng(7)
    special = np.array([0.0, -0.0, 90.0, -90.0, 180.0, -180.0, 270.0, 360.0, 720.0, -540.0, 1e-300, 5e-324, 1e6,
                        -1e7, 1e300, np.pi, -np.pi / 2, np.inf, -np.inf, np.nan])
    for order in ORDERS:
        n = len(order)
        angles = np.concatenate([rng.uniform(-400, 400, (3000, n)), rng.normal(0, 1e-4, (300, n)),
                                 rng.uniform(-1e7, 1e7, (300, n)), rng.choice(special, (400, n))])
        positions, axes = R.euler_columns([order])
        for unit, degrees in (("deg", True), ("rad", False)):
            for dtype in (np.float64, np.float32):
                out[f"euler/random/{order}/{unit}/{np.dtype(dtype).name}"] = convert(
                    euler, angles.astype(dtype), positions, np.zeros(1, np.int64), 1, dtype, axes, degrees)
    specials4 = np.array([0.0, -0.0, 1e-200, 1e200, np.inf, np.nan, 1.0, -1.0])
    quats = np.concatenate([rng.normal(size=(20000, 4)), rng.choice(specials4, (2000, 4))])
    for k in range(0, quats.shape[0], 500):  # small batches: an error in one is its own case
        out[f"quat/random/{k}"] = convert(R.quat_columns_normalized, quats[k:k + 500], np.arange(4).reshape(1, 4),
                                          np.zeros(1, np.int64), 1, np.float64)
    rv = np.concatenate([rng.normal(size=(20000, 3)) * 10.0 ** rng.integers(-8, 3, (20000, 1)),
                         rng.choice(specials4, (2000, 3))])
    out["axis-angle/random"] = convert(R.axis_angle_columns_to_quat, rv, np.arange(3).reshape(1, 3),
                                       np.zeros(1, np.int64), 1, np.float64)
    out["axis-angle/random/float32"] = convert(R.axis_angle_columns_to_quat, rv.astype(np.float32),
                                               np.arange(3).reshape(1, 3), np.zeros(1, np.int64), 1, np.float32)
    d6 = np.concatenate([rng.normal(size=(20000, 6)), rng.choice(specials4, (2000, 6))])
    d6[:50, 3:] = d6[:50, :3] * 2.0  # parallel columns: degenerate
    for k in range(0, d6.shape[0], 500):
        out[f"ortho6d/random/{k}"] = convert(R.ortho6d_columns_to_quat, d6[k:k + 500], np.arange(6).reshape(1, 6),
                                             np.zeros(1, np.int64), 1, np.float64)
    walk = np.cumsum(rng.normal(size=(500, 7, 3)) * 0.8, axis=0)
    walk[100:110] = 0.0  # no rotation: the previous axis is kept
    out["continuous/random"] = digest(R.axis_angle_make_continuous(walk))
    written = 0
    for seed in range(max(1, hostile // 250_000)):
        v = _hostile(seed, max(1, hostile // 30))
        written += v.size
        for columns in (1, 7):
            w = v[:v.size // columns * columns].reshape(-1, columns)
            out[f"writer-input/hostile/{seed}/{columns}"] = digest(w)
            out[f"writer/hostile/{seed}/{columns}"] = digest(write(w))
    out["_count/writer-hostile"] = str(written)
    tokens = _tokens(11, 200_000)
    text = "\n".join(" ".join(tokens[k:k + 10]) for k in range(0, len(tokens), 10)).encode()
    s = scan(np.frombuffer(text, np.uint8), by_line=False)
    out["scan/generated"] = scan_digest(s)
    good = [t for t in tokens if _call(float, t) is not None and not isinstance(_call(float, t), tuple)
            and "_" not in t]
    ok = all(not np.isnan(a) and a == b and np.signbit(a) == np.signbit(b) or (np.isnan(a) and np.isnan(b))
             for a, b in zip(scan(np.frombuffer(" ".join(good).encode(), np.uint8), by_line=False).values.tolist(),
                             [float(t) for t in good]))
    out["scan-float/generated"] = f"equal to float() on {len(good)} tokens: {ok}"
    out["_count/scan-float"] = str(len(good))
    return out


# ------------------------------------------------------------------------------------------------------------------
# the driver
# ------------------------------------------------------------------------------------------------------------------
def run_side(root: Path, data: Path, hostile: int, into: Path) -> dict[str, str]:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(root), str(root / "plugins")]))
    env.pop("MOTIONREP_COMPILE_NOTICE", None)
    subprocess.run([sys.executable, str(Path(__file__).resolve()), "--side", str(into), "--data", str(data),
                    "--hostile", str(hostile)], check=True, env=env, cwd=tempfile.gettempdir())
    return json.loads(into.read_text())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--base", default=DEFAULT_BASE, help="the revision with numba's kernels")
    parser.add_argument("--data", default=str(REPO.parent / "shared" / "data"))
    parser.add_argument("--hostile", type=int, default=500_000, help="hostile values for the writer (about)")
    parser.add_argument("--side", help=argparse.SUPPRESS)
    args = parser.parse_args()
    data = Path(args.data)
    if args.side:
        Path(args.side).write_text(json.dumps(side(data, args.hostile)))
        return 0
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        archive = subprocess.run(["git", "-C", str(REPO), "archive", args.base, "motionrep", "plugins"],
                                 capture_output=True, check=True)
        (tmp / "base").mkdir()
        subprocess.run(["tar", "-x", "-C", str(tmp / "base")], input=archive.stdout, check=True)
        start = time.time()
        base = run_side(tmp / "base", data, args.hostile, tmp / "base.json")
        this = run_side(REPO, data, args.hostile, tmp / "this.json")
    head = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True).stdout.strip()
    print(f"base {args.base} (numba) against this checkout ({head}), data {data}, {time.time() - start:.0f} s")
    groups: dict[str, list[int]] = {}
    different, nan_bits = [], []
    for key in sorted(set(base) | set(this)):
        if key.startswith("_count"):
            continue
        group = key.split("/", 1)[0]
        g = groups.setdefault(group, [0, 0, 0])
        g[0] += 1
        a = base.get(key, "")
        b = this.get(key.replace("read-numpy/", "read/", 1) if key.startswith("read-numpy/") else key, "")
        same = a.rpartition("|")[2] == b.rpartition("|")[2] and a != "" and b != ""  # read-numpy: the base's numpy path
        g[1 if same else 2] += 1
        if not same:
            different.append(key)
        elif a != b:
            nan_bits.append(key)
    print(f"{'group':14s} {'cases':>6s} {'identical':>9s} {'different':>9s}")
    for group, (n, same, diff) in groups.items():
        print(f"{group:14s} {n:6d} {same:9d} {diff:9d}")
    print(f"identical but for the sign of NaN results (NaN or infinite inputs): {len(nan_bits)} cases"
          + (f", e.g. {', '.join(nan_bits[:6])}" if nan_bits else ""))
    print(f"hostile values written: {this.get('_count/writer-hostile')}")
    print(f"scan against float(): base: {base.get('scan-float/generated')}; this: {this.get('scan-float/generated')}")
    for key in different[:20]:
        print(f"  different: {key}: base {base.get(key, '-')[:60]} this {this.get(key, '-')[:60]}")
    return 1 if different else 0


if __name__ == "__main__":
    sys.exit(main())
