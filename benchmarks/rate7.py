"""Issue 25, encoder choices only: payload bytes of ``transform`` under settings of its encoder's free choices, on
the tuning clips (the 20 clips of ``../shared/data/other``, none of them CMU), each at 2 %, 0.588 % and 0.0588 %.

``tune OUT.jsonl NAME JSON [NAME JSON ...]``
    in one process, every clip read once, then for each setting (a JSON object, below) every clip encoded at every
    bound by ``compress_motion(motion, "transform", max_error=bound, params=...)`` (features, the codec's search,
    the core's checks: the bytes are verified by the core), one row per setting appended to OUT: payload bytes
    per clip and bound, their sums, the encode time. ``--clips cmu31`` runs the eight CMU-31 clips instead (the
    held-out check, once, after the setting is chosen).

``table OUT.jsonl [--against NAME]``
    the sums per bound of every setting, relative to ``NAME`` (default: the first row).

A setting: ``{"params": {"region": 16, "rounding": 0.45, "slack": 5}, "min_saving": 0.2, "percentile": 90,
"activity": 0.0, "activity_delta": 16}`` (any subset; missing keys: the codec's defaults). ``min_saving`` and
``percentile`` patch the module constants for the run; ``activity`` is the codec's ``activity`` parameter.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from acl import BOUNDS, DATA  # noqa: E402


def _clips(which: str) -> list[Path]:
    from motionrep.io import read

    if which == "cmu31":
        return [p for p in sorted((DATA / "cmu").rglob("*.bvh")) if read(p).num_joints == 31]
    return sorted((DATA / "other").rglob("*.bvh"))


def _apply(setting: dict) -> dict:
    """Patch the module constants a setting names; returns the codec params."""
    from motionrep_transform import _codec

    _codec.MIN_SAVING = setting.get("min_saving", _ORIG["min_saving"])
    _codec._SENSITIVITY_PERCENTILE = setting.get("percentile", _ORIG["percentile"])
    for name, value in _ORIG["consts"].items():
        setattr(_codec, name, setting.get("consts", {}).get(name, value))
    return dict(setting.get("params", {}))


_ORIG: dict = {}


def tune(out: str, pairs: list[str], which: str) -> None:
    from motionrep.io import read
    from motionrep.pipeline.compress import compress_motion
    from motionrep_transform import _codec

    _ORIG.update(min_saving=_codec.MIN_SAVING, percentile=getattr(_codec, "_SENSITIVITY_PERCENTILE", 90),
                 consts={n: getattr(_codec, n) for n in ("_ACTIVITY", "_ACTIVITY_DELTA", "_ACTIVITY_LIMIT", "_PASSES", "_SCHEDULE",
                                                "_ORDER_ALPHA")
                         if hasattr(_codec, n)})
    motions = [(str(p.relative_to(DATA)), read(p)) for p in _clips(which)]
    for name, text in zip(pairs[::2], pairs[1::2]):
        setting = json.loads(text)
        params = _apply(setting)
        sizes, seconds, cpu = {}, 0.0, 0.0
        cpu_bound = {f"{b:g}": 0.0 for b in BOUNDS}
        for clip, m in motions:
            for bound in BOUNDS:
                t0, c0 = time.perf_counter(), time.process_time()
                r = compress_motion(m, "transform", max_error=f"{bound:g}%", params=params)
                seconds += time.perf_counter() - t0
                cpu += time.process_time() - c0
                cpu_bound[f"{bound:g}"] += time.process_time() - c0
                payload = sum(int(np.asarray(a).nbytes) for a in r.container.arrays.values())
                sizes[f"{clip}@{bound:g}"] = payload
        sums = {f"{b:g}": sum(v for k, v in sizes.items() if k.endswith(f"@{b:g}")) for b in BOUNDS}
        row = {"name": name, "setting": setting, "clips": which, "sums": sums, "seconds": round(seconds, 2), "cpu": round(cpu, 2), "cpu_bound": {k: round(v, 2) for k, v in cpu_bound.items()},
               "load": os.getloadavg()[0], "sizes": sizes}
        with open(out, "a") as f:
            f.write(json.dumps(row) + "\n")
        print(name, sums, f"{seconds:.1f} s, cpu {cpu:.1f} s", {k: round(v, 2) for k, v in cpu_bound.items()},
              flush=True)


def table(path: str, against: str | None) -> None:
    rows = [json.loads(line) for line in open(path)]
    base = next((r for r in rows if r["name"] == against), rows[0]) if against else rows[0]
    print(f"| setting | {' | '.join(b + ' %' for b in base['sums'])} | all | encode s (load) |")
    print("|---|" + "---:|" * (len(base["sums"]) + 2))
    for r in rows:
        if r["clips"] != base["clips"]:
            continue
        cells = [f"{r['sums'][b]} ({r['sums'][b] / base['sums'][b]:.4f})" for b in base["sums"]]
        total = sum(r["sums"].values()) / sum(base["sums"].values())
        print(f"| {r['name']} | {' | '.join(cells)} | {total:.4f} | {r['seconds']:.0f} ({r['load']:.1f}) |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("tune")
    t.add_argument("out")
    t.add_argument("pairs", nargs="+", help="NAME JSON pairs")
    t.add_argument("--clips", default="other", choices=["other", "cmu31"])
    b = sub.add_parser("table")
    b.add_argument("out")
    b.add_argument("--against")
    a = ap.parse_args()
    if a.cmd == "tune":
        if len(a.pairs) % 2:
            ap.error("give NAME JSON pairs")
        tune(a.out, a.pairs, a.clips)
    else:
        table(a.out, a.against)


if __name__ == "__main__":
    main()
