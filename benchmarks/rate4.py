"""Issue 25, every move measured: ``transform`` beside another checkout (main), bytes verified through BVH and
encode times, on the eight CMU-31 clips at 2 %, 0.588 % and 0.0588 %.

Two steps, each run with the interpreter of the tree it measures (main's venv for main, this tree's for this one),
so that nothing of one tree is loaded into the other:

``times OUT.json [k=v,...]``
    in one process, every clip read first, a warm-up encode, then ``compress_motion(motion, "transform",
    max_error=bound, params)`` of each clip at each bound, the wall time of each (the encode only: features, the
    codec's search, the core's two checks), the payload bytes and their SHA-256, the load average. Run it for
    both trees in turn, twice or more (``A B A B``), so that both see the same load; the table keeps each
    encode's best.

``table --before RUNS.jsonl --after RUNS.jsonl [--before-times F ...] [--after-times F ...]``
    from two ``benchmarks/acl.py run --codecs transform --clips cmu31 --runs RUNS.jsonl`` files (each run with
    its tree's interpreter and script: compressed, decompressed to BVH and checked with ``motionrep evaluate``)
    and the ``times`` files: the issue's targets (payload / ACL 2.1 strict-bound, median and worst over the
    clips, files verified), per clip, and the encode time of ``after`` over ``before`` (median, largest and the
    ratio of the sums, per bound); also whether the ``times`` files of one tree agree byte for byte.

``MOTIONREP_SHARED_DATA`` as the other benchmarks. Results: ``results/rate4.md``.
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

sys.path.insert(0, str(Path(__file__).resolve().parent))
from acl import BOUNDS, DATA  # noqa: E402

#: The issue's targets (payload / ACL, CMU-31 median) per bound, and the worst clip's at every bound.
TARGETS = {2.0: 0.12, 0.588: 0.15, 0.0588: 0.25}
WORST = 0.35


def _clips() -> list[Path]:
    from motionrep.io import read

    return [p for p in sorted((DATA / "cmu").rglob("*.bvh")) if read(p).num_joints == 31]


def times(out: str, params: str = "") -> None:
    import numpy as np

    from motionrep.io import read
    from motionrep.pipeline.compress import compress_motion

    kv = dict(pair.split("=", 1) for pair in params.split(",") if pair)
    kv = {k: float(v) if "." in v else int(v) for k, v in kv.items()}
    motions = [(p, read(p)) for p in _clips()]
    compress_motion(motions[0][1], "transform", max_error="2%", params=kv)  # warm
    rows = []
    for p, m in motions:
        for bound in BOUNDS:
            t0 = time.perf_counter()
            r = compress_motion(m, "transform", max_error=f"{bound:g}%", params=kv)
            seconds = time.perf_counter() - t0
            payload = b"".join(np.ascontiguousarray(r.container.arrays[k]).tobytes()
                               for k in sorted(r.container.arrays))
            rows.append({"clip": str(p.relative_to(DATA)).removesuffix(".bvh"), "bound_percent": bound,
                         "frames": m.num_frames, "seconds": seconds, "payload_bytes": len(payload),
                         "sha256": hashlib.sha256(payload).hexdigest(), "load": os.getloadavg()[0]})
    Path(out).write_text(json.dumps({"params": kv, "rows": rows}, indent=1))


def _runs(path: str) -> dict[tuple[str, float], dict]:
    return {(r["clip"], r["bound_percent"]): r for r in map(json.loads, Path(path).read_text().splitlines())}


def _best(files: list[str]) -> tuple[dict[tuple[str, float], dict], list[float], bool]:
    """Per (clip, bound) the fastest encode over the files, the loads seen, and whether the bytes agree."""
    best: dict[tuple[str, float], dict] = {}
    loads, same = [], True
    for f in files:
        for r in json.loads(Path(f).read_text())["rows"]:
            key = (r["clip"], r["bound_percent"])
            loads.append(r["load"])
            if key in best:
                same &= best[key]["sha256"] == r["sha256"]
                if r["seconds"] < best[key]["seconds"]:
                    best[key] = dict(r)
            else:
                best[key] = dict(r)
    return best, loads, same


def table(args: argparse.Namespace) -> None:
    from acl import acl_figures

    acl = acl_figures()
    before, after = _runs(args.before), _runs(args.after)
    print("| bound | CMU-31 median, before -> after | target | CMU-31 worst, before -> after | target | salsa ratio of "
          "medians, before -> after | files verified (after) |")
    print("|---|---|---|---|---|---|---|")
    for bound in BOUNDS:
        cells = []
        for runs in (before, after):
            ratios = [r["payload_bpbf"] / acl[key] for key, r in runs.items()
                      if key[1] == bound and key in acl and r["status"] == "ok"]
            cells.append((statistics.median(ratios), max(ratios)))
        salsa = []
        for runs in (before, after):
            sizes = [r["payload_bpbf"] for k, r in runs.items() if k[1] == bound and "salsa" in k[0]
                     and r["status"] == "ok"]
            salsa.append(f"{statistics.median(sizes) / acl[('salsa-median', bound)]:.3f}" if sizes else "-")
        ok = sum(1 for k, r in after.items() if k[1] == bound and r["status"] == "ok" and r.get("verified"))
        n = sum(1 for k in after if k[1] == bound)
        (mb, wb), (ma, wa) = cells
        print(f"| {bound:g} % | {mb:.3f} -> **{ma:.3f}** | <= {TARGETS[bound]}: "
              f"{'met' if ma <= TARGETS[bound] else 'not met'} | {wb:.3f} -> **{wa:.3f}** | <= {WORST}: "
              f"{'met' if wa <= WORST else 'not met'} | {salsa[0]} -> **{salsa[1]}** | {ok} / {n} |")
    ratios = {bound: [r["payload_bytes"] / before[k]["payload_bytes"] for k, r in after.items() if k[1] == bound
                      and r["status"] == "ok" and before.get(k, {}).get("status") == "ok"] for bound in BOUNDS}
    print()
    print("Payload bytes after / before, every clip of the runs: "
          + "; ".join(f"{b:g} %: median {statistics.median(v):.3f} ({min(v):.3f}-{max(v):.3f}, {len(v)} clips)"
                      for b, v in ratios.items() if v) + ".")
    print()
    print("| clip (the salsa clips summed up above) | frames | bound | before b/b/f | after b/b/f | after / before | "
          "after / ACL |")
    print("|---|---:|---|---:|---:|---:|---:|")
    for bound in BOUNDS:
        for key in sorted(k for k in after if k[1] == bound and "salsa" not in k[0]):
            a, b = after[key], before.get(key)
            if a["status"] != "ok" or b is None or b["status"] != "ok":
                print(f"| {key[0]} | | {bound:g} % | {b and b['status']} | {a['status']} | | |")
                continue
            ref = acl.get(key)
            vs_acl = "" if ref is None else f"{a['payload_bpbf'] / ref:.3f}"
            print(f"| {key[0]} | {a['frames']} | {bound:g} % | {b['payload_bpbf']:.3f} | {a['payload_bpbf']:.3f} | "
                  f"{a['payload_bytes'] / b['payload_bytes']:.3f} | {vs_acl} |")
    if not (args.before_times and args.after_times):
        return
    tb, lb, sb = _best(args.before_times)
    ta, la, sa = _best(args.after_times)
    print()
    print(f"Encode only (`rate4.py times`, best of {len(args.before_times)} / {len(args.after_times)} runs, load "
          f"{min(lb + la):.1f}-{max(lb + la):.1f}); the same bytes in every run of a tree: before {sb}, after {sa}.")
    print()
    print("| bound | before s (median) | after s (median) | after / before: median | largest | sum / sum |")
    print("|---|---:|---:|---:|---:|---:|")
    for bound in BOUNDS:
        keys = [k for k in tb if k[1] == bound and k in ta]
        ratios = [ta[k]["seconds"] / tb[k]["seconds"] for k in keys]
        print(f"| {bound:g} % | {statistics.median(tb[k]['seconds'] for k in keys):.3f} | "
              f"{statistics.median(ta[k]['seconds'] for k in keys):.3f} | {statistics.median(ratios):.2f} | "
              f"{max(ratios):.2f} | {sum(ta[k]['seconds'] for k in keys) / sum(tb[k]['seconds'] for k in keys):.2f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    t = sub.add_parser("times")
    t.add_argument("out")
    t.add_argument("params", nargs="?", default="")
    b = sub.add_parser("table")
    b.add_argument("--before", required=True)
    b.add_argument("--after", required=True)
    b.add_argument("--before-times", nargs="*", default=[])
    b.add_argument("--after-times", nargs="*", default=[])
    args = parser.parse_args()
    if args.command == "times":
        times(args.out, args.params)
    else:
        table(args)


if __name__ == "__main__":
    main()
