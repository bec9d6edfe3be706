"""Encode CPU time per clip and bound, tree beside tree (issue 25: at most 2x commit 7b11737's time per clip).

``measure`` encodes every CMU-31 clip of ``../shared/data`` (``rate4.py``'s list) with ``transform`` at 2 %,
0.588 % and 0.0588 % in one process (``compress_motion``, the clip already read, one warm-up encode first) and
writes, per ``clip@bound``, the best CPU time (user + system of the process) of ``--repeats`` rounds and the
SHA-256 of the payload's arrays, with the load average before and after. It measures whichever motionrep the
interpreter imports, so another revision is measured by putting a built tree of it first on ``PYTHONPATH``::

    git archive 7b11737 | tar -x -C /tmp/b7 && (cd /tmp/b7 && python setup.py -q build_ext --inplace)
    PYTHONPATH=/tmp/b7:/tmp/b7/plugins python benchmarks/encode_trees.py measure /tmp/b7_1.json
    python benchmarks/encode_trees.py measure /tmp/this_1.json          # this checkout; alternate the two

``table`` prints the per-clip table of the best time over every file given for each side, the ratio, and per
bound the median and largest ratio; it also says whether each side wrote the same payloads in all its runs.

Run: python benchmarks/encode_trees.py measure OUT.json [--repeats 3]
     python benchmarks/encode_trees.py table --base B1.json [B2.json ...] --this T1.json [T2.json ...]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import statistics
import sys
import time
from pathlib import Path

BOUNDS = (2.0, 0.588, 0.0588)


def measure(out: str, repeats: int) -> None:
    import numpy as np

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from rate4 import _clips

    from motionrep.io import read
    from motionrep.pipeline.compress import compress_motion

    clips = _clips()
    if not clips:
        raise SystemExit("no CMU-31 clips: ../shared/data is not there")
    motions = [(str(p).split("/data/")[1][:-4], read(p)) for p in clips]
    compress_motion(motions[0][1], "transform", max_error="2%")  # warm-up: imports, the kernels' first calls
    best: dict[str, float] = {}
    sha: dict[str, str] = {}
    load = [os.getloadavg()[0]]
    for _ in range(repeats):
        for name, motion in motions:
            for bound in BOUNDS:
                start = time.process_time()
                result = compress_motion(motion, "transform", max_error=f"{bound:g}%")
                key = f"{name}@{bound:g}"
                best[key] = min(best.get(key, float("inf")), time.process_time() - start)
                arrays = result.container.arrays
                sha[key] = hashlib.sha256(b"".join(np.ascontiguousarray(arrays[a]).tobytes()
                                                   for a in sorted(arrays))).hexdigest()
    load.append(os.getloadavg()[0])
    Path(out).write_text(json.dumps({"load": load, "cpu": best, "sha": sha}))
    print(f"wrote {out}: {len(best)} encodes, best of {repeats}, load {load[0]:.2f} -> {load[1]:.2f}")


def table(base: list[str], this: list[str]) -> None:
    B = [json.loads(Path(f).read_text()) for f in base]
    T = [json.loads(Path(f).read_text()) for f in this]
    for label, runs in (("base", B), ("this", T)):
        same = all(r["sha"] == runs[0]["sha"] for r in runs)
        loads = ", ".join(f"{r['load'][0]:.2f}-{r['load'][1]:.2f}" for r in runs)
        print(f"{label}: {len(runs)} runs, load {loads}; the same payloads in every run: {same}")
    print("\n| clip @ bound (%) | base s | this s | ratio |\n|---|---:|---:|---:|")
    ratios = {}
    for key in sorted(B[0]["cpu"]):
        b = min(r["cpu"][key] for r in B)
        t = min(r["cpu"][key] for r in T)
        ratios[key] = t / b
        print(f"| {key} | {b:.3f} | {t:.3f} | {t / b:.2f} |")
    print()
    for bound in BOUNDS:
        r = {k: v for k, v in ratios.items() if k.endswith(f"@{bound:g}")}
        if r:
            worst = max(r, key=r.get)
            print(f"{bound:g} %: median ratio {statistics.median(r.values()):.2f}, largest {r[worst]:.2f} ({worst})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    m = sub.add_parser("measure", help="time this interpreter's motionrep on every CMU-31 clip and bound")
    m.add_argument("out")
    m.add_argument("--repeats", type=int, default=3)
    t = sub.add_parser("table", help="compare runs of two trees")
    t.add_argument("--base", nargs="+", required=True)
    t.add_argument("--this", nargs="+", required=True)
    args = parser.parse_args()
    if args.command == "measure":
        measure(args.out, args.repeats)
    else:
        table(args.base, args.this)


if __name__ == "__main__":
    main()
