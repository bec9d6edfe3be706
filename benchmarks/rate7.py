"""Issue 25, encoder choices only: payload bytes of ``transform`` under settings of its encoder's free choices, on
the tuning clips (the 20 clips of ``../shared/data/other``, none of them CMU), each at 2 %, 0.588 % and 0.0588 %.

``tune OUT.jsonl NAME JSON [NAME JSON ...]``
    in one process, every clip read once, then for each setting (a JSON object, below) every clip encoded at every
    bound by ``compress_motion(motion, "transform", max_error=bound, params=...)`` (features, the codec's search,
    the core's checks: the bytes are verified by the core), one row per setting appended to OUT: payload bytes
    per clip and bound, their sums, the encode time. ``--clips cmu31`` runs the eight CMU-31 clips instead (the
    held-out check, once, after the setting is chosen).

``cpu OUT.json NAME JSON [NAME JSON ...] [--rounds N]``
    the encode's CPU time (user + system of the process, less inflated by a loaded machine than wall time) of the
    eight CMU-31 clips at each bound under each setting, the settings alternated clip by clip, best of
    ``--rounds``, and the payload bytes: what a setting costs against the first, the rest of the code the same.

``table OUT.jsonl [--against NAME]``
    the sums per bound of every setting, relative to ``NAME`` (default: the first row).

A setting: ``{"params": {"region": 16, "rounding": 0.45, "slack": 5}, "min_saving": 0.1, "percentile": 90,
"consts": {"_PASSES": 8}}`` (any subset; missing keys: the codec's defaults). ``min_saving``, ``percentile`` and
``consts`` patch ``motionrep_transform._codec``'s module constants for the run. (The variants of
``results/rate7.md`` that need code, feature exponents scaled by activity and a schedule of floors, ran with the
knobs of commit 042f8b8, ``{"consts": {"_ACTIVITY": 0.25}}`` and ``{"consts": {"_SCHEDULE": [[5, 0.2], [1,
0.05]]}}``; the per-level floors are commit 7781eb5, where ``{"consts": {"_FLOOR_LOW": 0.2}}`` is one floor for
all levels.)

Results: ``results/rate7.md``; the rows of its tables in ``results/rate7_tuning.jsonl``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
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
    """Patch the module constants a setting names (``min_saving``, ``percentile``, ``consts``: other constants of
    ``motionrep_transform._codec`` by name, e.g. ``{"_PASSES": 8}``); returns the codec params."""
    from motionrep_transform import _codec

    _codec.MIN_SAVING = setting.get("min_saving", _ORIG["min_saving"])
    _codec._SENSITIVITY_PERCENTILE = setting.get("percentile", _ORIG["percentile"])
    for name, value in _ORIG["consts"].items():
        setattr(_codec, name, value)
    for name, value in setting.get("consts", {}).items():
        if not hasattr(_codec, name):
            raise SystemExit(f"motionrep_transform._codec has no constant {name}")
        _ORIG["consts"].setdefault(name, getattr(_codec, name))
        setattr(_codec, name, value)
    return dict(setting.get("params", {}))


_ORIG: dict = {}


def tune(out: str, pairs: list[str], which: str) -> None:
    from motionrep.io import read
    from motionrep.pipeline.compress import compress_motion
    from motionrep_transform import _codec

    _ORIG.update(min_saving=_codec.MIN_SAVING, percentile=_codec._SENSITIVITY_PERCENTILE, consts={})
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
        row = {"name": name, "setting": setting, "clips": which, "sums": sums, "seconds": round(seconds, 2),
               "cpu": round(cpu, 2), "cpu_bound": {k: round(v, 2) for k, v in cpu_bound.items()},
               "load": os.getloadavg()[0], "sizes": sizes}
        with open(out, "a") as f:
            f.write(json.dumps(row) + "\n")
        print(name, sums, f"{seconds:.1f} s, cpu {cpu:.1f} s", {k: round(v, 2) for k, v in cpu_bound.items()},
              flush=True)


def cpu(out: str, pairs: list[str], rounds: int) -> None:
    from motionrep.io import read
    from motionrep.pipeline.compress import compress_motion
    from motionrep_transform import _codec

    _ORIG.update(min_saving=_codec.MIN_SAVING, percentile=_codec._SENSITIVITY_PERCENTILE, consts={})
    settings = [(name, json.loads(text)) for name, text in zip(pairs[::2], pairs[1::2])]
    motions = [(str(p.relative_to(DATA)), read(p)) for p in _clips("cmu31")]
    compress_motion(motions[0][1], "transform", max_error="2%")  # warm
    load, best, sizes = [os.getloadavg()[0]], {}, {}
    for _ in range(rounds):
        for clip, m in motions:
            for bound in BOUNDS:
                for name, setting in settings:
                    params = _apply(setting)
                    c0 = time.process_time()
                    r = compress_motion(m, "transform", max_error=f"{bound:g}%", params=params)
                    key = f"{clip}@{bound:g}@{name}"
                    best[key] = min(best.get(key, math.inf), time.process_time() - c0)
                    sizes[key] = sum(int(np.asarray(a).nbytes) for a in r.container.arrays.values())
    load.append(os.getloadavg()[0])
    Path(out).write_text(json.dumps({"load": load, "rounds": rounds, "settings": dict(settings),
                                     "best_cpu_seconds": best, "payload_bytes": sizes}, indent=1))
    first = settings[0][0]
    for bound in BOUNDS:
        for name, _ in settings[1:]:
            r = [best[f"{c}@{bound:g}@{name}"] / best[f"{c}@{bound:g}@{first}"] for c, _ in motions]
            print(f"{bound:g} %: {name} / {first}: CPU median {statistics.median(r):.3f}, largest {max(r):.3f}; "
                  f"bytes {sum(sizes[f'{c}@{bound:g}@{name}'] for c, _ in motions)} / "
                  f"{sum(sizes[f'{c}@{bound:g}@{first}'] for c, _ in motions)}")


def table(path: str, against: str | None) -> None:
    rows = [json.loads(line) for line in open(path)]
    base = next((r for r in rows if r["name"] == against), rows[0]) if against else rows[0]
    print(f"| setting | {' | '.join(b + ' %' for b in base['sums'])} | all | CPU s (load) |")
    print("|---|" + "---:|" * (len(base["sums"]) + 2))
    for r in rows:
        if r["clips"] != base["clips"]:
            continue
        cells = [f"{r['sums'][b]} ({r['sums'][b] / base['sums'][b]:.4f})" for b in base["sums"]]
        total = sum(r["sums"].values()) / sum(base["sums"].values())
        when = (f"{r['cpu']:.1f}" + (f" ({r['load']:.1f})" if "load" in r else "")) if "cpu" in r else "-"
        print(f"| {r['name']} | {' | '.join(cells)} | {total:.4f} | {when} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("tune")
    t.add_argument("out")
    t.add_argument("pairs", nargs="+", help="NAME JSON pairs")
    t.add_argument("--clips", default="other", choices=["other", "cmu31"])
    c = sub.add_parser("cpu")
    c.add_argument("out")
    c.add_argument("pairs", nargs="+", help="NAME JSON pairs, the first the reference")
    c.add_argument("--rounds", type=int, default=4)
    b = sub.add_parser("table")
    b.add_argument("out")
    b.add_argument("--against")
    a = ap.parse_args()
    if a.cmd == "tune":
        if len(a.pairs) % 2:
            ap.error("give NAME JSON pairs")
        tune(a.out, a.pairs, a.clips)
    elif a.cmd == "cpu":
        cpu(a.out, a.pairs, a.rounds)
    else:
        table(a.out, a.against)


if __name__ == "__main__":
    main()
