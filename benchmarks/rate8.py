"""Issue 25, closed-loop quantisation along the skeleton: payload bytes and encode CPU time of ``transform`` with the
features quantised open loop (as before) or closed loop (``motionrep.pipeline.chain``: depth by depth, each depth's
targets recomputed from what the decoder makes of the depths before it).

``tune OUT.jsonl MODE [MODE ...] [--clips other|cmu31] [--bounds 2,0.588,0.0588]``
    in one process, every clip read once, then for each mode every clip encoded at every bound by
    ``compress_motion(motion, "transform", max_error=bound)`` (the core verifies every payload), one row per mode
    appended to OUT: bytes per clip and bound, their sums, the process CPU time per bound, the load.

``cpu OUT.json [--clips cmu31] [--rounds 3]``
    the encode's CPU time of every clip at every bound, open and closed loop alternated clip by clip in one
    process, best of ``--rounds`` each, and their bytes.

``table OUT.jsonl``
    sums per bound relative to the first row, and the median of the per-clip ratios.

Modes: ``open`` (``closed_loop=false``) and ``closed`` (the default, ``closed_loop=true``). The prototype that
decided this (commit 1d3dd0f of this file: orientation feedback, position feedback for every joint or only for
joints with one point below them, open- or closed-loop sensitivities; patched over main f38dd8d's codec) wrote
``results/rate8_proto.jsonl``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from acl import DATA  # noqa: E402
from rate7 import _clips  # noqa: E402  (the tuning clips, or the eight CMU-31 ones)


def _params(mode: str) -> dict:
    if mode not in ("open", "closed"):
        raise SystemExit(f"unknown mode {mode!r}: open or closed")
    return {"closed_loop": mode == "closed"}


def _bytes(r) -> int:
    return sum(int(np.asarray(a).nbytes) for a in r.container.arrays.values())


def tune(out: str, modes: list[str], which: str, bounds: list[float]) -> None:
    from motionrep.io import read
    from motionrep.pipeline.compress import compress_motion

    motions = [(str(p.relative_to(DATA)), read(p)) for p in _clips(which)]
    for mode in modes:
        params = _params(mode)
        row = {"mode": mode, "clips": which, "bytes": {}, "sums": {}, "seconds": {}, "load": os.getloadavg()[0]}
        for bound in bounds:
            t0 = time.process_time()
            per = {name: _bytes(compress_motion(m, "transform", max_error=f"{bound:g}%", params=params))
                   for name, m in motions}
            row["bytes"][str(bound)] = per
            row["sums"][str(bound)] = sum(per.values())
            row["seconds"][str(bound)] = round(time.process_time() - t0, 2)
            print(mode, bound, row["sums"][str(bound)], row["seconds"][str(bound)], flush=True)
        with open(out, "a") as fh:
            fh.write(json.dumps(row) + "\n")


def cpu(out: str, which: str, rounds: int, bounds: list[float]) -> None:
    from motionrep.io import read
    from motionrep.pipeline.compress import compress_motion

    motions = [(str(p.relative_to(DATA)), read(p)) for p in _clips(which)]
    compress_motion(motions[0][1], "transform", max_error="2%")  # warm
    best: dict = {}
    sizes: dict = {}
    for _ in range(rounds):
        for name, m in motions:
            for bound in bounds:
                for mode in ("open", "closed"):
                    c0 = time.process_time()
                    r = compress_motion(m, "transform", max_error=f"{bound:g}%", params=_params(mode))
                    key = f"{name}@{bound:g}"
                    t = time.process_time() - c0
                    best.setdefault(mode, {})[key] = min(t, best.get(mode, {}).get(key, float("inf")))
                    sizes.setdefault(mode, {})[key] = _bytes(r)
    rows = {"clips": which, "rounds": rounds, "load": os.getloadavg()[0], "cpu": best, "bytes": sizes}
    Path(out).write_text(json.dumps(rows, indent=1))
    for bound in bounds:
        keys = [k for k in best["open"] if k.endswith(f"@{bound:g}")]
        ratio = [best["closed"][k] / best["open"][k] for k in keys]
        size = [sizes["closed"][k] / sizes["open"][k] for k in keys]
        print(f"{bound:g} %: CPU closed/open median {statistics.median(ratio):.2f} (largest {max(ratio):.2f}), "
              f"sum {sum(best['closed'][k] for k in keys):.2f} s / {sum(best['open'][k] for k in keys):.2f} s; "
              f"bytes median {statistics.median(size):.3f}")
    for k in best["open"]:
        print(k, f"{best['open'][k]:.3f} -> {best['closed'][k]:.3f} s", sizes["open"][k], "->", sizes["closed"][k])


def table(path: str) -> None:
    rows = [json.loads(line) for line in open(path)]
    base = rows[0]
    for r in rows:
        cells = []
        for b, s in r["sums"].items():
            ratios = [r["bytes"][b][c] / base["bytes"][b][c] for c in r["bytes"][b] if c in base["bytes"].get(b, {})]
            med = statistics.median(ratios) if ratios else float("nan")
            cells.append(f"{b}%: {s} ({s / base['sums'][b]:.3f}, median/clip {med:.3f}, {r['seconds'][b]} s)")
        print(r["mode"], r["clips"], " | ".join(cells))


def main() -> None:
    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("tune")
    t.add_argument("out")
    t.add_argument("modes", nargs="+")
    t.add_argument("--clips", default="other")
    t.add_argument("--bounds", default="2,0.588,0.0588")
    c = sub.add_parser("cpu")
    c.add_argument("out")
    c.add_argument("--clips", default="cmu31")
    c.add_argument("--rounds", type=int, default=3)
    c.add_argument("--bounds", default="2,0.588,0.0588")
    tb = sub.add_parser("table")
    tb.add_argument("path")
    a = ap.parse_args()
    if a.cmd == "tune":
        tune(a.out, a.modes, a.clips, [float(b) for b in a.bounds.split(",")])
    elif a.cmd == "cpu":
        cpu(a.out, a.clips, a.rounds, [float(b) for b in a.bounds.split(",")])
    else:
        table(a.path)


if __name__ == "__main__":
    main()
