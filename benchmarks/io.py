"""BVH read, BVH write and forward-kinematics throughput, side by side with numpy.loadtxt and pybvh, and beside a
base revision.

Usage::

    python benchmarks/io.py [DATA_DIR] [--min-kb 200] [--repeat 7] [--files PATTERN ...] [--base REV] [--rounds 2]

Reads every BVH file of at least ``--min-kb`` kilobytes under DATA_DIR (default ``../shared/data`` next to the
repository; ``edge/malformed`` is skipped) and times, best of ``--repeat`` runs each, in the same process:

* **read** -- motionrep ``read_bvh(path)`` (parse, validate, Euler angles to quaternions, a ``Motion``);
  ``numpy.loadtxt(path, skiprows=<header lines>)`` of the same frame numbers (no hierarchy, no rotations);
  pybvh ``read_bvh_file(path, world_up="+y")`` (its fastest setting: no up-axis detection).
* **write** -- ``format_bvh(motion)`` of the clip read (the file's own angles, shortest decimals).
* **FK** -- motionrep ``global_positions(motion)`` and pybvh ``frames_to_node_positions(bvh, root_pos,
  joint_angles)``: world positions of every joint and end site of every frame.
* **fresh process** -- each file read once, in file order, by a fresh process that has only imported
  ``motionrep.io`` (first-call costs included: what ``motionrep info``, ``convert`` or a script reading a few clips
  pays), against ``numpy.loadtxt`` the same way in another fresh process; the import times are given apart.

Throughput is file megabytes per second for reading and writing (the size of the file read) and joint-frames
(frames x (joints + end sites)) per second for FK; totals are sums of sizes over sums of times.  Ratios are
ours / theirs (above 1: motionrep is faster).

``--base REV`` (e.g. ``main``) measures that revision's code too (``git archive`` of its ``motionrep/`` and
``plugins/`` put first on ``PYTHONPATH``), in child processes alternating with this checkout's, ``--rounds`` times
each, each figure the best over the rounds: both see the same load.  A base whose reader still has two paths
(before the compiled core) is timed on its compiled path, its fastest, with numba loaded first.

pybvh is optional: run this script with an interpreter where it is installed (it is not a motionrep dependency);
without it those columns are skipped.  pybvh only reads files whose root has 6 channels and every other joint 3
rotation channels; its ratios are over the files it reads.
"""

from __future__ import annotations

import argparse
import gc
import inspect
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
#: Clips of at least this many frames count as long for the FK figure.
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


_FRESH = """
import sys, time
t0 = time.perf_counter()
import numpy as np
if sys.argv[1] == "ours":
    import motionrep.io as mio
t1 = time.perf_counter()
times = []
cpu = time.process_time()
for path, skip in zip(sys.argv[2::2], sys.argv[3::2]):
    start = time.perf_counter()
    if sys.argv[1] == "ours":
        mio.read_bvh(path)
    else:
        np.loadtxt(path, skiprows=int(skip), ndmin=2)
    times.append(time.perf_counter() - start)
print(t1 - t0, time.process_time() - cpu, *times)
"""


def fresh_process(files: list[Path], who: str, env: dict[str, str]) -> dict:
    """Seconds of a fresh process reading each file once, in order (``who``: "ours" or "loadtxt"), the CPU time of
    all the reads (user + system: a loaded machine inflates it less than the wall clock), and the import."""
    args = [a for p in files for a in (str(p), str(header_lines(p)))]
    out = subprocess.run([sys.executable, "-c", _FRESH, who, *args], capture_output=True, text=True, check=True,
                         env=env, cwd=tempfile.gettempdir()).stdout.split()
    return {"import": float(out[0]), "cpu": float(out[1]), "reads": [float(t) for t in out[2:]]}


def measure(files: list[Path], repeat: int) -> dict:
    """Every in-process figure of this interpreter's motionrep, per file."""
    from motionrep.io import format_bvh, parse_bvh, read_bvh
    from motionrep.model.kinematics import global_positions

    try:  # optional comparison
        from pybvh import frames_to_node_positions, read_bvh_file
    except ImportError:  # pragma: no cover - depends on the environment
        read_bvh_file = None
    if "compiled" in inspect.signature(parse_bvh).parameters:  # a base with two paths: its compiled one
        parse_bvh(files[0].read_bytes(), compiled=True)
    rows = {}
    for path in files:
        skip = header_lines(path)
        motion = read_bvh(path)
        row = {"mb": path.stat().st_size / 1e6, "frames": motion.num_frames,
               "points": motion.num_frames * (motion.num_joints + motion.skeleton.num_end_sites)}
        row["read"] = best_time(lambda: read_bvh(path), repeat)
        row["loadtxt"] = best_time(lambda: np.loadtxt(path, skiprows=skip, ndmin=2), repeat)
        row["write"] = best_time(lambda: format_bvh(motion), repeat)
        row["fk"] = best_time(lambda: global_positions(motion), repeat)
        if read_bvh_file is not None:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                try:
                    bvh = read_bvh_file(path, world_up="+y")
                except Exception:  # noqa: BLE001 - pybvh does not read every layout
                    bvh = None
                if bvh is not None:
                    row["pybvh_read"] = best_time(lambda: read_bvh_file(path, world_up="+y"), repeat)
                    positions = frames_to_node_positions(bvh, root_pos=bvh.root_pos, joint_angles=bvh.joint_angles)
                    if positions.shape == global_positions(motion).shape:  # the same points
                        row["pybvh_fk"] = best_time(lambda: frames_to_node_positions(
                            bvh, root_pos=bvh.root_pos, joint_angles=bvh.joint_angles), repeat)
        rows[str(path)] = row
    return rows


def child_env(root: Path | None) -> dict[str, str]:
    env = dict(os.environ)
    if root is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(root), str(root / "plugins")])
    return env


def run_child(root: Path | None, files: list[Path], repeat: int, into: Path) -> dict:
    """The figures of ``root``'s code (None: this checkout), measured in a child process."""
    env = child_env(root if root is not None else REPO)
    subprocess.run([sys.executable, str(Path(__file__).resolve()), "--child", str(into), "--repeat", str(repeat),
                    "--files-exact", *map(str, files)], check=True, env=env, cwd=tempfile.gettempdir())
    result = json.loads(into.read_text())
    result["fresh_ours"] = fresh_process(files, "ours", env)
    result["fresh_loadtxt"] = fresh_process(files, "loadtxt", env)
    return result


def merge(runs: list[dict]) -> dict:
    """Per file and figure, the best (smallest) time over the rounds."""
    out = {"rows": {}, "fresh_ours": None, "fresh_loadtxt": None}
    for run in runs:
        for path, row in run["rows"].items():
            best = out["rows"].setdefault(path, dict(row))
            for key, value in row.items():
                if key not in ("mb", "frames", "points"):
                    best[key] = min(best.get(key, value), value)
        for key in ("fresh_ours", "fresh_loadtxt"):
            if out[key] is None or sum(run[key]["reads"]) < sum(out[key]["reads"]):
                out[key] = run[key]
    return out


def totals(result: dict) -> dict:
    rows = list(result["rows"].values())

    def rate(size_key, key, subset=rows):
        return sum(r[size_key] for r in subset) / sum(r[key] for r in subset)

    long = [r for r in rows if r["frames"] >= LONG_FRAMES] or rows
    out = {"read MB/s": rate("mb", "read"), "loadtxt MB/s": rate("mb", "loadtxt"),
           "read / loadtxt": rate("mb", "read") / rate("mb", "loadtxt"), "write MB/s": rate("mb", "write"),
           "FK M joint-frames/s": rate("points", "fk") / 1e6,
           "FK M joint-frames/s (long clips)": rate("points", "fk", long) / 1e6}
    with_pybvh = [r for r in rows if "pybvh_read" in r]
    if with_pybvh:
        out["read / pybvh"] = rate("mb", "read", with_pybvh) / rate("mb", "pybvh_read", with_pybvh)
    ours, lt = result["fresh_ours"], result["fresh_loadtxt"]
    mb = sum(r["mb"] for r in rows)
    out["fresh process: read MB/s"] = mb / sum(ours["reads"])
    out["fresh process: loadtxt MB/s"] = mb / sum(lt["reads"])
    out["fresh process: read / loadtxt"] = sum(lt["reads"]) / sum(ours["reads"])
    out["fresh process: read / loadtxt, CPU time"] = lt["cpu"] / ours["cpu"]
    out["fresh process: import motionrep.io s"] = ours["import"]
    out["fresh process: import numpy s"] = lt["import"]
    out["fresh process: first file read s"] = ours["reads"][0]
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("data", nargs="?", default=str(REPO.parent / "shared" / "data"))
    parser.add_argument("--min-kb", type=float, default=200.0, help="skip smaller files (default 200)")
    parser.add_argument("--repeat", type=int, default=7, help="runs per measurement; the best counts (default 7)")
    parser.add_argument("--files", nargs="*", default=None, help="only files whose path contains one of these")
    parser.add_argument("--base", default=None, help="a revision to measure beside this checkout (e.g. main)")
    parser.add_argument("--rounds", type=int, default=2, help="alternating child runs per code tree (with --base)")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    parser.add_argument("--files-exact", nargs="*", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        files = [Path(p) for p in args.files_exact]
        Path(args.child).write_text(json.dumps({"rows": measure(files, args.repeat)}))
        return 0
    root = Path(args.data)
    files = sorted(p for p in root.rglob("*.bvh") if "malformed" not in p.parts
                   and p.stat().st_size >= args.min_kb * 1e3
                   and (not args.files or any(f in str(p) for f in args.files)))
    if not files:
        print(f"no BVH files of at least {args.min_kb:g} kB under {root}", file=sys.stderr)
        return 1
    load_start = os.getloadavg()
    head = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True).stdout.strip()
    print(f"motionrep BVH benchmark: {len(files)} files ({sum(p.stat().st_size for p in files) / 1e6:.1f} MB) from "
          f"{root}; load average {load_start[0]:.2f} {load_start[1]:.2f} {load_start[2]:.2f} ({os.cpu_count()} CPUs)")
    print(f"python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}, best of {args.repeat}"
          + (f", {args.rounds} alternating rounds" if args.base else ""))
    trees: dict[str, Path | None] = {}
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        if args.base:
            archive = subprocess.run(["git", "-C", str(REPO), "archive", args.base, "motionrep", "plugins"],
                                     capture_output=True, check=True)
            (tmp / "base").mkdir()
            subprocess.run(["tar", "-x", "-C", str(tmp / "base")], input=archive.stdout, check=True)
            trees[f"base ({args.base})"] = tmp / "base"
        trees[f"this ({head})"] = None
        runs: dict[str, list[dict]] = {name: [] for name in trees}
        for r in range(args.rounds if args.base else 1):
            for name, tree in trees.items():
                runs[name].append(run_child(tree, files, args.repeat, tmp / f"{r}.json"))
        results = {name: merge(rs) for name, rs in runs.items()}
    names = list(results)
    print(f"\n{'file':44s} {'MB':>5s} | " + " | ".join(
        f"{n[:22]:>22s}: read  write  FK Mjf/s" for n in names) + f" | {'loadtxt':>7s}")
    for path in files:
        key = str(path)
        rel = str(path.relative_to(root)) if path.is_relative_to(root) else key
        r0 = results[names[0]]["rows"][key]
        cells = []
        for n in names:
            r = results[n]["rows"][key]
            cells.append(f"{'':>22s}  {r['mb'] / r['read']:5.1f} {r['mb'] / r['write']:6.1f} "
                         f"{r['points'] / r['fk'] / 1e6:9.2f}")
        print(f"{rel[-44:]:44s} {r0['mb']:5.2f} | " + " | ".join(cells) + f" | {r0['mb'] / r0['loadtxt']:7.1f}")
    figures = {n: totals(results[n]) for n in names}
    print(f"\n{'figure':40s} " + " ".join(f"{n[:16]:>16s}" for n in names))
    for fig in figures[names[-1]]:
        print(f"{fig:40s} " + " ".join(f"{figures[n].get(fig, float('nan')):16.3f}" for n in names))
    load_end = os.getloadavg()
    print(f"\nload average at the start {load_start[0]:.2f}, at the end {load_end[0]:.2f} {load_end[1]:.2f} "
          f"{load_end[2]:.2f}")
    last = figures[names[-1]]
    print("target (issue 24): fresh process read / loadtxt >= 2 with one parser: "
          + ("met" if last["fresh process: read / loadtxt"] >= 2 else "not met") + " by wall time, "
          + ("met" if last["fresh process: read / loadtxt, CPU time"] >= 2 else "not met") + " by CPU time")
    return 0


if __name__ == "__main__":
    sys.exit(main())
