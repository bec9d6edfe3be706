"""Every shipped codec at --max-error 2% on the real clips: file sizes, verified end to end.

For each clip (every 31-joint CMU clip under ../shared/data/cmu and five clips of other skeletons) and each codec
(adaptive-fourier, naive-fourier, svd), this script runs the compression pipeline (``compress_file``, which
writes the ``.mrc`` only if the bound is met), then ``motionrep decompress X.mrc -o X.bvh`` and
``motionrep evaluate SOURCE X.bvh --json`` as separate commands, and checks that the error measured from the
BVH file is within the bound.  A Fourier codec that cannot reach the bound within ``max_k`` fails cleanly
(reported as FAIL with its best error); that is allowed, a silently exceeded bound is not.

Usage::

    python benchmarks/codecs_2pct.py [--jobs 2] [--out results.json] [--codecs svd,adaptive-fourier]
    python benchmarks/codecs_2pct.py --codecs adaptive-fourier:window=125 --out windows.json
    python benchmarks/codecs_2pct.py --table results.json     # print the table again

Prints a Markdown table of file sizes (bytes) per clip and codec, with K / rank and the verified error.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DATA = Path(os.environ.get("MOTIONREP_SHARED_DATA", REPO.parent / "shared" / "data"))
CODECS = ("adaptive-fourier", "naive-fourier", "svd")
OTHER = (
    "other/BvhToDeepMimic/0005_Walking001.bvh",
    "other/bvh-toolbox/walk01.bvh",
    "other/bvhio/test.bvh",
    "other/bandai_namco/dataset-1_bow_active_001.bvh",
    "other/ganimator/Elephant-idle1.bvh",
)


def clips() -> list[Path]:
    from motionrep.io import read

    cmu = []
    for p in sorted((DATA / "cmu").rglob("*.bvh")):
        head = p.read_bytes()[:200_000].decode("latin-1")
        joints = head.count("JOINT") + head.count("ROOT")
        if joints == 31 and read(p).num_joints == 31:
            cmu.append(p)
    return cmu + [DATA / o for o in OTHER]


def run_one(path: str, codec: str, workdir: str) -> dict:
    from motionrep.compress import compress_file
    from motionrep.errors import BoundNotMetError

    rel = str(Path(path).relative_to(DATA))
    name, *pairs = codec.split(":")  # "adaptive-fourier:window=125": a codec with parameters
    params = dict(pair.split("=", 1) for pair in pairs)
    stem = rel.replace("/", "__").removesuffix(".bvh") + "." + codec.replace(":", "_").replace("=", "")
    mrc = Path(workdir) / f"{stem}.mrc"
    bvh = Path(workdir) / f"{stem}.bvh"
    start = time.perf_counter()
    row = {"clip": rel, "codec": codec}
    try:
        result = compress_file(path, mrc, name, max_error="2%", seed=0, params=params)
    except BoundNotMetError as exc:
        row.update(ok=False, seconds=time.perf_counter() - start, error=str(exc), best=exc.best_error,
                   bound=exc.bound, wrote_file=mrc.exists())
        return row
    row.update(ok=True, seconds=time.perf_counter() - start, bytes=mrc.stat().st_size, info=dict(result.container.info),
               stored_error_pct=result.report.max_error_percent, figures=result.figures.as_dict(),
               frames=result.container.num_frames, joints=result.container.skeleton.num_joints)
    dec = subprocess.run([sys.executable, "-m", "motionrep", "decompress", str(mrc), "-o", str(bvh)],
                         capture_output=True, text=True)
    out = subprocess.run([sys.executable, "-m", "motionrep", "evaluate", path, str(bvh), "--json"],
                         capture_output=True, text=True) if dec.returncode == 0 else dec
    if out.returncode != 0:
        row.update(verified=False, verified_error_pct=float("nan"), bound=result.bound,
                   verify_error=(out.stderr or out.stdout).strip())
        return row
    ev = json.loads(out.stdout)
    row.update(verified_error=ev["max_error"], verified_error_pct=ev["max_error_percent"],
               bound=result.bound, verified=ev["max_error"] <= result.bound)
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("codecs_2pct.json"))
    ap.add_argument("--codecs", default=",".join(CODECS),
                    help="comma-separated; parameters after colons: adaptive-fourier:window=125")
    ap.add_argument("--only", default=None, help="substring filter on clip paths")
    ap.add_argument("--table", type=Path, default=None, help="only print the table of a previous --out file")
    args = ap.parse_args()
    if args.table is not None:
        rows = json.loads(args.table.read_text())
        order = list(dict.fromkeys(r["clip"] for r in rows))
        paths = sorted((DATA / c for c in order), key=lambda p: (not str(p.relative_to(DATA)).startswith("cmu"), p))
        table(rows, paths, list(dict.fromkeys(r["codec"] for r in rows)))
        return
    if not DATA.is_dir():
        sys.exit(f"no real clips at {DATA}")
    paths = [p for p in clips() if args.only is None or args.only in str(p)]
    codecs = args.codecs.split(",")
    rows = []
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    with tempfile.TemporaryDirectory() as work, ProcessPoolExecutor(args.jobs, mp_context=get_context("spawn")) as pool:
        # longest clips first so the pool stays busy
        order = sorted(((p, c) for p in paths for c in codecs), key=lambda pc: -pc[0].stat().st_size)
        futures = {pool.submit(run_one, str(p), c, work): (p, c) for p, c in order}
        for fut in as_completed(futures):
            row = fut.result()
            rows.append(row)
            state = ("ok %d bytes, %.2f%% verified%s" % (row["bytes"], row["verified_error_pct"],
                                                         "" if row["verified"] else " VERIFY FAILED") if row["ok"]
                     else "FAIL (best %.3g, bound %.3g)" % (row["best"] or float("nan"), row["bound"]))
            print(f"[{len(rows)}/{len(futures)}] {row['clip']} {row['codec']}: {state} in {row['seconds']:.1f} s",
                  file=sys.stderr, flush=True)
    args.out.write_text(json.dumps(rows, indent=2))
    table(rows, paths, codecs)


def table(rows: list[dict], paths: list[Path], codecs: list[str]) -> None:
    by = {(r["clip"], r["codec"]): r for r in rows}
    print("| clip | frames | joints | " + " | ".join(codecs) + " |")
    print("|---|---|---|" + "---|" * len(codecs))
    for p in paths:
        rel = str(p.relative_to(DATA))
        cells = []
        frames = joints = "?"
        for c in codecs:
            r = by.get((rel, c))
            if r is None:
                cells.append("-")
            elif r["ok"]:
                frames, joints = r["frames"], r["joints"]
                what = (f"K={r['info']['K']}" if "K" in r["info"] else f"r={r['info']['rank']}")
                flag = "" if r["verified"] else " **NOT VERIFIED**"
                cells.append(f"{r['bytes']} B ({what}, {r['verified_error_pct']:.2f}%, {r['seconds']:.0f} s){flag}")
            else:
                best = 2.0 * r["best"] / r["bound"] if r["best"] else float("nan")  # the bound is 2 %
                cells.append(f"fail (best {best:.2f}%, {r['seconds']:.0f} s)")
        print(f"| {rel} | {frames} | {joints} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
