"""Every shipped codec beside ACL 2.1 at the same guaranteed bounds, on every CMU clip of ../shared/data.

For each clip (``cmu/**.bvh``), bound (2 %, 0.588 %, 0.0588 % of the character height: ACL's 3.4, 1 and 0.1 cm on
the CMU skeletons) and codec, one task:

1. ``motionrep.pipeline.compress.compress_file`` writes the ``.mrc`` (only if the bound is met, measured by the core on
   the bytes written);
2. ``motionrep decompress X.mrc -o X.bvh`` and ``motionrep evaluate SRC X.bvh --json`` (the command line, run
   in-process through click's test runner to spare a Python start-up per file) check the error of the BVH file
   against the bound;
3. the row records the payload bytes (the codec's arrays, without the skeleton and metadata every codec shares),
   the whole file, bits per bone per frame of both (bones = joints + end sites, ACL's count), the encode time,
   the decode time of the payload to features, and the verified error.

Each task runs in its own forked process, killed after ``--budget`` seconds (the Fourier codecs train networks
and may need much longer; a killed task is reported as ``timeout``). Rows are appended to a JSONL file, and a run
skips the tasks it already has, so it can be stopped and resumed. ``report`` writes the tables
(``results/acl.md``), a CSV of every row and the rate-distortion plot with ACL's points
(``motionrep/data/acl_strict.csv``, figures measured outside this project, with their source).

Usage::

    python benchmarks/acl.py run [--codecs transform,svd] [--bounds 2,0.588,0.0588] [--clips cmu31|cmu]
                                 [--budget 120] [--jobs 1] [--runs results/acl_runs.jsonl]
    python benchmarks/acl.py report [--runs results/acl_runs.jsonl]
    python benchmarks/acl.py speed [--repeat 5]      # transform's encode and decode times -> results/acl_speed.json
    python benchmarks/acl.py entropy                 # the range coder against lzma / zstd -> results/acl_entropy.json

``speed`` measures, on the eight CMU-31 clips at 2 %, in one process, best of ``--repeat``: the encode
(``compress_motion``, the clip already read: features, the codec's search, the core's two checks); preparing a
payload for decoding (``codec.decoder(payload)``: range decoding and the inverse wavelet); sampling the prepared
decoder at the frame times (131072 of them), in blocks of ``motionrep.pipeline.runtime.BLOCK`` into one feature-major
buffer through its compiled kernel, as ``motionrep.open`` calls it (features, frames/s); and
``motionrep.open(...).poses`` (local rotations and root translation, poses/s: the runtime decoder, the
representation's decoding included). The load average is stored beside every figure.

``entropy`` codes the same quantised coefficients (transform at each bound on the eight CMU-31 clips) three
ways: the payload the codec writes (context models, range coder), ``lzma`` (preset 9 | extreme, raw LZMA2) and,
when the ``zstandard`` package is installed, zstd level 22, of the integers as little-endian int16 (int32 when
they do not fit), in the codec's order (level by level, row-major) and feature by feature, the smaller of the two
kept for each general-purpose coder, the step exponents added as int16 to both.
"""

from __future__ import annotations

import argparse
import csv
import json
import multiprocessing
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DATA = Path(os.environ.get("MOTIONREP_SHARED_DATA", REPO.parent / "shared" / "data"))
RESULTS = REPO / "benchmarks" / "results"
ANCHORS = REPO / "benchmarks" / "anchors"
BOUNDS = (2.0, 0.588, 0.0588)
CODECS = ("transform", "svd", "adaptive-fourier:window=125", "naive-fourier:window=125")


def cmu_clips(which: str) -> list[Path]:
    """The CMU clips: ``cmu31`` the eight 31-joint clips ACL's per-clip figures are for, ``cmu`` all of them."""
    from motionrep.io import read

    out = []
    for p in sorted((DATA / "cmu").rglob("*.bvh")):
        if which == "cmu31" and read(p).num_joints != 31:
            continue
        out.append(p)
    return out


def read_anchor(name: str) -> list[dict]:
    with open(ANCHORS / name, newline="") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def acl_figures() -> dict[tuple[str, float], float]:
    """``{(clip, bound %): ACL bits/bone/frame}``; the salsa median under the clip ``salsa-median``."""
    from motionrep.present.bench.anchors import acl_strict

    return {(a.clip, a.bound_percent): a.payload_bits_per_bone_frame for a in acl_strict()}


def probe_figures() -> dict[str, float]:
    return {r["clip"]: float(r["probe_bits_per_bone_frame"]) / float(r["acl_bits_per_bone_frame"])
            for r in read_anchor("probe_2pct.csv")}


def _load() -> float:
    return os.getloadavg()[0]


# ---------------------------------------------------------------------------------------------------------------
# one task
# ---------------------------------------------------------------------------------------------------------------
def run_task(src: str, codec: str, bound: float, workdir: str) -> dict:
    """Compress, decompress to BVH, evaluate; the row of one (clip, codec, bound)."""
    import numpy as np
    from click.testing import CliRunner

    from motionrep.cli import cli
    from motionrep.plugin.codec import Payload, frame_times
    from motionrep.pipeline.compress import compress_file
    from motionrep.errors import BoundNotMetError
    from motionrep.plugin.registry import get_codec

    rel = str(Path(src).relative_to(DATA)).removesuffix(".bvh")
    name, *pairs = codec.split(":")
    params = dict(pair.split("=", 1) for pair in pairs)
    stem = rel.replace("/", "__") + "." + codec.replace(":", "_").replace("=", "") + f".{bound:g}"
    mrc, bvh = Path(workdir) / f"{stem}.mrc", Path(workdir) / f"{stem}.bvh"
    row: dict = {"clip": rel, "codec": codec, "bound_percent": bound, "load": _load()}
    start = time.perf_counter()
    try:
        result = compress_file(src, mrc, name, max_error=f"{bound:g}%", params=params)
    except BoundNotMetError as exc:
        row.update(status="fail", seconds=time.perf_counter() - start, best_error=exc.best_error,
                   bound=exc.bound, message=str(exc), wrote_file=mrc.exists())
        return row
    seconds = time.perf_counter() - start
    c = result.container
    bones = c.skeleton.num_joints + c.skeleton.num_end_sites
    payload = sum(int(np.asarray(a).nbytes) for a in c.arrays.values())
    codec_obj = get_codec(name)
    times = frame_times(c.num_frames)
    best = float("inf")
    for _ in range(5):
        t0 = time.perf_counter()
        codec_obj.decode(Payload(c.arrays, c.info), times)
        best = min(best, time.perf_counter() - t0)
    runner = CliRunner()
    dec = runner.invoke(cli, ["decompress", str(mrc), "-o", str(bvh)])
    ev = runner.invoke(cli, ["evaluate", str(src), str(bvh), "--json"])
    verified = json.loads(ev.output) if ev.exit_code == 0 else None
    row.update(status="ok", seconds=seconds, frames=c.num_frames, joints=c.skeleton.num_joints,
               bones=bones, payload_bytes=payload, file_bytes=mrc.stat().st_size,
               payload_bpbf=8.0 * payload / (c.num_frames * bones),
               file_bpbf=8.0 * mrc.stat().st_size / (c.num_frames * bones),
               info=dict(c.info), stored_error_percent=result.report.max_error_percent, bound=result.bound,
               decode_seconds=best, decode_frames_per_second=c.num_frames / best if best > 0 else None,
               decompress_exit=dec.exit_code, evaluate_exit=ev.exit_code,
               verified_error=None if verified is None else verified["max_error"],
               verified_error_percent=None if verified is None else verified["max_error_percent"],
               verified=bool(verified is not None and verified["max_error"] <= result.bound))
    for p in (mrc, bvh):
        p.unlink(missing_ok=True)
    return row


def _child(conn, src: str, codec: str, bound: float, workdir: str) -> None:
    try:
        conn.send(run_task(src, codec, bound, workdir))
    except Exception as exc:  # noqa: BLE001 - reported as a row, the run goes on
        conn.send({"status": "error", "message": f"{type(exc).__name__}: {exc}"})
    conn.close()


def run(args: argparse.Namespace) -> None:
    runs = Path(args.runs)
    done = set()
    if runs.exists():
        for line in runs.read_text().splitlines():
            r = json.loads(line)
            done.add((r["clip"], r["codec"], r["bound_percent"]))
    clips = cmu_clips(args.clips)
    tasks = [(str(p), codec, bound) for bound in args.bounds for codec in args.codecs for p in clips
             if (str(p.relative_to(DATA)).removesuffix(".bvh"), codec, bound) not in done]
    print(f"{len(tasks)} tasks ({len(done)} already in {runs}); load {_load():.1f}", flush=True)
    # import and load everything once, so that each forked task starts warm
    import motionrep.cli  # noqa: F401
    from motionrep.plugin.registry import get_codec

    for codec in args.codecs:
        get_codec(codec.split(":")[0]).warm_up()
    ctx = multiprocessing.get_context("fork")
    running: list = []
    with tempfile.TemporaryDirectory() as workdir, open(runs, "a") as out:
        def finish(entry, row):
            src, codec, bound, proc, conn, t0 = entry
            rel = str(Path(src).relative_to(DATA)).removesuffix(".bvh")
            row = dict(row, clip=rel, codec=codec, bound_percent=bound)
            out.write(json.dumps(row) + "\n")
            out.flush()
            what = (f"{row.get('payload_bpbf', float('nan')):.3f} b/b/f, verified {row.get('verified')}"
                    if row["status"] == "ok" else row.get("message", "")[:100])
            print(f"{rel:40s} {codec:28s} {bound:<7g} {row['status']:8s} {time.perf_counter() - t0:7.1f}s {what}",
                  flush=True)

        while tasks or running:
            while tasks and len(running) < args.jobs:
                src, codec, bound = tasks.pop(0)
                parent, child = ctx.Pipe(duplex=False)
                proc = ctx.Process(target=_child, args=(child, src, codec, bound, workdir))
                proc.start()
                child.close()
                running.append((src, codec, bound, proc, parent, time.perf_counter()))
            time.sleep(0.05)
            for entry in list(running):
                src, codec, bound, proc, conn, t0 = entry
                if conn.poll():
                    finish(entry, conn.recv())
                    proc.join()
                    running.remove(entry)
                elif not proc.is_alive():
                    finish(entry, {"status": "error", "message": f"worker exited with {proc.exitcode}"})
                    running.remove(entry)
                elif time.perf_counter() - t0 > args.budget:
                    proc.kill()
                    proc.join()
                    finish(entry, {"status": "timeout", "message": f"not done within the {args.budget:g} s budget",
                                   "seconds": time.perf_counter() - t0, "load": _load()})
                    running.remove(entry)


# ---------------------------------------------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------------------------------------------
def _latest(rows: list[dict]) -> dict[tuple[str, str, float], dict]:
    out = {}
    for r in rows:
        out[(r["clip"], r["codec"], r["bound_percent"])] = r
    return out


def _cell(r: dict | None) -> str:
    if r is None:
        return "–"
    if r["status"] == "ok":
        mark = "" if r.get("verified") else " (NOT VERIFIED)"
        return f"{r['payload_bpbf']:.2f}{mark}"
    return {"fail": "fail", "timeout": "timeout"}.get(r["status"], "error")


def report(args: argparse.Namespace) -> None:
    rows = [json.loads(line) for line in Path(args.runs).read_text().splitlines()]
    latest = _latest(rows)
    acl = acl_figures()
    probe = probe_figures()
    clips = sorted({k[0] for k in latest})
    codecs = [c for c in CODECS if any(k[1] == c for k in latest)] + sorted(
        {k[1] for k in latest} - set(CODECS))
    bounds = [b for b in BOUNDS if any(k[2] == b for k in latest)]
    cmu31 = [c for c in clips if (c, 2.0) in acl]
    salsa = [c for c in clips if "beemsoft_salsa" in c]
    lines = ["# Every codec beside ACL 2.1 at a guaranteed bound", "",
             "Written by `python benchmarks/acl.py report` from `acl_runs.jsonl` (see `benchmarks/README.md`). "
             "Sizes are **payload bits per bone per frame** (the codec's bytes x 8 / (frames x (joints + end "
             "sites)), ACL's count); ACL 2.1's strict-bound figures are from `motionrep/data/acl_strict.csv`. "
             "Every size shown was verified: the `.mrc` decompressed to BVH by `motionrep decompress` and measured "
             "by `motionrep evaluate` within the bound.", ""]
    ok = [r for r in latest.values() if r["status"] == "ok"]
    verified = [r for r in ok if r.get("verified")]
    lines += [f"Files written: {len(ok)}; verified within their bound through BVH: {len(verified)} "
              f"({100.0 * len(verified) / max(1, len(ok)):.0f} %). Load average during the runs: "
              f"{min(r['load'] for r in rows):.1f}-{max(r['load'] for r in rows):.1f} (2 cores, shared).", ""]
    # the targets
    lines += ["## transform / ACL, the issue's targets", "",
              "| bound | CMU-31 median ratio | CMU-31 worst ratio | target | salsa median b/b/f | ACL salsa median | "
              "salsa ratio of medians |", "|---|---|---|---|---|---|---|"]
    for b in bounds:
        ratios = [latest[(c, "transform", b)]["payload_bpbf"] / acl[(c, b)] for c in cmu31
                  if latest.get((c, "transform", b), {}).get("status") == "ok"]
        sal = [latest[(c, "transform", b)]["payload_bpbf"] for c in salsa
               if latest.get((c, "transform", b), {}).get("status") == "ok"]
        target = "median <= 0.35, each <= 0.6" if b == 2.0 else "median <= 0.6"
        if ratios:
            sal_m = statistics.median(sal) if sal else float("nan")
            lines.append(f"| {b:g} % | {statistics.median(ratios):.3f} | {max(ratios):.3f} | {target} | "
                         f"{sal_m:.2f} ({len(sal)} clips) | {acl[('salsa-median', b)]:.2f} | "
                         f"{sal_m / acl[('salsa-median', b)]:.3f} |")
    lines.append("")
    for b in bounds:
        lines += [f"## {b:g} % of the character height", "",
                  "| clip | frames | ACL | " + " | ".join(codecs) + " | transform / ACL | probe / ACL | "
                  "transform file b/b/f | encode s |",
                  "|---|---|---|" + "---|" * len(codecs) + "---|---|---|---|"]
        for c in clips:
            t = latest.get((c, "transform", b))
            frames = next((latest[k]["frames"] for k in latest if k[0] == c and latest[k].get("frames")), "")
            a = acl.get((c, b))
            ratio = (f"**{t['payload_bpbf'] / a:.3f}**" if a and t and t["status"] == "ok" else "–")
            pr = f"{probe[c]:.2f}" if b == 2.0 and c in probe else "–"
            tf = f"{t['file_bpbf']:.2f}" if t and t["status"] == "ok" else "–"
            ts = f"{t['seconds']:.2f}" if t and t["status"] == "ok" else "–"
            lines.append(f"| {c} | {frames} | {a if a else '–'} | "
                         + " | ".join(_cell(latest.get((c, k, b))) for k in codecs)
                         + f" | {ratio} | {pr} | {tf} | {ts} |")
        lines.append("")
    fails = [r for r in latest.values() if r["status"] != "ok"]
    if fails:
        lines += ["## What did not finish", "", "| clip | codec | bound | outcome |", "|---|---|---|---|"]
        for r in sorted(fails, key=lambda r: (r["codec"], r["bound_percent"], r["clip"])):
            lines.append(f"| {r['clip']} | {r['codec']} | {r['bound_percent']:g} % | {r['status']}: "
                         f"{r.get('message', '')[:160]} |")
        lines.append("")
    (RESULTS / "acl.md").write_text("\n".join(lines))
    keys = ["clip", "codec", "bound_percent", "status", "frames", "joints", "bones", "payload_bytes", "file_bytes",
            "payload_bpbf", "file_bpbf", "seconds", "decode_frames_per_second", "stored_error_percent",
            "verified_error_percent", "verified", "load"]
    with open(RESULTS / "acl.csv", "w", newline="") as f:
        w = csv.DictWriter(f, keys, extrasaction="ignore")
        w.writeheader()
        for k in sorted(latest):
            w.writerow(latest[k])
    plot(latest, acl, cmu31, salsa, codecs, bounds)
    print("\n".join(lines))


def plot(latest, acl, cmu31, salsa, codecs, bounds) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 5), sharey=True)
    for ax, group, title, acl_key in ((axes[0], cmu31, "CMU, 31 joints (8 clips)", None),
                                      (axes[1], salsa, "CMU salsa, 43 joints", "salsa-median")):
        for i, codec in enumerate(codecs):
            med = []
            for b in bounds:
                vals = [latest[(c, codec, b)]["payload_bpbf"] for c in group
                        if latest.get((c, codec, b), {}).get("status") == "ok"]
                med.append(statistics.median(vals) if len(vals) == len(group) and vals else float("nan"))
            ax.plot(bounds, med, "o-", label=f"{codec} (median)", color=f"C{i}")
            if codec == "transform":
                for c in group:
                    ys = [latest.get((c, codec, b), {}).get("payload_bpbf", float("nan")) for b in bounds]
                    ax.plot(bounds, ys, "-", color="C0", alpha=0.15, lw=1)
        if acl_key is None:
            for c in group:
                ax.plot(bounds, [acl.get((c, b), float("nan")) for b in bounds], "-", color="k", alpha=0.15, lw=1)
            ys = [statistics.median([acl[(c, b)] for c in group if (c, b) in acl]) for b in bounds]
        else:
            ys = [acl[(acl_key, b)] for b in bounds]
        ax.plot(bounds, ys, "s--", color="k", label="ACL 2.1, strict bound (median)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("guaranteed L-inf bound, % of character height")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("payload bits per bone per frame")
    axes[1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(RESULTS / "acl_rd.png", dpi=110)


def speed(args: argparse.Namespace) -> None:
    import numpy as np

    from motionrep.plugin.codec import Payload, frame_times
    from motionrep.pipeline.compress import compress_motion
    from motionrep.io import read
    from motionrep.plugin.registry import get_codec
    from motionrep.pipeline.runtime import BLOCK, open_clip

    codec = get_codec("transform")
    codec.warm_up()

    def best(call) -> float:
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            call()
            times.append(time.perf_counter() - t0)
        return min(times)

    rows = []
    for path in cmu_clips("cmu31"):
        motion = read(path)
        compress_motion(motion, codec, max_error="2%")  # warm caches
        encode = best(lambda: compress_motion(motion, codec, max_error="2%"))
        result = compress_motion(motion, codec, max_error="2%")
        payload = Payload(result.container.arrays, result.container.info)
        F = motion.num_frames
        prepare = best(lambda: codec.decoder(payload))
        decoder = codec.decoder(payload)
        u = np.resize(frame_times(F), 131072)  # the clip's frame times, repeated
        kernel = getattr(decoder, "kernel", None)
        block = np.empty((decoder.width, BLOCK))  # feature-major, as motionrep.open decodes a block

        def sample_all():
            for a in range(0, u.size, BLOCK):
                if kernel is not None:  # the compiled sampler, as motionrep.open calls it
                    getattr(kernel, "dispatcher", kernel)(u[a:a + BLOCK], block, *decoder.kernel_args)
                else:
                    decoder(u[a:a + BLOCK])

        sample_all()  # compiled on first call
        sample = best(sample_all)
        clip = open_clip(result.data)
        seconds = np.tile(np.arange(F) / motion.fps, max(1, 100_000 // F))
        clip.poses(seconds)
        poses = best(lambda: clip.poses(seconds))
        row = {"clip": str(path.relative_to(DATA)).removesuffix(".bvh"), "frames": F,
               "joints": motion.skeleton.num_joints, "encode_seconds": encode, "prepare_seconds": prepare,
               "prepare_frames_per_second": F / prepare, "sample_frames_per_second": u.size / sample,
               "runtime_poses_per_second": seconds.size / poses, "load": _load()}
        rows.append(row)
        print(f"{row['clip']:32s} {F:5d} frames: encode {encode:.2f} s, prepare {1000 * prepare:.1f} ms "
              f"({row['prepare_frames_per_second']:,.0f} frames/s), sample {row['sample_frames_per_second']:,.0f} "
              f"frames/s, runtime {row['runtime_poses_per_second']:,.0f} poses/s, load {row['load']:.1f}",
              flush=True)
    (RESULTS / "acl_speed.json").write_text(json.dumps(rows, indent=1) + "\n")


def entropy(args: argparse.Namespace) -> None:
    import lzma

    import numpy as np

    from motionrep.pipeline.compress import compress_motion
    from motionrep.io import read
    from motionrep_transform._decoder import unpack

    try:
        import zstandard
    except ImportError:  # optional: benchmarks only
        zstandard = None

    def as_bytes(arrays) -> bytes:
        flat = np.concatenate([np.asarray(a).reshape(-1) for a in arrays])
        dtype = "<i2" if flat.size == 0 or np.abs(flat).max() < 2 ** 15 else "<i4"
        return flat.astype(dtype).tobytes()

    rows = []
    for bound in BOUNDS:
        for path in cmu_clips("cmu31"):
            result = compress_motion(read(path), "transform", max_error=f"{bound:g}%")
            q = unpack(result.container.arrays["data"].tobytes(), result.container.codec_version)
            side = [q.feature_exponents, q.region_exponents]
            layouts = {"levels": as_bytes(side + q.coefficients),
                       "features": as_bytes(side + [c.T for c in q.coefficients])}
            row = {"clip": str(path.relative_to(DATA)).removesuffix(".bvh"), "bound_percent": bound,
                   "range_coder": int(result.container.payload_bytes),
                   "lzma": min(len(lzma.compress(b, format=lzma.FORMAT_RAW, filters=[
                       {"id": lzma.FILTER_LZMA2, "preset": 9 | lzma.PRESET_EXTREME}])) for b in layouts.values()),
                   "zstd": None if zstandard is None else min(
                       len(zstandard.ZstdCompressor(level=22).compress(b)) for b in layouts.values())}
            rows.append(row)
            print(f"{row['clip']:32s} {bound:<7g} range coder {row['range_coder']:6d} B, lzma {row['lzma']:6d} B, "
                  f"zstd {row['zstd']} B", flush=True)
    (RESULTS / "acl_entropy.json").write_text(json.dumps(rows, indent=1) + "\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run")
    r.add_argument("--codecs", default=",".join(CODECS), type=lambda s: s.split(","))
    r.add_argument("--bounds", default=",".join(f"{b:g}" for b in BOUNDS),
                   type=lambda s: [float(x) for x in s.split(",")])
    r.add_argument("--clips", choices=("cmu31", "cmu"), default="cmu")
    r.add_argument("--budget", type=float, default=120.0, help="seconds per task before it is killed")
    r.add_argument("--jobs", type=int, default=1)
    r.add_argument("--runs", default=str(RESULTS / "acl_runs.jsonl"))
    p = sub.add_parser("report")
    p.add_argument("--runs", default=str(RESULTS / "acl_runs.jsonl"))
    sp = sub.add_parser("speed")
    sp.add_argument("--repeat", type=int, default=5)
    sub.add_parser("entropy")
    args = ap.parse_args()
    if args.command == "run":
        run(args)
    elif args.command == "speed":
        speed(args)
    elif args.command == "entropy":
        entropy(args)
    else:
        report(args)


if __name__ == "__main__":
    sys.exit(main())
