"""Every shipped codec at --max-error 2% on the real clips: file sizes, verified end to end.

For each clip (every 31-joint CMU clip under ../shared/data/cmu and five clips of other skeletons) and each codec
(adaptive-fourier, naive-fourier, svd), this script runs the compression pipeline (``compress_file``, which
writes the ``.mrc`` only if the bound is met), then ``motionrep decompress X.mrc -o X.bvh`` and
``motionrep evaluate SOURCE X.bvh --json`` as separate commands, and checks that the error measured from the
BVH file is within the bound.  A Fourier codec that cannot reach the bound within ``max_k`` fails cleanly
(reported as FAIL with its best error); that is allowed, a silently exceeded bound is not.

Each row also has the payload bytes (the codec's arrays, without the skeleton and metadata every codec shares),
the payload bits per bone per frame (ACL's count: bones = joints + end sites), the encode time, the time to
prepare the decoder and the best of five decodes of every frame with the prepared decoder, and the load average.

Usage::

    python benchmarks/codecs_2pct.py [--jobs 2] [--out results.json] [--codecs svd,adaptive-fourier]
    python benchmarks/codecs_2pct.py --codecs adaptive-fourier:window=125 --out windows.json
    python benchmarks/codecs_2pct.py --clips cmu31 --codecs adaptive-fourier:dtype=float32,adaptive-fourier \
        --out quantised.json                                # the eight CMU-31 clips ACL's figures are for
    python benchmarks/codecs_2pct.py --table results.json     # print the table again
    python benchmarks/codecs_2pct.py --compare quantised.json  # first codec against the others, beside ACL

Prints a Markdown table of file sizes (bytes) per clip and codec, with K / rank and the verified error;
``--compare`` a table of payload bytes and bits/bone/frame of each codec against the first, with ACL 2.1's
strict-bound figures (``motionrep/data/acl_strict.csv``) and the encode and decode times.
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


def clips(which: str = "all") -> list[Path]:
    """``all``: the 31-joint CMU clips and :data:`OTHER`; ``cmu31``: the 31-joint CMU clips only."""
    from motionrep.io import read

    cmu = []
    for p in sorted((DATA / "cmu").rglob("*.bvh")):
        head = p.read_bytes()[:200_000].decode("latin-1")
        joints = head.count("JOINT") + head.count("ROOT")
        if joints == 31 and read(p).num_joints == 31:
            cmu.append(p)
    return cmu + ([DATA / o for o in OTHER] if which == "all" else [])


def run_one(path: str, codec: str, workdir: str) -> dict:
    from motionrep.plugin.codec import Payload, frame_times
    from motionrep.pipeline.compress import compress_file
    from motionrep.errors import BoundNotMetError
    from motionrep.plugin.registry import get_codec

    rel = str(Path(path).relative_to(DATA))
    name, *pairs = codec.split(":")  # "adaptive-fourier:window=125": a codec with parameters
    params = dict(pair.split("=", 1) for pair in pairs)
    stem = rel.replace("/", "__").removesuffix(".bvh") + "." + codec.replace(":", "_").replace("=", "")
    mrc = Path(workdir) / f"{stem}.mrc"
    bvh = Path(workdir) / f"{stem}.bvh"
    start = time.perf_counter()
    row = {"clip": rel, "codec": codec, "load": os.getloadavg()[0]}
    try:
        result = compress_file(path, mrc, name, max_error="2%", seed=0, params=params)
    except BoundNotMetError as exc:
        row.update(ok=False, seconds=time.perf_counter() - start, error=str(exc), best=exc.best_error,
                   bound=exc.bound, wrote_file=mrc.exists())
        return row
    row.update(ok=True, seconds=time.perf_counter() - start, bytes=mrc.stat().st_size, info=dict(result.container.info),
               stored_error_pct=result.report.max_error_percent, figures=result.figures.as_dict(),
               frames=result.container.num_frames, joints=result.container.skeleton.num_joints)
    c = result.container
    bones = c.skeleton.num_joints + c.skeleton.num_end_sites
    times = frame_times(c.num_frames)
    t0 = time.perf_counter()
    decoder = get_codec(name).decoder(Payload(c.arrays, c.info))
    prepare = time.perf_counter() - t0
    decode = min(_seconds(decoder, times) for _ in range(5))
    row.update(bones=bones, payload_bytes=c.payload_bytes, payload_bpbf=8.0 * c.payload_bytes / (c.num_frames * bones),
               prepare_seconds=prepare, decode_seconds=decode, decode_frames_per_second=c.num_frames / decode)
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


def _seconds(decoder, times) -> float:
    t0 = time.perf_counter()
    decoder(times)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("codecs_2pct.json"))
    ap.add_argument("--codecs", default=",".join(CODECS),
                    help="comma-separated; parameters after colons: adaptive-fourier:window=125")
    ap.add_argument("--only", default=None, help="substring filter on clip paths")
    ap.add_argument("--clips", choices=("all", "cmu31"), default="all",
                    help="cmu31: only the eight 31-joint CMU clips (those of ACL's figures)")
    ap.add_argument("--table", type=Path, default=None, help="only print the table of a previous --out file")
    ap.add_argument("--compare", type=Path, default=None,
                    help="only print the comparison table of a previous --out file (first codec against the others)")
    args = ap.parse_args()
    if args.compare is not None:
        compare(json.loads(args.compare.read_text()))
        return
    if args.table is not None:
        rows = json.loads(args.table.read_text())
        order = list(dict.fromkeys(r["clip"] for r in rows))
        paths = sorted((DATA / c for c in order), key=lambda p: (not str(p.relative_to(DATA)).startswith("cmu"), p))
        table(rows, paths, list(dict.fromkeys(r["codec"] for r in rows)))
        return
    if not DATA.is_dir():
        sys.exit(f"no real clips at {DATA}")
    paths = [p for p in clips(args.clips) if args.only is None or args.only in str(p)]
    codecs = args.codecs.split(",")
    rows = []
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    with tempfile.TemporaryDirectory() as work, ProcessPoolExecutor(args.jobs, mp_context=get_context("spawn")) as pool:
        # several jobs: longest clips first so the pool stays busy; one: shortest first, so that an interrupted
        # run has the most clips, each with every codec
        order = sorted(((p, c) for p in paths for c in codecs),
                       key=lambda pc: pc[0].stat().st_size * (-1 if args.jobs > 1 else 1))
        futures = {pool.submit(run_one, str(p), c, work): (p, c) for p, c in order}
        for fut in as_completed(futures):
            row = fut.result()
            rows.append(row)
            state = ("ok %d bytes, %.2f%% verified%s" % (row["bytes"], row["verified_error_pct"],
                                                         "" if row["verified"] else " VERIFY FAILED") if row["ok"]
                     else "FAIL (best %.3g, bound %.3g)" % (row["best"] or float("nan"), row["bound"]))
            print(f"[{len(rows)}/{len(futures)}] {row['clip']} {row['codec']}: {state} in {row['seconds']:.1f} s",
                  file=sys.stderr, flush=True)
            args.out.write_text(json.dumps(rows, indent=2))  # after every row: an interrupted run keeps them
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


def _acl_figures() -> dict[str, float]:
    """ACL 2.1's strict-bound bits/bone/frame at 2 % per CMU clip (``motionrep/data/acl_strict.csv``, see ``acl.py``)."""
    from motionrep.present.bench.anchors import acl_strict

    return {a.clip + ".bvh": a.payload_bits_per_bone_frame for a in acl_strict() if a.bound_percent == 2}


def compare(rows: list[dict]) -> None:
    """Payload bytes and bits/bone/frame of every codec of ``rows`` against the first one, beside ACL's."""
    import statistics

    codecs = list(dict.fromkeys(r["codec"] for r in rows))
    base, others = codecs[0], codecs[1:]
    by = {(r["clip"], r["codec"]): r for r in rows}
    acl = _acl_figures()
    clips_ = list(dict.fromkeys(r["clip"] for r in rows))
    head = f"| clip | frames | {base} payload B |"
    rule = "|---|---:|---:|"
    for c in others:
        head += f" {c} payload B | / {base} | {c} b/b/f | / ACL | encode s ({base} s) | decode fps ({base}) |"
        rule += "---:|---:|---:|---:|---:|---:|"
    print(head + " ACL b/b/f | load |")
    print(rule + "---:|---:|")
    ratios: dict[str, dict[str, list[float]]] = {c: {"bytes": [], "bpbf": [], "acl": [], "time": [], "fps": []}
                                                 for c in others}
    verified = written = 0
    for clip in clips_:
        b = by.get((clip, base))
        ok_b = b is not None and b["ok"]
        cells = [clip, str(b["frames"]) if ok_b else "?", f"{b['payload_bytes']:,}" if ok_b else _failed(b)]
        loads = [r["load"] for r in (by.get((clip, c)) for c in codecs) if r and "load" in r]
        for c in others:
            r = by.get((clip, c))
            if r is None or not r["ok"]:
                cells += [_failed(r), "–", "–", "–", "–", "–"]
                continue
            a = acl.get(clip)
            ratio = r["payload_bytes"] / b["payload_bytes"] if ok_b else float("nan")
            t = r["seconds"] / b["seconds"] if ok_b else float("nan")
            fps = r["decode_frames_per_second"] / b["decode_frames_per_second"] if ok_b else float("nan")
            for key, v in (("bytes", ratio), ("bpbf", r["payload_bpbf"]), ("time", t), ("fps", fps),
                           ("acl", r["payload_bpbf"] / a if a else float("nan"))):
                ratios[c][key].append(v)
            cells += [f"{r['payload_bytes']:,}", f"{ratio:.3f}", f"{r['payload_bpbf']:.2f}",
                      f"{r['payload_bpbf'] / a:.2f}" if a else "–",
                      f"{r['seconds']:.0f} ({b['seconds']:.0f})" if ok_b else f"{r['seconds']:.0f}",
                      f"{r['decode_frames_per_second']:,.0f} ({b['decode_frames_per_second']:,.0f})" if ok_b else "–"]
        for c in codecs:
            r = by.get((clip, c))
            if r is not None and r["ok"]:
                written += 1
                verified += bool(r.get("verified"))
        cells += [f"{acl[clip]:.2f}" if clip in acl else "–", "-".join(f"{x:.1f}" for x in (min(loads), max(loads)))
                  if loads else "?"]
        print("| " + " | ".join(cells) + " |")
    print()
    print(f"Files written: {written}; within the bound when decompressed to BVH and evaluated: {verified}.")
    for c in others:
        m = {k: statistics.median(v) if v else float("nan") for k, v in ratios[c].items()}
        print(f"{c}: median over {len(ratios[c]['bytes'])} clips: payload {m['bytes']:.3f}x {base}'s, "
              f"{m['bpbf']:.2f} bits/bone/frame = {m['acl']:.2f}x ACL's, encode time {m['time']:.2f}x, "
              f"decode speed {m['fps']:.2f}x")


def _failed(r: dict | None) -> str:
    if r is None:
        return "–"
    if not r["ok"]:
        return f"fail ({2.0 * r['best'] / r['bound']:.2f}%)" if r.get("best") else "fail"
    return "?"


if __name__ == "__main__":
    main()
