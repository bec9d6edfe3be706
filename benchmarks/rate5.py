"""Issue 25, payload version 3: the decode time of ``transform`` beside another checkout (main), on the eight
CMU-31 clips at 2 %, 0.588 % and 0.0588 %.

``prepare OUT.json``
    run with the interpreter of the tree it measures (this tree's venv, then main's, alternately: ``A B A B``, so
    that both see the same load): in one process, every clip read and compressed by ``transform`` at each bound
    (each tree writes its own payload version; the integers are the same), then, clip by clip, ``codec.decoder
    (payload)`` (the integers' decoding and the inverse wavelet: what ``benchmarks/speed.py`` calls prepare),
    best of ``--repeat`` (default 30); the payload version, its bytes, the load average.

``table A.json [A.json ...] --against B.json [B.json ...]``
    the best of each tree's runs per clip and bound, and A / B (median, largest, ratio of the sums).

``MOTIONREP_SHARED_DATA`` as the other benchmarks. Results: ``results/rate5.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from rate4 import _clips  # noqa: E402

BOUNDS = (2.0, 0.588, 0.0588)


def prepare(out: str, repeat: int) -> None:
    from motionrep.io import read
    from motionrep.pipeline.compress import compress_motion
    from motionrep.plugin.codec import Payload
    from motionrep.plugin.registry import get_codec

    codec = get_codec("transform")
    rows = []
    for path in _clips():
        motion = read(path)
        for bound in BOUNDS:
            c = compress_motion(motion, "transform", max_error=f"{bound:g}%").container
            payload = Payload(dict(c.arrays), version=c.codec_version)
            best = float("inf")
            for _ in range(repeat):
                t0 = time.perf_counter()
                codec.decoder(payload)
                best = min(best, time.perf_counter() - t0)
            rows.append({"clip": path.stem, "dir": path.parent.name, "bound_percent": bound, "seconds": best,
                         "version": int(c.codec_version), "payload_bytes": int(c.payload_bytes),
                         "load": os.getloadavg()[0]})
    Path(out).write_text(json.dumps(rows, indent=1) + "\n")
    print(f"{out}: {len(rows)} payloads, prepare {sum(r['seconds'] for r in rows) * 1e3:.2f} ms in all")


def _best(files: list[str]) -> dict:
    best: dict = {}
    for f in files:
        for r in json.loads(Path(f).read_text()):
            key = (r["dir"], r["clip"], r["bound_percent"])
            if key not in best or r["seconds"] < best[key]["seconds"]:
                best[key] = r
    return best


def table(after: list[str], before: list[str]) -> None:
    a, b = _best(after), _best(before)
    print("| bound | versions (after / before) | prepare ms, sum after / before | after / before: median | "
          "largest | sum / sum | payload bytes after / before (sum) |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for bound in BOUNDS:
        keys = sorted(k for k in a if k[2] == bound and k in b)
        ratios = [a[k]["seconds"] / b[k]["seconds"] for k in keys]
        sa, sb = sum(a[k]["seconds"] for k in keys), sum(b[k]["seconds"] for k in keys)
        pa, pb = sum(a[k]["payload_bytes"] for k in keys), sum(b[k]["payload_bytes"] for k in keys)
        va = sorted({a[k]["version"] for k in keys})
        vb = sorted({b[k]["version"] for k in keys})
        print(f"| {bound:g} % | {va} / {vb} | {sa * 1e3:.2f} / {sb * 1e3:.2f} | {statistics.median(ratios):.3f} | "
              f"{max(ratios):.3f} | {sa / sb:.3f} | {pa} / {pb} ({pa / pb:.4f}) |")
    loads = [r["load"] for r in list(a.values()) + list(b.values())]
    print(f"\nLoad (1-minute average) during the runs: {min(loads):.1f}-{max(loads):.1f}.")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("prepare")
    p.add_argument("out")
    p.add_argument("--repeat", type=int, default=30)
    t = sub.add_parser("table")
    t.add_argument("after", nargs="+")
    t.add_argument("--against", nargs="+", required=True)
    args = ap.parse_args()
    if args.cmd == "prepare":
        prepare(args.out, args.repeat)
    else:
        table(args.after, args.against)


if __name__ == "__main__":
    main()
