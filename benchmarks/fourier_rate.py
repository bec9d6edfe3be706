"""adaptive-fourier's rate at 2 % beside ACL 2.1's strict-bound sizes, clip by clip, with where the bytes go.

For each clip (the eight CMU-31 clips of ACL's figures, or others with ``--clips``) and each codec setting, one task
in its own forked process:

1. ``motionrep.pipeline.compress.compress_file`` writes the ``.mrc`` at ``--bound`` % (2 by default);
2. ``motionrep decompress`` to BVH and ``motionrep evaluate`` check the error from the BVH file (click's runner,
   in-process, as ``acl.py`` does);
3. the row records payload bytes, bits per bone per frame (ACL's count: bones = joints + end sites), the ratio to
   ACL's strict-bound figure (``motionrep/data/acl_strict.csv``), the encode wall time and CPU time (this process and
   its window workers), the load average, and the payload's breakdown: per window its K, hidden width, step
   indices and the ideal coded bits of each part (head, frequencies, column exponents, hidden layers ``Q0``, ``Q1``,
   output weights ``Q2``, output biases), as ``motionrep_fourier._packed`` codes them.

``--set module.NAME=value`` sets a constant of a ``motionrep_fourier`` module in the task's process before it
encodes (for measuring a lever against the default in the same run; the label names the setting).

Usage::

    python benchmarks/fourier_rate.py run [--label main] [--codec adaptive-fourier] [--clips cmu31|NAMES]
                                          [--set _quantise._COARSER=24] [--runs results/fourier_rate_runs.jsonl]
    python benchmarks/fourier_rate.py report [--runs ...] [--labels a,b]   # Markdown tables of the runs
    python benchmarks/fourier_rate.py speed [--label branch] [--repeat 3]  # warm encode times, best of N
    python benchmarks/fourier_rate.py determinism [--clips cmu31]        # payloads across jobs and threads
"""

from __future__ import annotations

import argparse
import importlib
import json
import multiprocessing
import os
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DATA = Path(os.environ.get("MOTIONREP_SHARED_DATA", REPO.parent / "shared" / "data"))
RESULTS = REPO / "benchmarks" / "results"
CMU31 = ("cmu/BvhToDeepMimic/02_01", "cmu/InverseKinematics/02_01", "cmu/RGBDAcquisition/102_01cc",
         "cmu/bvh-matlab/walk", "cmu/bvh11/131_01", "cmu/bvh11/131_03", "cmu/fairmotion/01_01",
         "cmu/pybvh/cmu_12_01_walk")
#: Clips a constant of the codec may be chosen on (other skeletons, studios and frame rates than the targets'):
#: the CMU-31 clips, and :data:`HELD_OUT`, are then held out.
FIT = ("other/BvhToDeepMimic/0005_Walking001", "other/bvh-toolbox/walk01", "other/bandai_namco/dataset-1_bow_active_001",
       "other/ganimator/Elephant-idle1", "cmu/ganimator/08_01_trimmed", "other/bvh-python-20tab/test_mocapbank",
       "other/MocapNET/gestures_help", "other/bandai_namco/dataset-1_dash_normal_001")
#: Clips never used to choose anything, beside the CMU-31 clips.
HELD_OUT = ("cmu/beemsoft_salsa/60_01_scaled", "cmu/beemsoft_salsa/61_10_scaled", "other/bvhio/test",
            "other/bvh-python/samba_dancing", "other/BVHFiles.jl/Example", "other/bvh11/sample")


def _cpu() -> float:
    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def breakdown(data) -> dict:
    """Ideal coded bits of each part of a quantised payload's ``data`` array, and each window's K, h and steps."""
    import numpy as np

    from motionrep.plugin.coding import fit_matrix_model
    from motionrep_fourier._packed import unpack

    edges, scale, networks = unpack(np.asarray(data))
    parts = {"columns": 0.0, "Q0": 0.0, "Q1": 0.0, "Q2": 0.0, "b2": 0.0}
    omega2 = np.concatenate([n.omega2 for n in networks])[None, :]
    freq = fit_matrix_model(omega2).cost(omega2)
    windows = []
    for n in networks:
        Q0, Q1, Q2 = n.layers
        bits = {"columns": np.concatenate(n.columns)[None, :], "Q0": Q0, "Q1": Q1, "Q2": Q2[:, :-1],
                "b2": Q2[:, -1][None, :]}
        cost = {k: fit_matrix_model(v).cost(v) for k, v in bits.items()}
        for k, v in cost.items():
            parts[k] += v
        windows.append({"frames": None, "K": n.K, "h": int(Q0.shape[0]), "steps": n.steps.tolist(),
                        "nonzero": {k: int(np.count_nonzero(v)) for k, v in bits.items() if k != "columns"},
                        "bits": {k: round(v, 1) for k, v in cost.items()}})
    for w, a, b in zip(windows, edges[:-1], edges[1:]):
        w["frames"] = int(b - a + 1)
    total_bits = 8.0 * np.asarray(data).size
    parts["frequencies"] = freq
    parts["head"] = total_bits - sum(parts.values())  # lengths, K, output scale, steps, models, coder's end
    return {"parts_bits": {k: round(float(v), 1) for k, v in parts.items()}, "windows": windows}


def run_task(src: str, codec: str, bound: float, sets: list[str], workdir: str) -> dict:
    import numpy as np
    from click.testing import CliRunner

    from motionrep.cli import cli
    from motionrep.errors import BoundNotMetError
    from motionrep.pipeline.compress import compress_file
    from motionrep.present.bench.anchors import acl_strict

    for item in sets:  # module.NAME=value, a constant of a motionrep_fourier module
        target, value = item.split("=", 1)
        module, name = target.rsplit(".", 1)
        setattr(importlib.import_module(f"motionrep_fourier.{module}"), name, json.loads(value))
    rel = str(Path(src).relative_to(DATA)).removesuffix(".bvh")
    name, *pairs = codec.split(":")
    params = dict(pair.split("=", 1) for pair in pairs)
    stem = rel.replace("/", "__")
    mrc, bvh = Path(workdir) / f"{stem}.mrc", Path(workdir) / f"{stem}.bvh"
    row: dict = {"clip": rel, "codec": codec, "bound_percent": bound, "sets": sets, "load": os.getloadavg()[0]}
    cpu0, start = _cpu(), time.perf_counter()
    try:
        result = compress_file(src, mrc, name, max_error=f"{bound:g}%", seed=0, params=params)
    except BoundNotMetError as exc:
        row.update(status="fail", seconds=time.perf_counter() - start, cpu_seconds=_cpu() - cpu0,
                   best_error=exc.best_error, bound=exc.bound, message=str(exc))
        return row
    seconds, cpu = time.perf_counter() - start, _cpu() - cpu0
    c = result.container
    bones = c.skeleton.num_joints + c.skeleton.num_end_sites
    payload = sum(int(np.asarray(a).nbytes) for a in c.arrays.values())
    acl = {a.clip: a.payload_bits_per_bone_frame for a in acl_strict() if a.bound_percent == bound}
    runner = CliRunner()
    dec = runner.invoke(cli, ["decompress", str(mrc), "-o", str(bvh)])
    ev = runner.invoke(cli, ["evaluate", str(src), str(bvh), "--json"])
    # stdout only: a notice on stderr (compiled kernels being prepared) is not part of the JSON
    verified = json.loads(ev.stdout) if ev.exit_code == 0 and dec.exit_code == 0 else None
    bpbf = 8.0 * payload / (c.num_frames * bones)
    row.update(status="ok", seconds=seconds, cpu_seconds=cpu, load_after=os.getloadavg()[0], frames=c.num_frames,
               joints=c.skeleton.num_joints, bones=bones, width=None, payload_bytes=payload, payload_bpbf=bpbf,
               acl_bpbf=acl.get(rel), acl_ratio=bpbf / acl[rel] if rel in acl else None,
               seconds_per_1000_frames=1000.0 * seconds / c.num_frames,
               info={k: v for k, v in c.info.items() if k in ("K", "windows", "hidden", "steps", "parameters")},
               stored_error_percent=result.report.max_error_percent, bound=result.bound,
               verified_error=None if verified is None else verified["max_error"],
               verified=bool(verified is not None and verified["max_error"] <= result.bound))
    if "data" in c.arrays:
        row.update(breakdown(c.arrays["data"]))
    for p in (mrc, bvh):
        p.unlink(missing_ok=True)
    return row


def _child(conn, *args) -> None:
    try:
        conn.send(run_task(*args))
    except Exception as exc:  # noqa: BLE001 - reported as a row, the run goes on
        conn.send({"status": "error", "message": f"{type(exc).__name__}: {exc}"})
    conn.close()


def clip_list(which: str) -> list[str]:
    if which == "cmu31":
        return list(CMU31)
    if which == "held-out":
        return list(HELD_OUT)
    if which == "fit":
        return list(FIT)
    return which.split(",")


def rows_of(runs: str) -> list[dict]:
    path = Path(runs)
    return [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []


def run(args: argparse.Namespace) -> None:
    done = {(r["label"], r["clip"], r["bound_percent"]) for r in rows_of(args.runs) if r["status"] in ("ok", "fail")}
    tasks = [c for c in clip_list(args.clips) if (args.label, c, args.bound) not in done]
    print(f"{len(tasks)} tasks for {args.label!r}; load {os.getloadavg()[0]:.1f}", flush=True)
    import motionrep.cli  # noqa: F401  (every task forks warm)
    from motionrep.plugin.registry import get_codec

    get_codec(args.codec.split(":")[0]).warm_up()
    ctx = multiprocessing.get_context("fork")
    with tempfile.TemporaryDirectory() as workdir, open(args.runs, "a") as out:
        for clip in tasks:
            parent, child = ctx.Pipe(duplex=False)
            proc = ctx.Process(target=_child, args=(child, str(DATA / f"{clip}.bvh"), args.codec, args.bound,
                                                    args.set, workdir))
            t0 = time.perf_counter()
            proc.start()
            child.close()
            row = parent.recv() if parent.poll(args.budget) else {"status": "timeout"}
            proc.kill()
            proc.join()
            row = dict(row, label=args.label, clip=clip, codec=args.codec, bound_percent=args.bound)
            out.write(json.dumps(row) + "\n")
            out.flush()
            what = (f"{row['payload_bytes']} B {row['payload_bpbf']:.3f} b/b/f ratio {row.get('acl_ratio') or 0:.3f} "
                    f"verified {row['verified']} cpu {row['cpu_seconds']:.1f}s" if row["status"] == "ok"
                    else row.get("message", "")[:120])
            print(f"{clip:36s} {row['status']:7s} {time.perf_counter() - t0:6.1f}s {what}", flush=True)


def _latest(rows: list[dict]) -> dict:
    return {(r["label"], r["clip"], r["bound_percent"]): r for r in rows}


def report(args: argparse.Namespace) -> None:
    rows = rows_of(args.runs)
    latest = _latest(rows)
    labels = args.labels.split(",") if args.labels else list(dict.fromkeys(r["label"] for r in rows))
    clips = list(dict.fromkeys(k[1] for k in latest if k[0] in labels))
    for label in labels:
        print(f"\n### {label}\n")
        print("| clip | frames | windows | K | bytes | b/b/f | / ACL | Q0 | Q1 | Q2 | b2 | other | enc s | s/1000 f "
              "| CPU s | load | verified |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        for clip in clips:
            r = latest.get((label, clip, 2.0))
            if r is None:
                continue
            if r["status"] != "ok":
                print(f"| {clip} | | | | {r['status']} | | | | | | | | | | | | |")
                continue
            p = r.get("parts_bits", {})
            total = 8.0 * r["payload_bytes"]
            share = {k: f"{100.0 * v / total:.0f} %" for k, v in p.items()}
            other = 100.0 * (p.get("columns", 0) + p.get("frequencies", 0) + p.get("head", 0)) / total if p else 0
            K = r["info"].get("K")
            ratio = f"{r['acl_ratio']:.3f}" if r.get("acl_ratio") else "–"
            print(f"| {clip} | {r['frames']} | {r['info'].get('windows', 1)} | {K} | {r['payload_bytes']} | "
                  f"{r['payload_bpbf']:.2f} | {ratio} | {share.get('Q0', '')} | {share.get('Q1', '')} | "
                  f"{share.get('Q2', '')} | {share.get('b2', '')} | {other:.0f} % | {r['seconds']:.1f} | "
                  f"{r['seconds_per_1000_frames']:.1f} | {r['cpu_seconds']:.1f} | {r['load']:.1f} | "
                  f"{r['verified']} |")
        ok = [latest[(label, c, 2.0)] for c in clips if latest.get((label, c, 2.0), {}).get("status") == "ok"]
        ratios = [r["acl_ratio"] for r in ok if r.get("acl_ratio")]
        if ratios:
            print(f"\nACL ratio: median {statistics.median(ratios):.3f}, worst {max(ratios):.3f} "
                  f"({len(ratios)} clips); bytes in all {sum(r['payload_bytes'] for r in ok)}")


def speed(args: argparse.Namespace) -> None:
    """Encode times of each clip in this process, warm (a first encode of the clip not timed), best of
    ``--repeat``: wall and CPU seconds (this process and its window workers), per 1000 frames, with the load. One
    JSON line per clip appended to ``--out`` (the tree's ``motionrep`` is whatever this Python imports: run it
    with another tree's interpreter to time that tree in the same way)."""
    from motionrep.io import read
    from motionrep.pipeline.compress import Pipeline

    import motionrep

    for clip in clip_list(args.clips):
        motion = read(DATA / f"{clip}.bvh")
        pipeline = Pipeline.build(args.codec.split(":")[0], max_error=f"{args.bound:g}%", params=dict(
            pair.split("=", 1) for pair in args.codec.split(":")[1:]))
        pipeline.compress(motion)  # warm: kernels, caches
        best = None
        for _ in range(args.repeat):
            load, cpu0, t0 = os.getloadavg()[0], _cpu(), time.perf_counter()
            result = pipeline.compress(motion)
            wall, cpu = time.perf_counter() - t0, _cpu() - cpu0
            if best is None or wall < best["seconds"]:
                best = {"seconds": wall, "cpu_seconds": cpu, "load": load}
        row = {"label": args.label, "tree": str(Path(motionrep.__file__).parent.parent), "clip": clip,
               "frames": motion.num_frames, "payload_bytes": result.container.payload_bytes, **best,
               "seconds_per_1000_frames": 1000.0 * best["seconds"] / motion.num_frames}
        with open(args.out, "a") as out:
            out.write(json.dumps(row) + "\n")
        print(f"{args.label:10s} {clip:36s} {best['seconds']:6.2f} s {row['seconds_per_1000_frames']:5.1f} s/1000 f "
              f"cpu {best['cpu_seconds']:5.2f} load {best['load']:.1f}", flush=True)


_ONE_ENCODE = r"""
import hashlib, json, sys
import numpy as np
from motionrep.pipeline.compress import compress_file
path, codec, bound, jobs = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
params = dict(pair.split("=", 1) for pair in codec.split(":")[1:])
params.update({} if jobs == "default" else {"jobs": int(jobs)})
r = compress_file(path, None, codec.split(":")[0], max_error=bound + "%", seed=0, params=params)
data = b"".join(np.ascontiguousarray(a).tobytes() for a in r.container.arrays.values())
print(json.dumps({"payload_sha256": hashlib.sha256(data).hexdigest(), "payload_bytes": len(data)}))
"""


def determinism(args: argparse.Namespace) -> None:
    """Each clip encoded in fresh processes with ``jobs`` 1, 2 and the default, under 1, 2 and 4 BLAS / OpenMP
    threads (environment): the payloads must be byte-identical."""
    import subprocess

    same = True
    for clip in clip_list(args.clips):
        digests = []
        for jobs, threads in (("1", "1"), ("2", "2"), ("default", "4")):
            env = dict(os.environ, OPENBLAS_NUM_THREADS=threads, OMP_NUM_THREADS=threads, MKL_NUM_THREADS=threads)
            out = subprocess.run([sys.executable, "-c", _ONE_ENCODE, str(DATA / f"{clip}.bvh"), args.codec,
                                  f"{args.bound:g}", jobs], capture_output=True, text=True, env=env, check=True)
            digests.append(json.loads(out.stdout.strip().splitlines()[-1]))
        identical = len({d["payload_sha256"] for d in digests}) == 1
        same &= identical
        print(f"{clip:36s} {digests[0]['payload_bytes']:7d} B {digests[0]['payload_sha256'][:16]} "
              f"{'identical' if identical else 'DIFFERENT: ' + str([d['payload_sha256'][:16] for d in digests])}",
              flush=True)
    print("every payload identical" if same else "NOT every payload identical")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--label", default="main")
    r.add_argument("--codec", default="adaptive-fourier")
    r.add_argument("--clips", default="cmu31", help="cmu31, fit, held-out, or comma-separated clip paths")
    r.add_argument("--bound", type=float, default=2.0)
    r.add_argument("--set", action="append", default=[], help="module.NAME=json value (motionrep_fourier)")
    r.add_argument("--budget", type=float, default=1800.0)
    r.add_argument("--runs", default=str(RESULTS / "fourier_rate_runs.jsonl"))
    t = sub.add_parser("speed")
    t.add_argument("--label", default="branch")
    t.add_argument("--codec", default="adaptive-fourier")
    t.add_argument("--clips", default="cmu31")
    t.add_argument("--bound", type=float, default=2.0)
    t.add_argument("--repeat", type=int, default=3)
    t.add_argument("--out", default=str(RESULTS / "fourier_rate_speed.jsonl"))
    d = sub.add_parser("determinism")
    d.add_argument("--codec", default="adaptive-fourier")
    d.add_argument("--clips", default="cmu31")
    d.add_argument("--bound", type=float, default=2.0)
    p = sub.add_parser("report")
    p.add_argument("--runs", default=str(RESULTS / "fourier_rate_runs.jsonl"))
    p.add_argument("--labels", default=None)
    args = ap.parse_args()
    if not DATA.is_dir():
        sys.exit(f"no real clips at {DATA}")
    {"run": run, "report": report, "speed": speed, "determinism": determinism}[args.cmd](args)


if __name__ == "__main__":
    main()
