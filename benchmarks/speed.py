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
3. ``decode``: a clip compressed with ``adaptive-fourier`` (K = 10, as in the paper) and with ``svd`` at 2 %,
   decoded at 200,000 random times in batches of 1024, 8192 and 65536 (best of 3): poses per second through the
   codec only (feature vectors) and
   through codec + representation (local joint rotations, a ``Motion``), the time of one pose at an arbitrary
   time, and the split of the batch time into its steps.

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
    from motionrep.plugins import get_codec

    get_codec("adaptive-fourier").warm_up()
    warm = time.perf_counter() - t
    from motionrep.compress import compress_motion
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
    for K in dict.fromkeys(f["K"] for _, f in events):
        mine = [(t, f) for t, f in events if f["K"] == K]
        end = mine[-1][0]
        checked = [f for _, f in mine if "error" in f]
        stages.append({"K": K, "seconds": end - prev, "iterations": mine[-1][1]["iteration"],
                       "checks": len(checked),
                       "error_percent": checked[-1]["error_percent"] if checked else None})
        prev = end
    return {"clip": name, "code": _code(), "frames": motion.num_frames, "dropped": dropped, "joints": motion.num_joints,
            "bound": bound, "seconds": total, "after_last_event": total - (prev - start), "stages": stages,
            "read_seconds": read_s, "warm_up_seconds": warm, "rss_mb_before": rss_before, "rss_mb_peak": _rss_mb(),
            "peak_reset": peak_reset,
            "load_start": load0, "load_end": _load(), **outcome}


def _height(motion) -> float:
    from motionrep.kinematics import character_height

    return character_height(motion.skeleton)


# ---------------------------------------------------------------------------------------------------------------
# 2. profile one clip (child process)
# ---------------------------------------------------------------------------------------------------------------
#: (label, file suffix, function name): cumulative times read from the profile.
_PROFILE_KEYS = [
    ("compress_motion (everything)", "motionrep/compress.py", "compress_motion"),
    ("codec encode", "_codecs.py", "encode"),
    ("L-BFGS run (training)", "_train.py", "run"),
    ("network loss and gradient (torch)", "_train.py", "loss_and_grad"),
    ("L-BFGS two-loop direction (numpy)", "_train.py", "_direction"),
    ("strong-Wolfe line search (scipy)", "_linesearch.py", "line_search_wolfe2"),
    ("line search", "_train.py", "_line_search"),
    ("shared evaluation of candidates", "motionrep/compress.py", "evaluate_payload"),
    ("  codec decode (numpy network)", "_network.py", "network_forward"),
    ("  representation from_features", "_rep.py", "from_features"),
    ("  evaluator (FK + L-inf)", "motionrep/evaluate.py", "__call__"),
    ("payload building", "_train.py", "payload_of"),
    ("frequency selection (PCA + DCT)", "_train.py", "next_adaptive_frequency"),
    ("network growth (warm start)", "_train.py", "_grow"),
    ("container pack", "motionrep/container.py", "pack"),
    ("container unpack", "motionrep/container.py", "unpack"),
]


def profile_one(name: str, bound: str, trim: bool = True) -> dict:
    import cProfile
    import pstats
    import tracemalloc

    from motionrep.plugins import get_codec

    get_codec("adaptive-fourier").warm_up()
    from motionrep.compress import compress_motion
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
def decode_speed(name: str, poses: int) -> dict:
    import numpy as np

    from motionrep.codec import Payload
    from motionrep.compress import compress_motion
    from motionrep.ops import fixed_axes_restored
    from motionrep.plugins import get_codec, get_representation

    get_codec("adaptive-fourier").warm_up()
    motion, _ = _read(name, True)
    out = {"clip": name, "code": _code(), "frames": motion.num_frames, "joints": motion.num_joints, "poses": poses,
           "codecs": []}
    rng = np.random.default_rng(0)
    times = rng.random(poses)
    for codec_name, kwargs in (("adaptive-fourier", {"max_error": None, "params": {"k": 10}}),
                               ("svd", {"max_error": "2%"})):
        result = compress_motion(motion, codec_name, seed=0, **kwargs)
        c = result.container
        codec, rep = get_codec(c.codec), get_representation(c.representation)
        payload = Payload(arrays=c.arrays, info=c.info)
        entry = {"codec": codec_name, "info": {k: v for k, v in c.info.items() if k != "omega"},
                 "parameters": c.num_parameters, "error_percent": result.report.max_error_percent,
                 "load_start": _load(), "batches": []}
        for batch in (1024, 8192, 65536):
            best_f = best_p = 0.0
            for _ in range(REPEATS):  # best of REPEATS: the machine is shared
                t0 = time.perf_counter()
                for i in range(0, poses, batch):
                    codec.decode(payload, times[i:i + batch])
                t1 = time.perf_counter()
                for i in range(0, poses, batch):
                    fixed_axes_restored(rep.from_features(codec.decode(payload, times[i:i + batch]), c.skeleton,
                                                          c.fps))
                t2 = time.perf_counter()
                best_f, best_p = max(best_f, poses / (t1 - t0)), max(best_p, poses / (t2 - t1))
            entry["batches"].append({"batch": batch, "poses": poses, "repeats": REPEATS,
                                     "features_per_second": best_f, "poses_per_second": best_p})
        single = []
        for t in rng.random(2000):
            s = time.perf_counter()
            fixed_axes_restored(rep.from_features(codec.decode(payload, np.array([t])), c.skeleton, c.fps))
            single.append(time.perf_counter() - s)
        single_codec = []
        for t in rng.random(2000):
            s = time.perf_counter()
            codec.decode(payload, np.array([t]))
            single_codec.append(time.perf_counter() - s)
        entry["one_pose_seconds_median"] = statistics.median(single)
        entry["one_pose_seconds_p90"] = sorted(single)[int(0.9 * len(single))]
        entry["one_features_seconds_median"] = statistics.median(single_codec)
        # where the batch time goes (8192 poses)
        t = times[:8192]
        steps: dict[str, float] = {}
        reps = 20
        if codec_name != "svd":
            from motionrep_fourier._network import elu, fourier_features

            a = {k: np.asarray(v, dtype=np.float64) for k, v in c.arrays.items()}
            s = time.perf_counter()
            for _ in range(reps):
                x = fourier_features(t, a["omega"])
            steps["Fourier features (sin, cos)"] = (time.perf_counter() - s) / reps
            s = time.perf_counter()
            for _ in range(reps):
                z0 = x @ a["W0"].T + a["b0"]
                z1 = elu(z0) @ a["W1"].T + a["b1"]
                y = elu(z1) @ a["W2"].T + a["b2"]
            steps["three layers incl. ELU"] = (time.perf_counter() - s) / reps
            s = time.perf_counter()
            for _ in range(reps):
                elu(z0)
                elu(z1)
            steps["  of which the two ELUs"] = (time.perf_counter() - s) / reps
        else:
            s = time.perf_counter()
            for _ in range(reps):
                y = codec.decode(payload, t)
            steps["svd decode"] = (time.perf_counter() - s) / reps
        s = time.perf_counter()
        for _ in range(reps):
            rep.from_features(y, c.skeleton, c.fps)
        steps["representation from_features"] = (time.perf_counter() - s) / reps
        entry["split_8192_seconds"] = steps
        # float32, what the stored weights already are: an upper bound on what a float32 decode path could do
        if codec_name != "svd":
            a32 = {k: np.asarray(v, dtype=np.float32) for k, v in c.arrays.items()}
            t32 = t.astype(np.float32)

            def f32(tt):
                ang = (2 * np.pi) * tt[:, None] * a32["omega"][None, :]
                x = np.empty((tt.size, 2 * ang.shape[1] + 1), np.float32)
                x[:, 0] = tt
                x[:, 1::2] = np.sin(ang)
                x[:, 2::2] = np.cos(ang)
                h = x @ a32["W0"].T
                h += a32["b0"]
                _elu_inplace(h)
                h2 = h @ a32["W1"].T
                h2 += a32["b1"]
                _elu_inplace(h2)
                out = h2 @ a32["W2"].T
                out += a32["b2"]
                return out

            y32 = f32(t32)
            s = time.perf_counter()
            for _ in range(reps):
                f32(t32)
            entry["float32_network_features_per_second"] = 8192 * reps / (time.perf_counter() - s)
            entry["float32_max_abs_difference"] = float(np.max(np.abs(y32 - codec.decode(payload, t))))
        entry["load_end"] = _load()
        out["codecs"].append(entry)
    return out


def _elu_inplace(h):
    import numpy as np

    neg = np.minimum(h, 0)
    np.expm1(neg, out=neg)
    np.maximum(h, 0, out=h)
    h += neg
    return h


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
    from motionrep.bench import machine_info

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
        doc["decode"] = decode_speed(args.decode_clip, args.decode_poses)
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
            iters = sum(s["iterations"] for s in e["stages"])
            checks = sum(s["checks"] for s in e["stages"])
            outcome = (f"K={e['K']}, {e['error_percent']:.2f}%, ratio {e['paper_ratio']:.2f}" if e["ok"] else
                       f"failed (best {e['best_error_percent']:.2f}%)" if e.get("best_error_percent") else "failed")
            frames = f"{e['frames']} (-{e['dropped']})" if e.get("dropped") else str(e["frames"])
            k10 = [x["seconds"] for x in e["stages"] if x["K"] <= 10]
            to10 = f"{sum(k10):.1f}" if any(x["K"] == 10 for x in e["stages"]) else "-"
            md.append(f"| {e['clip']} | {frames} | {outcome} | {e['seconds']:.1f} | {to10} | {len(e['stages'])} "
                      f"| {iters} "
                      f"| {1000 * sum(s['seconds'] for s in e['stages']) / max(iters, 1):.1f} ms | {checks} "
                      f"| {e['after_last_event']:.2f} | {e['rss_mb_before']:.0f}, {e['rss_mb_peak']:.0f} "
                      f"| {e['load_start']}-{e['load_end']} |")
        warm = [e["warm_up_seconds"] for e in enc.values()]
        md += ["", f"One-time cost per process, not included above: importing and warming up torch, "
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
    if dec:
        md += [f"## Decode throughput ({dec['clip']}, {dec['frames']} frames, {dec['joints']} joints; "
               f"{dec['poses']:,} random times, best of {REPEATS}, load {dec['codecs'][0]['load_start']}-"
               f"{dec['codecs'][-1]['load_end']})", "",
               "| codec | batch | feature vectors / s (codec only) | poses / s (codec + representation) |",
               "|---|---:|---:|---:|"]
        for c in dec["codecs"]:
            for b in c["batches"]:
                md.append(f"| {c['codec']} ({', '.join(f'{k}={v}' for k, v in c['info'].items())}) | {b['batch']} "
                          f"| {b['features_per_second']:,.0f} | {b['poses_per_second']:,.0f} |")
        md += ["", "| codec | one pose at an arbitrary time (median, p90) | one feature vector (median) |",
               "|---|---:|---:|"]
        for c in dec["codecs"]:
            md.append(f"| {c['codec']} | {1e6 * c['one_pose_seconds_median']:.0f} us, "
                      f"{1e6 * c['one_pose_seconds_p90']:.0f} us | {1e6 * c['one_features_seconds_median']:.0f} us |")
        md += ["", "Split of one batch of 8192 poses:", "", "| codec | step | ms |", "|---|---|---:|"]
        for c in dec["codecs"]:
            for k, v in c["split_8192_seconds"].items():
                md.append(f"| {c['codec']} | {k} | {1000 * v:.2f} |")
            if "float32_network_features_per_second" in c:
                md.append(f"| {c['codec']} | float32 network instead (max abs difference "
                          f"{c['float32_max_abs_difference']:.1e}): feature vectors / s | "
                          f"{c['float32_network_features_per_second']:,.0f} |")
        md.append("")
    return "\n".join(md)


if __name__ == "__main__":
    main()
