"""Speed of the adaptive-Fourier codec: compression time per clip and per stage, where the time goes, decode
throughput, memory.

Measurements (each clip in a fresh process, so that memory peaks and first-call costs are per clip):

1. ``encode``: ``compress_motion(motion, "adaptive-fourier", max_error="2%")`` on each 31-joint CMU clip (without
   the T-pose frame most of them start with, as in ``benchmarks/paper.py``), timed
   by the wall clock, with a ``progress`` callback that timestamps every event the codec reports (one per 25
   L-BFGS iterations, with K and the error of the stored payload when it is checked): seconds and iterations
   per stage (per K), and the time after the last event (packing, decoding and measuring the payload twice).
   Peak resident memory (``ru_maxrss``) before and after.  torch is imported and warmed up first
   (``Codec.warm_up`` of the Fourier codecs); that one-time cost is reported separately.
2. ``profile``: the same on one clip under ``cProfile``, with the time grouped by what it is spent on (network
   forward/backward, the L-BFGS direction, line-search bookkeeping, the shared evaluation and its parts,
   frequency selection, the pipeline's own checks), and ``tracemalloc``'s peak of numpy/Python allocations.
3. ``decode``: a clip compressed with ``svd`` at 2 %, ``adaptive-fourier`` (K = 10, as in the paper) and
   ``transform`` (when installed), in every representation, opened with the runtime decoder (``motionrep.open``)
   and sampled at 200,000 random times (best of 3): poses per second (float64 and float32 rotations), the codec
   alone, the median time of one pose, beside the figures before it and the targets; and the start-up of a fresh
   process (numba's cache warm and empty).

Results: ``benchmarks/results/speed.json`` and ``benchmarks/results/speed.md``; the 1-minute load average is
recorded with every measurement (the machine is shared).

Usage::

    python benchmarks/speed.py [--clips NAME ...] [--profile-clip NAME] [--decode-poses 200000] [--skip decode ...]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DATA = Path(os.environ.get("MOTIONREP_SHARED_DATA", REPO.parent / "shared" / "data"))
RESULTS = REPO / "benchmarks" / "results"
#: Repeats of each decode throughput measurement (the best is kept).
REPEATS = 3
#: The 31-joint CMU clips (cgspeed rig, 120 fps), shortest first.
CLIPS = ("RGBDAcquisition/102_01cc", "InverseKinematics/02_01", "BvhToDeepMimic/02_01", "bvh-matlab/walk",
         "pybvh/cmu_12_01_walk", "bvh11/131_01", "bvh11/131_03", "fairmotion/01_01")


def _load() -> float:
    return round(os.getloadavg()[0], 2)


def _rss_mb() -> float:
    """Peak resident memory of this process since it started or since :func:`_reset_peak`, in MB."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # kB on Linux


def _current_rss_mb() -> float | None:
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return None


def _reset_peak() -> bool:
    """Reset the kernel's peak-RSS counter (Linux: write 5 to /proc/self/clear_refs), so that the peak of the
    encode is seen even when importing torch peaked higher."""
    try:
        Path("/proc/self/clear_refs").write_text("5")
        return True
    except OSError:
        return False


def _code() -> str:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from paper import code_hash

    return code_hash()


def _path(name: str) -> Path:
    return DATA / "cmu" / f"{name}.bvh"


def _read(name: str, trim: bool):
    """The clip, without its leading transition (T-pose frame) when ``trim`` (as ``benchmarks/paper.py``)."""
    from motionrep.io import read

    motion = read(_path(name))
    if not trim:
        return motion, 0
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from paper import leading_transition

    n = leading_transition(motion)
    return (motion.frames(slice(n, None)) if n else motion), n


# ---------------------------------------------------------------------------------------------------------------
# 1. encode one clip (child process)
# ---------------------------------------------------------------------------------------------------------------
def encode_one(name: str, bound: str, trim: bool = True) -> dict:
    t = time.perf_counter()
    from motionrep.plugin.registry import get_codec

    get_codec("adaptive-fourier").warm_up()
    warm = time.perf_counter() - t
    from motionrep.pipeline.compress import compress_motion
    from motionrep.errors import BoundNotMetError

    t = time.perf_counter()
    motion, dropped = _read(name, trim)
    read_s = time.perf_counter() - t
    rss_before = _current_rss_mb()
    peak_reset = _reset_peak()
    events: list[tuple[float, dict]] = []

    def progress(stage, fields):
        events.append((time.perf_counter(), {k: v for k, v in fields.items() if k != "omega"}))

    load0 = _load()
    start = time.perf_counter()
    try:
        result = compress_motion(motion, "adaptive-fourier", max_error=bound, progress=progress, seed=0)
        outcome = {"ok": True, "K": result.container.info.get("K"), "error_percent": result.report.max_error_percent,
                   "paper_ratio": result.figures.paper_ratio, "evaluations": result.evaluations,
                   "iterations": result.container.info.get("iterations"), "seconds_reported": result.seconds}
    except BoundNotMetError as exc:
        best = None if exc.best_error is None else 100 * exc.best_error / _height(motion)
        outcome = {"ok": False, "best_error_percent": best, "message": str(exc)}
    total = time.perf_counter() - start
    stages = []
    prev = start
    # stages by K where the codec's progress names it (windows and the numpy training may not: one stage then)
    for K in dict.fromkeys(f.get("K") for _, f in events):
        mine = [(t, f) for t, f in events if f.get("K") == K]
        end = mine[-1][0]
        checked = [f for _, f in mine if "error" in f]
        stages.append({"K": K, "seconds": end - prev, "iterations": mine[-1][1].get("iteration"),
                       "checks": len(checked),
                       "error_percent": checked[-1]["error_percent"] if checked else None})
        prev = end
    return {"clip": name, "code": _code(), "frames": motion.num_frames, "dropped": dropped, "joints": motion.num_joints,
            "bound": bound, "seconds": total, "after_last_event": total - (prev - start), "stages": stages,
            "read_seconds": read_s, "warm_up_seconds": warm, "rss_mb_before": rss_before, "rss_mb_peak": _rss_mb(),
            "peak_reset": peak_reset,
            "load_start": load0, "load_end": _load(), **outcome}


def _height(motion) -> float:
    from motionrep.model.kinematics import character_height

    return character_height(motion.skeleton)


# ---------------------------------------------------------------------------------------------------------------
# 2. profile one clip (child process)
# ---------------------------------------------------------------------------------------------------------------
#: (label, file suffix, function name): cumulative times read from the profile.
_PROFILE_KEYS = [
    ("compress_motion (everything)", "motionrep/pipeline/compress.py", "compress_motion"),
    ("codec encode", "_codecs.py", "encode"),
    ("L-BFGS run (training)", "_lbfgs.py", "run"),
    ("network loss and gradient (torch)", "_trainnet.py", "loss_and_grad"),
    ("L-BFGS two-loop direction (numpy)", "_lbfgs.py", "_direction"),
    ("strong-Wolfe line search (scipy)", "_linesearch.py", "line_search_wolfe2"),
    ("line search", "_lbfgs.py", "_line_search"),
    ("shared evaluation of candidates", "motionrep/pipeline/compress.py", "evaluate_payload"),
    ("  codec decode (compiled float32 network)", "_codecs.py", "decode"),
    ("  representation from_features", "_rep.py", "from_features"),
    ("  evaluator (FK + L-inf)", "motionrep/pipeline/evaluate.py", "__call__"),
    ("payload building", "_train.py", "payload_of"),
    ("frequency selection (PCA + DCT)", "_train.py", "next_adaptive_frequency"),
    ("network growth (warm start)", "_trainnet.py", "grow"),
    ("container pack", "motionrep/io/container.py", "pack"),
    ("container unpack", "motionrep/io/container.py", "unpack"),
]


def profile_one(name: str, bound: str, trim: bool = True) -> dict:
    import cProfile
    import pstats
    import tracemalloc

    from motionrep.plugin.registry import get_codec

    get_codec("adaptive-fourier").warm_up()
    from motionrep.pipeline.compress import compress_motion
    from motionrep.errors import BoundNotMetError

    motion, _ = _read(name, trim)
    prof = cProfile.Profile()
    load0 = _load()
    start = time.perf_counter()
    prof.enable()
    try:
        compress_motion(motion, "adaptive-fourier", max_error=bound, seed=0)
        ok = True
    except BoundNotMetError:
        ok = False
    prof.disable()
    profiled = time.perf_counter() - start
    stats = pstats.Stats(prof)
    cum: dict[str, float] = {}
    calls: dict[str, int] = {}
    for (filename, _line, func), (cc, nc, tt, ct, _callers) in stats.stats.items():
        for label, suffix, fname in _PROFILE_KEYS:
            # several functions of one name (a closure calling a method): keep the outermost (largest) one
            if func == fname and filename.endswith(suffix) and ct > cum.get(label, -1.0):
                cum[label] = ct
                calls[label] = nc
    top = sorted(((tt, f"{Path(fn).name}:{func}", nc) for (fn, _l, func), (cc, nc, tt, ct, _c) in
                  stats.stats.items()), reverse=True)[:15]
    # memory: numpy and Python allocations during one encode (torch's own allocator is not traced)
    tracemalloc.start()
    try:
        compress_motion(motion, "adaptive-fourier", max_error=bound, seed=0)
    except BoundNotMetError:
        pass
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return {"clip": name, "code": _code(), "frames": motion.num_frames, "bound": bound, "ok": ok,
            "profiled_seconds": profiled,
            "cumulative": cum, "calls": calls,
            "top_self": [{"function": f, "self_seconds": t, "calls": n} for t, f, n in top],
            "tracemalloc_peak_mb": peak / 2**20, "rss_mb_peak": _rss_mb(), "load_start": load0, "load_end": _load()}


# ---------------------------------------------------------------------------------------------------------------
# 3. decode throughput (in this process)
# ---------------------------------------------------------------------------------------------------------------
#: The decode figures before the runtime decoder (results/speed.md at code 689765ee00c5, quiet machine: load
#: 1.0-1.3) and the targets of issue 12.
DECODE_PREVIOUS = {"poses_per_second": "139k-170k (adaptive-fourier), 208k-285k (svd)",
                   "one_pose_us": "399 (adaptive-fourier), 248 (svd)"}
DECODE_TARGETS = {"poses_per_second": 1_000_000, "one_pose_us": 20.0}
#: Codecs of the decode measurement: (name, compress options). ``transform`` is measured when it is installed.
DECODE_CODECS = (("svd", {"max_error": "2%"}),
                 # K = 10 as in the paper; decoding costs the same however long it trained (100 iterations a stage)
                 ("adaptive-fourier", {"max_error": None, "params": {"k": 10, "iters": 100}}),
                 ("transform", {"max_error": "2%"}))
DECODE_REPRESENTATIONS = ("root-quat-axis-angle", "euler", "ortho6d", "dual-quaternion")


def _cpu_best(fn, repeats: int) -> tuple[float, float]:
    """Best wall-clock and best thread-CPU seconds of ``repeats`` runs of ``fn()`` (the CPU time leaves out the
    time this thread waited for a core, which on a shared machine is most of the noise)."""
    import gc

    wall = cpu = float("inf")
    gc.collect()
    gc.disable()
    try:
        for _ in range(repeats):
            w, c = time.perf_counter(), time.thread_time()
            fn()
            wall, cpu = min(wall, time.perf_counter() - w), min(cpu, time.thread_time() - c)
    finally:
        gc.enable()
    return wall, cpu


def decode_speed(name: str, poses: int) -> dict:
    """The runtime decoder (``motionrep.open``) on one clip, every codec x representation: batched poses per
    second (``clip.poses(times, out=...)``, float64 and float32 rotations), the codec alone (feature vectors
    per second), the median time of ``clip.pose(t)``, and numba's start-up in fresh processes."""
    import numpy as np

    import motionrep
    from motionrep.pipeline.compress import compress_motion
    from motionrep.errors import MotionrepError
    from motionrep.plugin.registry import get_codec
    from motionrep.plugin.representation import empty_poses

    get_codec("adaptive-fourier").warm_up()
    motion, _ = _read(name, True)
    out = {"clip": name, "code": _code(), "frames": motion.num_frames, "joints": motion.num_joints, "poses": poses,
           "repeats": REPEATS, "load_start": _load(), "codecs": [], "previous": DECODE_PREVIOUS,
           "targets": DECODE_TARGETS}
    rng = np.random.default_rng(0)
    sample = None
    for codec_name, options in DECODE_CODECS:
        try:
            get_codec(codec_name)
        except MotionrepError:
            print(f"  {codec_name}: not installed, skipped", flush=True)
            continue
        for rep in DECODE_REPRESENTATIONS:
            try:
                result = compress_motion(motion, codec_name, representation=rep, seed=0, **options)
            except MotionrepError as exc:
                out["codecs"].append({"codec": codec_name, "representation": rep, "error": str(exc)})
                continue
            clip = motionrep.open(result.data)
            if sample is None and codec_name == "adaptive-fourier":
                sample = result.data
            times = rng.random(poses) * clip.duration
            entry = {"codec": codec_name, "representation": rep, "bytes": len(result.data),
                     "info": {k: v for k, v in result.container.info.items() if k != "omega"},
                     "error_percent": result.report.max_error_percent, "load_start": _load()}
            for dtype in (np.float64, np.float32):
                buffer = empty_poses(clip.skeleton, poses, dtype)
                clip.poses(times, out=buffer)  # pages touched, kernels compiled
                wall, cpu = _cpu_best(lambda: clip.poses(times, out=buffer), REPEATS)
                entry[f"poses_per_second_{np.dtype(dtype).name}"] = poses / wall
                entry[f"poses_per_cpu_second_{np.dtype(dtype).name}"] = poses / cpu
            u = clip.normalized_times(times)
            decoder = clip._decoder
            kernel = getattr(decoder, "kernel", None)
            features = np.empty((decoder.width, 512))  # feature-major, as motionrep.open decodes a block

            def codec_only():
                for a in range(0, poses, 512):
                    if kernel is not None:  # the compiled decoder, as motionrep.open calls it
                        kernel.dispatcher(u[a:a + 512], features, *decoder.kernel_args)
                    else:
                        decoder(u[a:a + 512])

            wall, cpu = _cpu_best(codec_only, REPEATS)
            entry["features_per_second"], entry["features_per_cpu_second"] = poses / wall, poses / cpu
            single, single_cpu = [], []
            for t in rng.random(3000) * clip.duration:
                s, c = time.perf_counter(), time.thread_time()
                clip.pose(t)
                single.append(time.perf_counter() - s)
                single_cpu.append(time.thread_time() - c)
            entry["one_pose_seconds_median"] = statistics.median(single)
            entry["one_pose_seconds_p90"] = sorted(single)[int(0.9 * len(single))]
            entry["one_pose_cpu_seconds_median"] = statistics.median(single_cpu)
            entry["load_end"] = _load()
            out["codecs"].append(entry)
            print(f"  {codec_name} / {rep}: {entry['poses_per_second_float64']:,.0f} poses/s, one pose "
                  f"{1e6 * entry['one_pose_seconds_median']:.1f} us (load {entry['load_end']})", flush=True)
    if sample is not None:
        out["start_up"] = _start_up(sample)
    out["load_end"] = _load()
    return out


_START_UP = """
import sys, time
t0 = time.perf_counter()
import numpy
t1 = time.perf_counter()
import motionrep
clip = motionrep.open(sys.argv[1])
t2 = time.perf_counter()
clip.pose(0.1)
t3 = time.perf_counter()
clip.poses([0.1, 0.2])
t4 = time.perf_counter()
print(t1 - t0, t2 - t1, t3 - t2, t4 - t3)
"""


def _start_up(data: bytes) -> dict:
    """Seconds of a fresh process to import motionrep and open a clip, then of its first pose and first batch
    (numba loading its cached machine code, or compiling it when its cache is empty), with the cache warm and
    with an empty one (``NUMBA_CACHE_DIR`` set to a new directory)."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "clip.mrc"
        path.write_bytes(data)
        runs = {}
        for label, cache in (("warm cache", None), ("empty cache", Path(tmp) / "numba")):
            env = dict(os.environ)
            if cache is not None:
                env["NUMBA_CACHE_DIR"] = str(cache)
            proc = subprocess.run([sys.executable, "-c", _START_UP, str(path)], capture_output=True, text=True,
                                  env=env, check=True)
            numpy_s, open_s, pose_s, batch_s = map(float, proc.stdout.split())
            runs[label] = {"import_numpy": numpy_s, "import_and_open": open_s, "first_pose": pose_s,
                           "first_batch": batch_s, "load": _load()}
    return runs


# ---------------------------------------------------------------------------------------------------------------
# driver
# ---------------------------------------------------------------------------------------------------------------
def _child(kind: str, *args: str) -> dict:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    proc = subprocess.run([sys.executable, __file__, "_" + kind, *args], capture_output=True, text=True, env=env)
    if proc.returncode != 0:
        raise SystemExit(f"{kind} {args} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def machine() -> dict:
    from motionrep.present.bench import machine_info

    return machine_info()


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] in ("_encode", "_profile"):
        fn = encode_one if argv[0] == "_encode" else profile_one
        print(json.dumps(fn(argv[1], argv[2])))
        return
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--clips", nargs="*", default=list(CLIPS))
    parser.add_argument("--bound", default="2%")
    parser.add_argument("--profile-clip", default="InverseKinematics/02_01")
    parser.add_argument("--decode-clip", default="bvh11/131_01")
    parser.add_argument("--decode-poses", type=int, default=200_000)
    parser.add_argument("--skip", nargs="*", default=[], choices=["encode", "profile", "decode"])
    parser.add_argument("--out", type=Path, default=RESULTS / "speed.json")
    args = parser.parse_args(argv)
    doc = json.loads(args.out.read_text()) if args.out.exists() else {}
    doc["machine"] = machine()
    if "decode" not in args.skip:
        print(f"decode {args.decode_clip} ({time.strftime('%H:%M:%S')}, load {_load()})", flush=True)
        before = doc.get("decode") or {}
        doc["decode"] = decode_speed(args.decode_clip, args.decode_poses)
        doc["decode"]["previous_run"] = _previous_run(before)
        _save(args.out, doc)
    if "profile" not in args.skip:
        print(f"profile {args.profile_clip} ({time.strftime('%H:%M:%S')}, load {_load()})", flush=True)
        doc["profile"] = _child("profile", args.profile_clip, args.bound)
        _save(args.out, doc)
    if "encode" not in args.skip:
        doc.setdefault("encode", {})
        for name in args.clips:
            print(f"encode {name} ({time.strftime('%H:%M:%S')}, load {_load()})", flush=True)
            doc["encode"][name] = _child("encode", name, args.bound)
            e = doc["encode"][name]
            print(f"  {e['frames']} frames: {e['seconds']:.1f} s, ok={e['ok']}, K={e.get('K')}, "
                  f"{len(e['stages'])} stages, load {e['load_start']}-{e['load_end']}", flush=True)
            _save(args.out, doc)
    (args.out.with_suffix(".md")).write_text(report(doc))
    print(f"wrote {args.out} and {args.out.with_suffix('.md')}")


def _save(path: Path, doc: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(doc, indent=1))
    tmp.replace(path)


def _codes(doc: dict) -> set[str]:
    found = {e.get("code") for e in doc.get("encode", {}).values()}
    found |= {doc.get(k, {}).get("code") for k in ("profile", "decode")}
    return {c for c in found if c}


def report(doc: dict) -> str:
    m = doc["machine"]
    md = [f"# Speed of adaptive-fourier ({m['date']})", "",
          f"Machine: {m['cpus']} CPUs ({m['cpu']}), Python {m['python']}, "
          + ", ".join(f"{k} {v}" for k, v in m["versions"].items() if v) + ". Code: "
          + ", ".join(sorted(_codes(doc))) + " (SHA-256 of the codec, representation and pipeline sources when "
          "each measurement ran, as in paper.md).", ""]
    enc = doc.get("encode", {})
    if enc:
        md += ["## Compression time per clip (adaptive-fourier, bound 2 %, each clip in a fresh process)", "",
               "| clip | frames | outcome | encode s | s to finish K = 10 | stages | L-BFGS iterations "
               "| s per iteration | checks | after last stage, s | RSS MB before encode, peak during it "
               "| load avg start-end |",
               "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
        for e in sorted(enc.values(), key=lambda e: e["frames"]):
            iters = sum(s["iterations"] or 0 for s in e["stages"])
            checks = sum(s["checks"] for s in e["stages"])
            outcome = (f"K={e['K']}, {e['error_percent']:.2f}%, ratio {e['paper_ratio']:.2f}" if e["ok"] else
                       f"failed (best {e['best_error_percent']:.2f}%)" if e.get("best_error_percent") else "failed")
            frames = f"{e['frames']} (-{e['dropped']})" if e.get("dropped") else str(e["frames"])
            k10 = [x["seconds"] for x in e["stages"] if isinstance(x["K"], int) and x["K"] <= 10]
            to10 = f"{sum(k10):.1f}" if any(x["K"] == 10 for x in e["stages"]) else "-"
            md.append(f"| {e['clip']} | {frames} | {outcome} | {e['seconds']:.1f} | {to10} | {len(e['stages'])} "
                      f"| {iters} "
                      f"| {1000 * sum(s['seconds'] for s in e['stages']) / max(iters, 1):.1f} ms | {checks} "
                      f"| {e['after_last_event']:.2f} | {e['rss_mb_before']:.0f}, {e['rss_mb_peak']:.0f} "
                      f"| {e['load_start']}-{e['load_end']} |")
        warm = [e["warm_up_seconds"] for e in enc.values()]
        md += ["", f"One-time cost per process, not included above: warming up the codec (imports), "
               f"{min(warm):.1f}-{max(warm):.1f} s.", ""]
        for e in sorted(enc.values(), key=lambda e: e["frames"]):
            md += [f"<details><summary>Stages of {e['clip']}</summary>", "",
                   "| K | seconds | iterations | checks | error after the stage, % |", "|---:|---:|---:|---:|---:|"]
            for s in e["stages"]:
                err = "-" if s["error_percent"] is None else f"{s['error_percent']:.2f}"
                md.append(f"| {s['K']} | {s['seconds']:.2f} | {s['iterations']} | {s['checks']} | {err} |")
            md += ["", "</details>", ""]
    prof = doc.get("profile")
    if prof:
        total = prof["cumulative"].get("compress_motion (everything)", prof["profiled_seconds"])
        md += [f"## Where the time goes ({prof['clip']}, {prof['frames']} frames, under cProfile: "
               f"{prof['profiled_seconds']:.1f} s, load {prof['load_start']}-{prof['load_end']})", "",
               "| part | cumulative s | share | calls |", "|---|---:|---:|---:|"]
        for label, _s, _f in _PROFILE_KEYS:
            if label in prof["cumulative"]:
                v = prof["cumulative"][label]
                md.append(f"| {label} | {v:.2f} | {100 * v / total:.0f} % | {prof['calls'][label]} |")
        md += ["", "Top functions by own time:", "", "| function | own s | calls |", "|---|---:|---:|"]
        md += [f"| {t['function']} | {t['self_seconds']:.2f} | {t['calls']} |" for t in prof["top_self"][:10]]
        md += ["", f"Memory: tracemalloc peak (numpy and Python allocations during one encode) "
               f"{prof['tracemalloc_peak_mb']:.1f} MB; process peak RSS {prof['rss_mb_peak']:.0f} MB (mostly torch).",
               ""]
    dec = doc.get("decode")
    if dec and "previous" in dec:
        md += _decode_report(dec)
    return "\n".join(md)


def _previous_run(before: dict) -> dict:
    """The figures of the last decode measurement (the one this run replaces), by ``codec/representation``."""
    rows = {f"{c['codec']}/{c['representation']}": {"poses_per_second": c["poses_per_second_float64"],
                                                    "one_pose_us": 1e6 * c["one_pose_seconds_median"]}
            for c in before.get("codecs", []) if "error" not in c}
    return {"code": before.get("code"), "load": [before.get("load_start"), before.get("load_end")], "rows": rows}


def _decode_report(dec: dict) -> list[str]:
    ok = [c for c in dec["codecs"] if "error" not in c]
    target_p, target_us = dec["targets"]["poses_per_second"], dec["targets"]["one_pose_us"]
    md = [f"## Decoding with the runtime decoder ({dec['clip']}, {dec['frames']} frames, {dec['joints']} joints; "
          f"{dec['poses']:,} random times, best of {dec['repeats']}; load {dec['load_start']}-{dec['load_end']})", "",
          "`clip = motionrep.open(data)`; batched: `clip.poses(times, out=...)` (codec, representation, fixed "
          "axes; rotations float64, the values the core measured, or float32); codec only: the prepared decoder "
          "in blocks of 512; one pose: `clip.pose(t)`, median and 90th percentile over 3000 random times. "
          "\"per CPU s\" divides by this thread's CPU time instead of the wall clock (the machine may be shared).",
          "",
          "| codec | representation | poses/s float64 (per CPU s) | poses/s float32 | features/s (codec only) "
          "| one pose median, p90 (CPU) | previous run: poses/s, one pose | target | met |",
          "|---|---|---:|---:|---:|---:|---:|---|---|"]
    previous = dec.get("previous_run", {}).get("rows", {})
    for c in ok:
        met = c["poses_per_second_float64"] >= target_p and 1e6 * c["one_pose_seconds_median"] <= target_us
        md.append(f"| {c['codec']} | {c['representation']} | {c['poses_per_second_float64']:,.0f} "
                  f"({c['poses_per_cpu_second_float64']:,.0f}) | {c['poses_per_second_float32']:,.0f} "
                  f"| {c['features_per_second']:,.0f} | {1e6 * c['one_pose_seconds_median']:.1f} us, "
                  f"{1e6 * c['one_pose_seconds_p90']:.1f} us ({1e6 * c.get('one_pose_cpu_seconds_median', 0):.1f} us) "
                  f"| {_previous_cell(previous.get(c['codec'] + '/' + c['representation']))} "
                  f"| >= {target_p:,} poses/s, <= {target_us:g} us "
                  f"| {'yes' if met else 'no'} |")
    for c in dec["codecs"]:
        if "error" in c:
            md.append(f"| {c['codec']} | {c['representation']} | failed: {c['error'][:80]} | | | | | | |")
    run = dec.get("previous_run", {})
    if run.get("rows"):
        md += ["", f"Previous run: code {run.get('code')}, load {run['load'][0]}-{run['load'][1]}."]
    md += ["", f"Before the runtime decoder (batched through `decompress`'s steps, one pose through them): "
           f"{dec['previous']['poses_per_second']} poses/s; one pose {dec['previous']['one_pose_us']} us.", ""]
    if "start_up" in dec:
        md += ["Start-up of a fresh process (import motionrep, open a clip; then its first pose and first batch, "
               "when numba loads its cached machine code or, with an empty cache, compiles it):", "",
               "| numba cache | import numpy | import motionrep + open | first pose | first batch | load |",
               "|---|---:|---:|---:|---:|---:|"]
        for label, r in dec["start_up"].items():
            md.append(f"| {label} | {r['import_numpy']:.2f} s | {r['import_and_open']:.2f} s | {r['first_pose']:.2f} s "
                      f"| {r['first_batch']:.2f} s | {r['load']} |")
        md.append("")
    return md


def _previous_cell(row: dict | None) -> str:
    return "-" if row is None else f"{row['poses_per_second']:,.0f}, {row['one_pose_us']:.1f} us"


if __name__ == "__main__":
    main()
