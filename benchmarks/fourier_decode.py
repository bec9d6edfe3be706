"""Decode speed of the Fourier codecs, this tree's decoder beside an earlier revision's, in one process.

Clips: real clips coded with ``adaptive-fourier`` and ``naive-fourier`` (K = 10 as in the paper, 100 iterations a
stage; decoding costs the same however long it trained), in windows as they are coded by default and as one
network (``window=0``), representation ``root-quat-axis-angle``.  For each, through the runtime decoder
(``motionrep.open``, ``clip.poses(times, out=...)``, rotations float64): poses per second at sequential times
(playback) and at random times, the codec's kernel alone (feature vectors per second, as ``motionrep.open`` calls
it, 512 times a call) and the median time of one ``clip.pose(t)``.  The "before" decoder is the Fourier kernel of
``--before`` (``plugins/motionrep_fourier/_network.py`` at that revision, loaded beside this tree's and given the
same prepared arrays), so both run side by side at the same load; the decoded features are checked to be the
same bits.  Best of ``--repeats`` runs, the two decoders measured alternately (the same load for both), wall
clock and thread CPU time; the machine's load is recorded.

    python benchmarks/fourier_decode.py [--before REV] [--clip bvh11/131_01] [--poses 200000]
"""

from __future__ import annotations

import argparse
import atexit
import importlib.util
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "benchmarks" / "results"
sys.path.insert(0, str(Path(__file__).resolve().parent))

from speed import _cpu_best as _best  # noqa: E402  (best wall and thread-CPU seconds of repeated runs)

#: (label, codec, params): windows as coded by default, and one network.
CLIPS = (("adaptive-fourier, windows", "adaptive-fourier", {"k": 10, "iters": 100}),
         ("naive-fourier, windows", "naive-fourier", {"k": 10, "iters": 100}),
         ("adaptive-fourier, one network", "adaptive-fourier", {"k": 10, "iters": 100, "window": 0}),
         ("naive-fourier, one network", "naive-fourier", {"k": 10, "iters": 100, "window": 0}))


def _load() -> float:
    return round(os.getloadavg()[0], 2)


def _kernel_at(rev: str):
    """The Fourier decoding kernel of revision ``rev`` (a LazyKernel), loaded as its own module."""
    source = subprocess.run(["git", "-C", str(REPO), "show", f"{rev}:plugins/motionrep_fourier/_network.py"],
                            capture_output=True, text=True, check=True).stdout
    folder = tempfile.mkdtemp()  # kept while the process runs: numba caches the compiled kernel beside it
    atexit.register(shutil.rmtree, folder, True)
    path = Path(folder) / "_network_before.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location("_network_before", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module._networks_kernel


def _use_kernel(clip, kernel) -> None:
    """Make ``clip`` (a ``motionrep.open`` clip of a Fourier payload) decode with ``kernel``."""
    clip._codec_kernel = kernel
    clip._kernels = None


def measure(clip, kernel, times: dict, repeats: int, rng) -> dict:
    from motionrep.plugin.representation import empty_poses

    _use_kernel(clip, kernel)
    d = clip._decoder
    out: dict = {}
    for label, t in times.items():
        buffer = empty_poses(clip.skeleton, t.size, np.float64)
        clip.poses(t, out=buffer)
        wall, cpu = _best(lambda: clip.poses(t, out=buffer), repeats)
        u = clip.normalized_times(t)
        X = np.empty((d.width, 512))
        dispatcher = getattr(kernel, "dispatcher", kernel)

        def codec_only():
            for a in range(0, u.size, 512):
                dispatcher(u[a:a + 512], X, *d.kernel_args)

        cwall, ccpu = _best(codec_only, repeats)
        out[label] = {"poses_per_second": t.size / wall, "poses_per_cpu_second": t.size / cpu,
                      "features_per_second": t.size / cwall, "features_per_cpu_second": t.size / ccpu}
    single = []
    for s in rng.random(3000) * clip.duration:
        a = time.perf_counter()
        clip.pose(s)
        single.append(time.perf_counter() - a)
    out["one_pose_us_median"] = 1e6 * statistics.median(single)
    return out


def _better(old: dict | None, new: dict) -> dict:
    """The best of two measurements: the higher rates, the lower one-pose time."""
    if old is None:
        return new
    best = {label: {key: max(old[label][key], new[label][key]) for key in new[label]}
            for label in new if isinstance(new[label], dict)}
    best["one_pose_us_median"] = min(old["one_pose_us_median"], new["one_pose_us_median"])
    return best


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", default="HEAD~1", help="git revision of the decoder to compare with")
    parser.add_argument("--clip", default="bvh11/131_01")
    parser.add_argument("--poses", type=int, default=200_000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--out", type=Path, default=RESULTS / "fourier_decode.json")
    args = parser.parse_args(argv)

    import motionrep
    from motionrep.present.bench import machine_info
    from motionrep.pipeline.compress import compress_motion
    from motionrep.plugin.registry import get_codec
    from speed import _read

    before_rev = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", args.before], capture_output=True,
                                text=True, check=True).stdout.strip()
    after_rev = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                               text=True, check=True).stdout.strip()
    before = _kernel_at(args.before)
    get_codec("adaptive-fourier").warm_up()
    motion, _ = _read(args.clip, True)
    doc = {"machine": machine_info(), "clip": args.clip, "frames": motion.num_frames, "joints": motion.num_joints,
           "poses": args.poses, "repeats": args.repeats, "before": before_rev, "after": after_rev,
           "load_start": _load(), "clips": []}
    rng = np.random.default_rng(0)
    for label, codec, params in CLIPS:
        result = compress_motion(motion, codec, representation="root-quat-axis-angle", seed=0, max_error=None,
                                 params=params)
        clip = motionrep.open(result.data)
        times = {"sequential": np.linspace(0.0, clip.duration, args.poses),
                 "random": rng.random(args.poses) * clip.duration}
        u = clip.normalized_times(times["random"])
        features = []
        for kernel in (before, clip._codec_kernel):
            X = np.empty((clip._decoder.width, u.size))
            getattr(kernel, "dispatcher", kernel)(u, X, *clip._decoder.kernel_args)
            features.append(X)
        after = clip._codec_kernel
        entry = {"label": label, "codec": codec, "windows": int(result.container.info.get("windows", 1)),
                 "K": result.container.info["K"], "hidden": result.container.info["hidden"],
                 "same_bits": bool(np.array_equal(features[0].view(np.int64), features[1].view(np.int64))),
                 "load_start": _load()}
        for _ in range(args.repeats):  # alternately, so that both see the same load; the best of each is kept
            for name, kernel in (("before", before), ("after", after)):
                entry[name] = _better(entry.get(name), measure(clip, kernel, times, 1, rng))
        entry["load_end"] = _load()
        doc["clips"].append(entry)
        b, a = entry["before"], entry["after"]
        print(f"{label} ({entry['windows']} windows), load {entry['load_start']}-{entry['load_end']}, same bits "
              f"{entry['same_bits']}: sequential {b['sequential']['poses_per_second'] / 1e3:.0f}k -> "
              f"{a['sequential']['poses_per_second'] / 1e3:.0f}k, random {b['random']['poses_per_second'] / 1e3:.0f}k"
              f" -> {a['random']['poses_per_second'] / 1e3:.0f}k poses/s; one pose {b['one_pose_us_median']:.1f} ->"
              f" {a['one_pose_us_median']:.1f} us", flush=True)
    doc["load_end"] = _load()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=1))
    args.out.with_suffix(".md").write_text(report(doc))
    print(f"wrote {args.out} and {args.out.with_suffix('.md')}")


def report(doc: dict) -> str:
    k = lambda v: f"{v / 1e3:,.0f}k" if v < 1e6 else f"{v / 1e6:.2f} M"  # noqa: E731
    md = [f"# Fourier decoding, before ({doc['before']}) and after ({doc['after']}) side by side "
          f"({doc['machine']['date']})", "",
          f"{doc['clip']}, {doc['frames']} frames, {doc['joints']} joints, root-quat-axis-angle, K = 10; "
          f"{doc['poses']:,} times, best of {doc['repeats']}; load {doc['load_start']}-{doc['load_end']} on "
          f"{doc['machine']['cpus']} CPUs (shared). Poses per wall-clock second (per CPU second) through "
          "`motionrep.open`; codec alone: the kernel's feature vectors per wall-clock second.", "",
          "| clip | times | poses/s before | poses/s after | codec alone before | codec alone after |",
          "|---|---|---:|---:|---:|---:|"]
    for e in doc["clips"]:
        b, a = e["before"], e["after"]
        for times in ("sequential", "random"):
            md.append(f"| {e['label']} ({e['windows']}) | {times} | {k(b[times]['poses_per_second'])} "
                      f"({k(b[times]['poses_per_cpu_second'])}) | {k(a[times]['poses_per_second'])} "
                      f"({k(a[times]['poses_per_cpu_second'])}) | {k(b[times]['features_per_second'])} | "
                      f"{k(a[times]['features_per_second'])} |")
    md += ["", "| clip | one pose before, us median | after | same bits |", "|---|---:|---:|---|"]
    for e in doc["clips"]:
        md.append(f"| {e['label']} | {e['before']['one_pose_us_median']:.1f} | {e['after']['one_pose_us_median']:.1f}"
                  f" | {e['same_bits']} |")
    return "\n".join(md) + "\n"


if __name__ == "__main__":
    main()
