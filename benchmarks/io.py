"""BVH read and forward-kinematics throughput, side by side with numpy.loadtxt and pybvh.

Usage::

    python benchmarks/io.py [DATA_DIR] [--min-kb 200] [--repeat 7] [--files PATTERN ...]

Reads every BVH file of at least ``--min-kb`` kilobytes under DATA_DIR (default ``../shared/data`` next to the
repository; ``edge/malformed`` is skipped) and times, best of ``--repeat`` runs each, in the same process:

* **read** -- motionrep ``read_bvh(path)`` (parse, validate, Euler angles to quaternions, a ``Motion``) with the
  compiled loops (numba is loaded before timing, as in any process that has read more than a few MB); its numpy
  path (``parse_bvh(path.read_bytes(), compiled=False)``: what a process uses until then, so that reading one clip
  never imports numba);
  ``numpy.loadtxt(path, skiprows=<header lines>)`` of the same frame numbers (no hierarchy, no rotations);
  pybvh ``read_bvh_file(path, world_up="+y")`` (its fastest setting: no up-axis detection).
* **FK** -- motionrep ``global_positions(motion)`` and pybvh ``frames_to_node_positions(bvh, root_pos,
  joint_angles)``: world positions of every joint and end site of every frame.

Throughput is file megabytes per second for reading and joint-frames (frames x (joints + end sites)) per second
for FK; totals are sums of sizes over sums of times.  The summary gives each figure beside the one before the
compiled reader and FK and beside its target, with the load average at the start and the end, and the start-up
of a fresh process reading the smallest file, by the numpy path (the default there) and by the compiled loops
(numba's import and cached machine code): with the two paths' rates this gives the break-even behind
``motionrep.io._numbers.NUMPY_PATH_BUDGET``.  The ratio columns are ours / theirs (above 1: motionrep is
faster).  pybvh is optional: run this script with an interpreter where it is installed (it is not a motionrep
dependency); without it those columns are skipped.  pybvh only reads files whose root has 6 channels and every
other joint 3 rotation channels; its ratios are over the files it reads.
"""

from __future__ import annotations

import argparse
import gc
import os
import platform
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from motionrep.io import parse_bvh, read_bvh
from motionrep.io._numbers import NUMPY_PATH_BUDGET
from motionrep.model.kinematics import global_positions

try:  # optional comparison
    import pybvh
    from pybvh import frames_to_node_positions, read_bvh_file
except ImportError:  # pragma: no cover - depends on the environment
    pybvh = None

REPO = Path(__file__).resolve().parent.parent

#: Figures before the compiled reader and FK (benchmarks/README.md, code of 2026-11-22, load 3-6) and the targets
#: of issue 12: (previous, target).
PREVIOUS_AND_TARGET = {"read / loadtxt": (0.64, 1.0), "read / pybvh": (0.77, 1.0),
                       "FK M joint-frames/s (long clips)": (5.8, 20.0)}
#: Clips of at least this many frames count as long for the FK target.
LONG_FRAMES = 1000


def best_time(fn, repeat: int) -> float:
    """The fastest of ``repeat`` runs of ``fn()`` in seconds (garbage collection off while timing)."""
    best = float("inf")
    gc.collect()
    gc.disable()
    try:
        for _ in range(repeat):
            start = time.perf_counter()
            fn()
            best = min(best, time.perf_counter() - start)
    finally:
        gc.enable()
    return best


def header_lines(path: Path) -> int:
    """Number of lines up to and including ``Frame Time:`` (what loadtxt must skip)."""
    with open(path, "rb") as f:
        for n, line in enumerate(f, start=1):
            if line.lstrip().startswith(b"Frame Time"):
                return n
    raise ValueError(f"{path}: no Frame Time line")


def bench_file(path: Path, repeat: int) -> dict:
    size = path.stat().st_size
    skip = header_lines(path)
    row: dict = {"file": path, "mb": size / 1e6}
    motion = read_bvh(path)
    points = motion.num_frames * (motion.num_joints + motion.skeleton.num_end_sites)
    row["points"] = points
    row["frames"] = motion.num_frames
    row["ours_read"] = best_time(lambda: read_bvh(path), repeat)
    row["numpy_read"] = best_time(lambda: parse_bvh(path.read_bytes(), path, compiled=False), repeat)
    row["loadtxt_read"] = best_time(lambda: np.loadtxt(path, skiprows=skip, ndmin=2), repeat)
    row["ours_fk"] = best_time(lambda: global_positions(motion), repeat)
    if pybvh is not None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                bvh = read_bvh_file(path, world_up="+y")
            except Exception:  # noqa: BLE001 - pybvh does not read every layout
                bvh = None
            if bvh is not None:
                row["pybvh_read"] = best_time(lambda: read_bvh_file(path, world_up="+y"), repeat)
                positions = frames_to_node_positions(bvh, root_pos=bvh.root_pos, joint_angles=bvh.joint_angles)
                ours = global_positions(motion)
                if positions.shape == ours.shape:  # same points (pybvh orders end sites among the joints)
                    row["pybvh_fk"] = best_time(
                        lambda: frames_to_node_positions(bvh, root_pos=bvh.root_pos, joint_angles=bvh.joint_angles),
                        repeat)
    return row


_START_UP = """
import sys, time
from pathlib import Path
t0 = time.perf_counter()
import motionrep.io
t1 = time.perf_counter()
motionrep.io.parse_bvh(Path(sys.argv[1]).read_bytes(), compiled=sys.argv[2] == "compiled")
t2 = time.perf_counter()
motionrep.io.parse_bvh(Path(sys.argv[1]).read_bytes(), compiled=sys.argv[2] == "compiled")
t3 = time.perf_counter()
print(t1 - t0, t2 - t1, t3 - t2, "numba" in sys.modules)
"""


def start_up(path: Path, path_kind: str = "numpy") -> dict:
    """Seconds of a fresh process to import ``motionrep.io``, read ``path`` once by ``path_kind`` ("numpy", or
    "compiled": numba is imported and loads the cached machine code of the reader's loops then) and read it
    again (median of three processes)."""
    runs = []
    for _ in range(3):
        out = subprocess.run([sys.executable, "-c", _START_UP, str(path), path_kind], capture_output=True, text=True,
                             check=True)
        a, b, c, numba = out.stdout.split()
        runs.append((float(a), float(b), float(c), numba == "True"))
    runs.sort(key=lambda r: r[1])
    a, b, c, numba = runs[1]
    return {"import": a, "first_read": b, "second_read": c, "numba": numba}


def rate(total, seconds) -> float:
    return total / seconds if seconds > 0 else float("nan")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("data", nargs="?", default=str(REPO.parent / "shared" / "data"))
    parser.add_argument("--min-kb", type=float, default=200.0, help="skip smaller files (default 200)")
    parser.add_argument("--repeat", type=int, default=7, help="runs per measurement; the best counts (default 7)")
    parser.add_argument("--files", nargs="*", default=None, help="only files whose path contains one of these")
    args = parser.parse_args(argv)
    root = Path(args.data)
    files = sorted(p for p in root.rglob("*.bvh") if "malformed" not in p.parts
                   and p.stat().st_size >= args.min_kb * 1e3
                   and (not args.files or any(f in str(p) for f in args.files)))
    if not files:
        print(f"no BVH files of at least {args.min_kb:g} kB under {root}", file=sys.stderr)
        return 1
    load_start = os.getloadavg()[0]
    print(f"motionrep BVH benchmark: {len(files)} files from {root}; load average {load_start:.2f} "
          f"({os.cpu_count()} CPUs)")
    print(f"python {platform.python_version()}, numpy {np.__version__}, "
          f"pybvh {getattr(pybvh, '__version__', 'not installed')}, {platform.machine()}, "
          f"{platform.processor() or 'cpu'}, best of {args.repeat}")
    head = f"{'file':48s} {'MB':>5s} | {'read MB/s: ours':>15s} {'numpy path':>10s} {'loadtxt':>8s} {'pybvh':>7s} | " \
           f"{'FK M jf/s: ours':>15s} {'pybvh':>7s}"
    print(head)
    print("-" * len(head))
    parse_bvh(files[0].read_bytes(), compiled=True)  # numba and the reader's kernels loaded: read_bvh runs compiled
    rows = []
    for path in files:
        r = bench_file(path, args.repeat)
        rows.append(r)
        name = str(path.relative_to(root)) if path.is_relative_to(root) else str(path)
        pyr = f"{r['mb'] / r['pybvh_read']:7.1f}" if "pybvh_read" in r else f"{'-':>7s}"
        pyf = f"{r['points'] / r['pybvh_fk'] / 1e6:7.2f}" if "pybvh_fk" in r else f"{'-':>7s}"
        print(f"{name[-48:]:48s} {r['mb']:5.2f} | {r['mb'] / r['ours_read']:15.1f} {r['mb'] / r['numpy_read']:10.1f} "
              f"{r['mb'] / r['loadtxt_read']:8.1f} {pyr} | {r['points'] / r['ours_fk'] / 1e6:15.2f} {pyf}")

    def total(key, rows_, size_key="mb"):
        return rate(sum(r[size_key] for r in rows_), sum(r[key] for r in rows_))

    print("-" * len(head))
    read_ours, read_lt = total("ours_read", rows), total("loadtxt_read", rows)
    fk_ours = total("ours_fk", rows, "points") / 1e6
    read_np = total("numpy_read", rows)
    print(f"all {len(rows)} files: read {read_ours:.1f} MB/s (loadtxt {read_lt:.1f} MB/s, ours/loadtxt "
          f"{read_ours / read_lt:.2f}); numpy path {read_np:.1f} MB/s ({read_np / read_lt:.2f}x loadtxt); "
          f"FK {fk_ours:.2f} M joint-frames/s")
    figures = {"read / loadtxt": read_ours / read_lt}
    long = [r for r in rows if r["frames"] >= LONG_FRAMES]
    if long:
        figures["FK M joint-frames/s (long clips)"] = total("ours_fk", long, "points") / 1e6
    with_read = [r for r in rows if "pybvh_read" in r]
    with_fk = [r for r in rows if "pybvh_fk" in r]
    if with_read:
        a, b = total("ours_read", with_read), total("pybvh_read", with_read)
        figures["read / pybvh"] = a / b
        print(f"{len(with_read)} files pybvh reads: read ours {a:.1f} MB/s, pybvh {b:.1f} MB/s, "
              f"ours/pybvh {a / b:.2f}")
    if with_fk:
        a, b = total("ours_fk", with_fk, "points") / 1e6, total("pybvh_fk", with_fk, "points") / 1e6
        print(f"{len(with_fk)} files: FK ours {a:.2f} M joint-frames/s, pybvh {b:.2f}, ours/pybvh {a / b:.2f}")
    if pybvh is None:
        print("pybvh not installed: its columns are skipped")
    print(f"\nagainst the targets (load average {load_start:.2f} at the start, {os.getloadavg()[0]:.2f} at the end):")
    print(f"{'figure':36s} {'previous':>9s} {'now':>9s} {'target':>9s}  met")
    for name, (previous, target) in PREVIOUS_AND_TARGET.items():
        now = figures.get(name)
        shown = "-" if now is None else f"{now:9.2f}"
        met = "-" if now is None else ("yes" if now >= target else "no")
        print(f"{name:36s} {previous:9.2f} {shown:>9s} {'>= ' + format(target, 'g'):>9s}  {met}")
    small = min(files, key=lambda p: p.stat().st_size)
    kb = small.stat().st_size / 1e3
    print(f"\nfresh process, import motionrep.io and read the smallest file twice ({small.name}, {kb:.0f} kB), "
          f"median of 3 processes:")
    first = {}
    for kind in ("numpy", "compiled"):
        start = start_up(small, kind)
        first[kind] = start["first_read"]
        print(f"  {kind + ' path':14s} {start['import']:.2f} s import, {start['first_read']:.3f} s first read, "
              f"{start['second_read'] * 1e3:.1f} ms second read; numba imported: {start['numba']}")
    # numba's start-up: the compiled first read less its second read; it is won back after reading
    # start-up / (1 / numpy rate - 1 / compiled rate) megabytes
    fixed = first["compiled"] - first["numpy"] + sum(r["numpy_read"] - r["ours_read"] for r in rows if r["file"] == small)
    per_mb = sum(r["numpy_read"] - r["ours_read"] for r in rows) / sum(r["mb"] for r in rows)
    print(f"numba's start-up in a fresh process ~{fixed:.2f} s; the numpy path costs {per_mb:.3f} s per MB more: "
          f"break-even at ~{fixed / per_mb:.0f} MB read in one process "
          f"(motionrep reads {NUMPY_PATH_BUDGET / 1e6:g} MB by the numpy path before it switches)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
