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
3. ``decode``: a clip compressed with ``transform`` and ``svd`` at 2 % and ``adaptive-fourier`` (K = 10, as in
   the paper), in every representation, each file decoded in fresh processes by this checkout and by another
   one's interpreter (``--against``, default main's venv: its numba decoders), alternately in the same run:
   preparing the decoder, the runtime decoder (``motionrep.open``) at 100,000 random times (best of 3; float64
   and float32 rotations), the codec alone, the median time of one pose, whether numba was imported, beside
   issue 24's targets; and the whole-process ``motionrep decompress x.mrc -o x.bvh``.

Results: ``benchmarks/results/speed.json`` and ``benchmarks/results/speed.md``; the 1-minute load average is
recorded with every measurement (the machine is shared).

Usage::

    python benchmarks/speed.py [--clips NAME ...] [--profile-clip NAME] [--decode-poses 100000] [--skip decode ...]
        [--against /path/to/other/.venv/bin/python] [--decode-codecs transform svd] [--decode-representations ...]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
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
# 3. decode throughput, side by side with another checkout (its own interpreter) in the same run
# ---------------------------------------------------------------------------------------------------------------
#: Issue 24's targets (transform and svd, the default representation): batched runtime decode, one pose from
#: Python, preparing a transform clip.
DECODE_TARGETS = {"poses_per_second": 5_000_000, "one_pose_us": 2.0, "prepare_frames_per_second": 1_000_000}
#: The checkout decoding is compared with: main's virtual environment (numba decoders), when it is there.
AGAINST = REPO.parent.parent / "main" / ".venv" / "bin" / "python"
#: Codecs of the decode measurement: (name, compress options).
DECODE_CODECS = (("transform", {"max_error": "2%"}),
                 ("svd", {"max_error": "2%"}),
                 # K = 10 as in the paper; decoding costs the same however long it trained (100 iterations a stage)
                 ("adaptive-fourier", {"max_error": None, "params": {"k": 10, "iters": 100}}))
DECODE_REPRESENTATIONS = ("root-quat-axis-angle", "euler", "ortho6d", "dual-quaternion")
#: Rounds of the side-by-side measurement: each checkout measures each file once per round, alternately; the
#: best of its rounds is kept.
ROUNDS = 2


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


def decode_file(path: str, poses: int) -> dict:
    """One ``.mrc`` file decoded by the checkout this interpreter imports (this function uses only what main and
    this branch both offer): preparing the codec's decoder, batched ``clip.poses(times, out=...)`` at ``poses``
    random times (float64 and float32 rotations), the codec alone in blocks of 512, one ``clip.pose(t)``; and
    whether numba was imported."""
    import numpy as np

    import motionrep
    from motionrep.io.container import unpack
    from motionrep.plugin.codec import Payload
    from motionrep.plugin.registry import get_codec
    from motionrep.plugin.representation import empty_poses

    data = Path(path).read_bytes()
    container = unpack(data)
    codec = get_codec(container.codec)
    payload = Payload(arrays=container.arrays, info=container.info, version=container.codec_version)
    codec.decoder(payload)  # numba's cached code loaded, if any
    out = {"frames": int(container.num_frames), "load_start": _load()}
    out["prepare_seconds"], out["prepare_cpu_seconds"] = _cpu_best(lambda: codec.decoder(payload), 20)
    clip = motionrep.open(data)
    rng = np.random.default_rng(0)
    times = rng.random(poses) * clip.duration
    for dtype in (np.float64, np.float32):
        buffer = empty_poses(clip.skeleton, poses, dtype)
        clip.poses(times, out=buffer)  # pages touched, kernels loaded
        wall, cpu = _cpu_best(lambda: clip.poses(times, out=buffer), REPEATS)
        out[f"poses_per_second_{np.dtype(dtype).name}"] = poses / wall
        out[f"poses_per_cpu_second_{np.dtype(dtype).name}"] = poses / cpu
    u = clip.normalized_times(times)
    decoder = clip._decoder
    kernel = getattr(decoder, "kernel", None)
    kernel = getattr(kernel, "dispatcher", kernel)  # a numba kernel: its dispatcher, as main's motionrep.open calls it
    features = np.empty((decoder.width, 512))  # feature-major, as motionrep.open decodes a block

    def codec_only():
        for a in range(0, poses, 512):
            if kernel is not None:
                kernel(u[a:a + 512], features, *decoder.kernel_args)
            else:
                decoder(u[a:a + 512])

    wall, cpu = _cpu_best(codec_only, REPEATS)
    out["features_per_second"], out["features_per_cpu_second"] = poses / wall, poses / cpu
    single, single_cpu = [], []
    for t in rng.random(5000) * clip.duration:
        w, c = time.perf_counter(), time.thread_time()
        clip.pose(t)
        single.append(time.perf_counter() - w)
        single_cpu.append(time.thread_time() - c)
    out["one_pose_seconds_median"] = statistics.median(single)
    out["one_pose_seconds_p90"] = sorted(single)[int(0.9 * len(single))]
    out["one_pose_cpu_seconds_median"] = statistics.median(single_cpu)
    many = (rng.random(5000) * clip.duration).tolist()

    def one_at_a_time():
        for t in many:
            clip.pose(t)

    wall, cpu = _cpu_best(one_at_a_time, 9)  # a loop: no timer call per pose
    out["one_pose_seconds_loop"], out["one_pose_cpu_seconds_loop"] = wall / len(many), cpu / len(many)
    out["numba_imported"] = "numba" in sys.modules
    out["load_end"] = _load()
    return out


def _measure(python: str, path: Path, poses: int) -> dict:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    proc = subprocess.run([python, __file__, "_decodefile", str(path), str(poses)], capture_output=True, text=True,
                          env=env, cwd=tempfile.gettempdir())
    if proc.returncode != 0:
        raise SystemExit(f"{python} decode {path.name} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _best_of(runs: list[dict]) -> dict:
    """Each figure's best over the rounds (highest rate, lowest time)."""
    best = dict(runs[0])
    for r in runs[1:]:
        for k, v in r.items():
            if isinstance(v, float) and k not in ("load_start", "load_end"):
                best[k] = min(best[k], v) if "seconds" in k else max(best[k], v)
    best["load_start"], best["load_end"] = runs[0]["load_start"], runs[-1]["load_end"]
    return best


_DECOMPRESS = [sys.executable, "-m", "motionrep", "decompress"]


def _whole_process(python: str, mrc: Path, repeats: int = 5) -> dict:
    """Median wall and CPU seconds of ``motionrep decompress x.mrc -o x.bvh`` (a fresh process each time)."""
    import resource

    walls, cpus = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeats + 1):
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            w = time.perf_counter()
            subprocess.run([python, "-m", "motionrep", "decompress", str(mrc), "-o", str(Path(tmp) / "x.bvh"),
                            "--force"], check=True, capture_output=True, cwd=tmp)
            walls.append(time.perf_counter() - w)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpus.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return {"seconds": statistics.median(walls[1:]), "cpu_seconds": statistics.median(cpus[1:]), "load": _load()}


def _transform_v1(container) -> bytes:
    """The ``.mrc`` bytes of a transform container with its payload as version 1 (the same integers; version 1 is
    read by both checkouts)."""
    import dataclasses

    import numpy as np

    from motionrep.io.container import pack
    from motionrep_transform import _stream, _stream2

    data = _stream.pack(_stream2.unpack(np.asarray(container.arrays["data"]).tobytes()))
    return pack(dataclasses.replace(container, arrays={"data": np.frombuffer(data, np.uint8)}, codec_version=1))


def decode_speed(name: str, poses: int, against: Path | None, codecs: list[str] | None = None,
                 representations: list[str] | None = None) -> dict:
    """Every codec x representation of one clip, encoded by this checkout, decoded by this checkout and by
    ``against`` (another checkout's interpreter, main's numba decoders), alternately in the same run: see
    :func:`decode_file`; and the whole-process ``decompress`` of the transform and svd files."""
    from motionrep.errors import MotionrepError
    from motionrep.pipeline.compress import compress_motion
    from motionrep.plugin.registry import get_codec

    get_codec("adaptive-fourier").warm_up()
    motion, _ = _read(name, True)
    sides = {"this": sys.executable}
    if against is not None:
        sides["against"] = str(against)
    out = {"clip": name, "code": _code(), "frames": motion.num_frames, "joints": motion.num_joints, "poses": poses,
           "repeats": REPEATS, "rounds": ROUNDS, "load_start": _load(), "codecs": [], "targets": DECODE_TARGETS,
           "against": str(against) if against else None, "whole_process": {}}
    with tempfile.TemporaryDirectory() as tmp:
        files = []
        for codec_name, options in DECODE_CODECS:
            for rep in DECODE_REPRESENTATIONS:
                if (codecs is not None and codec_name not in codecs) or (representations is not None
                                                                         and rep not in representations):
                    continue
                entry = {"codec": codec_name, "representation": rep}
                try:
                    result = compress_motion(motion, codec_name, representation=rep, seed=0, **options)
                except MotionrepError as exc:
                    out["codecs"].append(dict(entry, error=str(exc)))
                    continue
                path = Path(tmp) / f"{codec_name}-{rep}.mrc"
                path.write_bytes(result.data)
                files.append((entry, path, len(result.data)))
                if codec_name == "transform" and rep == DECODE_REPRESENTATIONS[0]:  # the same integers, payload v1
                    v1 = _transform_v1(result.container)
                    path = Path(tmp) / f"{codec_name}-{rep}-v1.mrc"
                    path.write_bytes(v1)
                    files.append(({"codec": "transform (payload v1)", "representation": rep}, path, len(v1)))
        for entry, path, size in files:
            runs = {side: [] for side in sides}
            for _ in range(ROUNDS):
                for side, python in sides.items():
                    runs[side].append(_measure(python, path, poses))
            entry.update(bytes=size, **{side: _best_of(r) for side, r in runs.items()})
            out["codecs"].append(entry)
            this = entry["this"]
            print(f"  {entry['codec']} / {entry['representation']}: {this['poses_per_second_float64']:,.0f} poses/s, "
                  f"one pose {1e6 * this['one_pose_seconds_loop']:.2f} us"
                  + (f" (against: {entry['against']['poses_per_second_float64']:,.0f}, "
                     f"{1e6 * entry['against']['one_pose_seconds_loop']:.2f} us)" if "against" in entry else "")
                  + f", load {this['load_end']}", flush=True)
            if entry["representation"] == DECODE_REPRESENTATIONS[0] and entry["codec"] in ("transform", "svd"):
                out["whole_process"][entry["codec"]] = {side: _whole_process(python, path) for side, python in
                                                        sides.items()}
    out["load_end"] = _load()
    return out


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
    if argv and argv[0] == "_decodefile":
        print(json.dumps(decode_file(argv[1], int(argv[2]))))
        return
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--clips", nargs="*", default=list(CLIPS))
    parser.add_argument("--bound", default="2%")
    parser.add_argument("--profile-clip", default="InverseKinematics/02_01")
    parser.add_argument("--decode-clip", default="bvh11/131_01")
    parser.add_argument("--decode-poses", type=int, default=100_000)
    parser.add_argument("--decode-codecs", nargs="*", default=[c for c, _ in DECODE_CODECS])
    parser.add_argument("--decode-representations", nargs="*", default=list(DECODE_REPRESENTATIONS))
    parser.add_argument("--against", type=Path, default=AGAINST if AGAINST.exists() else None,
                        help="the interpreter of the checkout decoding is compared with (default: main's venv)")
    parser.add_argument("--skip", nargs="*", default=[], choices=["encode", "profile", "decode"])
    parser.add_argument("--out", type=Path, default=RESULTS / "speed.json")
    args = parser.parse_args(argv)
    doc = json.loads(args.out.read_text()) if args.out.exists() else {}
    doc["machine"] = machine()
    if "decode" not in args.skip:
        print(f"decode {args.decode_clip} ({time.strftime('%H:%M:%S')}, load {_load()})", flush=True)
        measured = decode_speed(args.decode_clip, args.decode_poses, args.against, args.decode_codecs,
                                args.decode_representations)
        doc["decode"] = _merged_decode(doc.get("decode"), measured, args.decode_codecs, args.decode_clip)
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


def _merged_decode(old: dict | None, new: dict, codecs: list[str], clip: str) -> dict:
    """The decode section of a run of some codecs (``--decode-codecs``) with the other codecs' rows of the earlier
    run on the same clip kept (and said to be kept, with that run's load and code), so that measuring one codec
    again does not drop the others from the report."""
    if not old or old.get("clip") != clip:
        return new
    base = lambda e: e["codec"].split(" (")[0]  # noqa: E731 ("transform (payload v1)" is transform's)
    kept = [e for e in old.get("codecs", []) if base(e) not in codecs]
    if not kept:
        return new
    order = [c for c, _ in DECODE_CODECS]
    out = dict(new)
    out["codecs"] = sorted(kept + new["codecs"], key=lambda e: order.index(base(e)) if base(e) in order else 99)
    out["whole_process"] = {**{k: v for k, v in old.get("whole_process", {}).items() if k not in codecs},
                            **new.get("whole_process", {})}
    earlier = old.get("kept_from_earlier", {"load_start": old["load_start"], "load_end": old["load_end"],
                                           "code": old["code"]})
    out["kept_from_earlier"] = dict(earlier, codecs=sorted({base(e) for e in kept}))
    return out


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
    if dec and "rounds" in dec:
        md += _decode_report(dec)
    return "\n".join(md)


def _decode_report(dec: dict) -> list[str]:
    t = dec["targets"]
    against = dec.get("against")
    md = [f"## Decoding ({dec['clip']}, {dec['frames']} frames, {dec['joints']} joints; load "
          f"{dec['load_start']}-{dec['load_end']})", "",
          "Each file encoded once by this checkout, then decoded in fresh processes by this checkout (C decoders) "
          + (f"and by `{against}` (main's checkout: its C decoders since the compiled decoders were merged, numba's "
             "before; the last column says whether it imported numba), alternately, "
             f"{dec['rounds']} rounds each, the best kept"
             if against else "") + ". Batched: `clip.poses(times, out=...)` at "
          f"{dec['poses']:,} random times (codec, pose plan, fixed axes), best of {dec['repeats']}; \"CPU\" divides by "
          "the thread's CPU time instead of the wall clock (the machine is shared); one pose: `clip.pose(t)` in a loop "
          "over 5000 random times, the mean per pose (best of 9 loops), and the median of the same calls timed one "
          "by one (which adds the timer's own calls); prepare: `codec.decoder(payload)` (the integers' decoding and "
          "the inverse wavelet for transform), best of 20; codec only: the prepared decoder in blocks of 512.", "",
          "| codec | representation | poses/s float64 (CPU) | poses/s float32 | one pose: loop (median one by one) "
          "| prepare | features/s codec only | numba imported |", "|---|---|---:|---:|---:|---:|---:|---|"]
    if dec.get("kept_from_earlier"):
        k = dec["kept_from_earlier"]
        md[-2:-2] = [f"The rows of {', '.join(k['codecs'])} (and their whole-process times) are an earlier run's (load "
                     f"{k['load_start']}-{k['load_end']}, code {k['code']}), kept when only the other codecs were "
                     "measured again; the load above is this run's.", ""]

    def row(c: dict, side: str) -> str:
        r = c[side]
        frames_per_s = r["frames"] / r["prepare_seconds"]
        return (f"{r['poses_per_second_float64'] / 1e6:.2f} M ({r['poses_per_cpu_second_float64'] / 1e6:.2f} M) | "
                f"{r['poses_per_second_float32'] / 1e6:.2f} M | {1e6 * r['one_pose_seconds_loop']:.2f} us "
                f"({1e6 * r['one_pose_seconds_median']:.2f} us) | {1e3 * r['prepare_seconds']:.2f} ms "
                f"({frames_per_s / 1e6:.2f} M frames/s) | {r['features_per_second'] / 1e6:.2f} M "
                f"| {'yes' if r['numba_imported'] else 'no'} |")

    for c in dec["codecs"]:
        if "error" in c:
            md.append(f"| {c['codec']} | {c['representation']} | failed: {c['error'][:80]} | | | | | |")
            continue
        md.append(f"| {c['codec']} | {c['representation']} | " + row(c, "this"))
        if "against" in c:
            md.append(f"| ... main | | " + row(c, "against"))
    md += ["", f"Targets (issue 24; transform and svd, {DECODE_REPRESENTATIONS[0]}): batched >= "
           f"{t['poses_per_second'] / 1e6:g} M poses/s, one pose <= {t['one_pose_us']:g} us, preparing a transform "
           f"clip >= {t['prepare_frames_per_second'] / 1e6:g} M frames/s.", "",
           "| codec | batched, float64 | one pose | prepare | ratio to main (batched, one pose, prepare) |",
           "|---|---|---|---|---|"]
    for c in dec["codecs"]:
        if ("error" in c or c["representation"] != DECODE_REPRESENTATIONS[0]
                or c["codec"] not in ("transform", "transform (payload v1)", "svd")):
            continue
        r = c["this"]
        rate, one = r["poses_per_second_float64"], 1e6 * r["one_pose_seconds_loop"]
        prep = r["frames"] / r["prepare_seconds"]
        cells = [f"{rate / 1e6:.2f} M: {'met' if rate >= t['poses_per_second'] else 'NOT met'}",
                 f"{one:.2f} us: {'met' if one <= t['one_pose_us'] else 'NOT met'}",
                 (f"{prep / 1e6:.2f} M frames/s: {'met' if prep >= t['prepare_frames_per_second'] else 'NOT met'}"
                  if c["codec"].startswith("transform") else "-")]
        ratio = "-"
        if "against" in c:
            a = c["against"]
            ratio = (f"{rate / a['poses_per_second_float64']:.2f}x, "
                     f"{a['one_pose_seconds_loop'] / r['one_pose_seconds_loop']:.2f}x faster, "
                     f"{a['prepare_seconds'] / r['prepare_seconds']:.1f}x faster")
        md.append(f"| {c['codec']} | " + " | ".join(cells) + f" | {ratio} |")
    if dec.get("whole_process"):
        md += ["", "Whole process `motionrep decompress x.mrc -o x.bvh` (median of 5 after one warm-up; issue 24's "
               "target 0.5 s):", "", "| codec | this checkout | main | load |", "|---|---:|---:|---:|"]
        for codec, sides in dec["whole_process"].items():
            main = sides.get("against")
            md.append(f"| {codec} | {sides['this']['seconds']:.2f} s (CPU {sides['this']['cpu_seconds']:.2f} s) | "
                      + (f"{main['seconds']:.2f} s (CPU {main['cpu_seconds']:.2f} s)" if main else "-")
                      + f" | {sides['this']['load']} |")
    md.append("")
    return md


if __name__ == "__main__":
    main()
