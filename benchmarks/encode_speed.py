"""The transform codec's encode in one process, beside base revisions, and the same payload bytes (issue 24:
"encode at ACL's speed", at most ACL's 0.15 s for a CMU-31 clip of about 1000-1250 frames at 2 %).

Usage::

    python benchmarks/encode_speed.py [--base REV ...] [--rounds 3] [--repeat 5] [--clip cmu/bvh11/131_01]
                                      [--frames A:B]

For this checkout and each ``--base`` revision (``git archive`` of its ``motionrep/`` and ``plugins/`` first on
``PYTHONPATH``, its compiled extensions built in place from its own sources by its ``setup.py``, so that a base
whose C differs runs its own; a base with numba kernels has them loaded by a warm-up), in child processes that alternate
``--rounds`` times so that all see the same load:

* **time**: ``compress_motion(motion, "transform", max_error="2%")`` of ``--clip``, the clip already in memory and
  the compiled code warm, best of ``--repeat``, wall clock and CPU time (user + system of the process: a loaded
  machine inflates it less); each figure is the best over the rounds;
* **bytes**: SHA-256 of the payload (its arrays and info) and the stored evaluation's L-inf error, for the eight
  CMU-31 clips at 2 %, 0.588 % and 0.0588 % (the bounds of ``benchmarks/acl.py``): they must be the same in every
  tree (a speed-up may not change what is coded);
* **where the time goes** (this checkout only): one encode under cProfile, grouped.

Writes nothing; prints the table.  ``MOTIONREP_SHARED_DATA`` as the other benchmarks.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DATA = Path(os.environ.get("MOTIONREP_SHARED_DATA", REPO.parent / "shared" / "data"))
BOUNDS = ("2%", "0.588%", "0.0588%")
#: ACL 2.1's time for the issue's clip (benchmarks/results/acl.md; issue 24)
ACL_SECONDS = 0.15


def cmu31() -> list[Path]:
    from motionrep.io import read

    return [p for p in sorted((DATA / "cmu").rglob("*.bvh")) if read(p).num_joints == 31]


def clip_motion(clip: str, frames: str | None):
    """The clip, or with ``frames`` ``A:B`` its frames ``A .. B - 1`` (a window of the issue's length, 1247 frames,
    out of a longer clip)."""
    from motionrep.io import read

    motion = read(DATA / f"{clip}.bvh")
    if frames:
        first, end = (int(v) for v in frames.split(":", 1))
        if not 0 <= first < end <= motion.num_frames:
            raise SystemExit(f"--frames {frames}: need 0 <= A < B <= {motion.num_frames} (the clip's frames)")
        motion = motion.frames(slice(first, end))
    return motion


def child(clip: str, repeat: int, into: Path, frames: str | None = None) -> None:
    from motionrep.io import read
    from motionrep.pipeline.compress import compress_motion

    motion = clip_motion(clip, frames)
    compress_motion(motion, "transform", max_error="2%")  # warm: compiled code loaded
    wall, cpu = [], []
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        compress_motion(motion, "transform", max_error="2%")
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    digests = {}
    for path in cmu31():
        m = read(path)
        for bound in BOUNDS:
            result = compress_motion(m, "transform", max_error=bound)
            h = hashlib.sha256()
            for name in sorted(result.container.arrays):
                h.update(name.encode() + result.container.arrays[name].tobytes())
            h.update(json.dumps(result.container.info, sort_keys=True).encode())
            digests[f"{path.relative_to(DATA).with_suffix('')} {bound}"] = (
                f"{h.hexdigest()[:16]} {result.report.max_error!r} {len(result.data)}")
    into.write_text(json.dumps({"wall": min(wall), "cpu": min(cpu), "frames": motion.num_frames,
                                "digests": digests}))


def profile(clip: str, frames: str | None = None) -> None:
    import cProfile
    import pstats

    from motionrep.pipeline.compress import compress_motion

    motion = clip_motion(clip, frames)
    compress_motion(motion, "transform", max_error="2%")
    pr = cProfile.Profile()
    pr.enable()
    compress_motion(motion, "transform", max_error="2%")
    pr.disable()
    stats = pstats.Stats(pr).stats
    total = sum(v[2] for v in stats.values())

    def cum(name: str) -> float:
        return sum(v[3] for (f, _, fn), v in stats.items() if fn == name.split(":")[1] and f.endswith(name.split(":")[0]))

    parts = {"the codec's encode (all)": cum("_codec.py:encode"),
             "  shared evaluation: frame_errors (decode, FK, distances)": cum("evaluate.py:frame_errors"),
             "  shared evaluation: feature_sensitivity": cum("evaluate.py:feature_sensitivity"),
             "  closed loop: the chain's targets (retargeting from the decoded parents)": cum("chain.py:targets"),
             "  closed loop: the chain's sensitivity": cum("chain.py:sensitivity"),
             "  FK (compiled)": sum(v[2] for (f, _, fn), v in stats.items() if fn == "<built-in method motionrep._ccore.fk>"),
             "pipeline: decompress the stored payload twice (measure, determinism)": cum("decode.py:decompress"),
             "pipeline: to_features": cum("_rep.py:to_features")}
    print(f"\nwhere one encode's {total:.3f} s go (cProfile, cumulative; this checkout):")
    for name, seconds in parts.items():
        print(f"  {name:72s} {seconds:6.3f} s  {100 * seconds / total:5.1f} %")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--base", nargs="*", default=["main"], help="revisions to measure beside this checkout")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--clip", default="cmu/bvh11/131_01")
    parser.add_argument("--frames", help="A:B, only the clip's frames A .. B - 1 (say 600:1847 of "
                                         "cmu/fairmotion/01_01: 1247 frames, the issue's length)")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    parser.add_argument("--profile", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.frames and not args.child and not args.profile:
        try:
            clip_motion(args.clip, args.frames)
        except ValueError:
            parser.error(f"--frames {args.frames}: give A:B, two whole numbers")
    if args.child:
        child(args.clip, args.repeat, Path(args.child), args.frames)
        return 0
    if args.profile:
        profile(args.clip, args.frames)
        return 0
    head = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True).stdout.strip()
    load = os.getloadavg()
    window = f" frames {args.frames}" if args.frames else ""
    print(f"transform encode of {args.clip}{window} at 2 %, best of {args.repeat} over {args.rounds} alternating rounds; "
          f"load {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} ({os.cpu_count()} CPUs)")
    results: dict[str, list[dict]] = {}
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        trees: dict[str, Path] = {}
        for rev in args.base:
            archive = subprocess.run(["git", "-C", str(REPO), "archive", rev, "motionrep", "plugins", "setup.py",
                                      "pyproject.toml"], capture_output=True, check=True)
            (tmp / rev).mkdir()
            subprocess.run(["tar", "-x", "-C", str(tmp / rev)], input=archive.stdout, check=True)
            # the base's own compiled core (else the installed one of this checkout would be imported)
            subprocess.run([sys.executable, "setup.py", "-q", "build_ext", "--inplace"], cwd=tmp / rev, check=True,
                           capture_output=True)
            trees[f"base {rev}"] = tmp / rev
        trees[f"this {head}"] = REPO
        for r in range(args.rounds):
            for name, root in trees.items():
                env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(root), str(root / "plugins")]))
                out = tmp / f"{r}-{len(results.get(name, []))}.json"
                subprocess.run([sys.executable, str(Path(__file__).resolve()), "--child", str(out), "--clip",
                                args.clip, "--repeat", str(args.repeat)]
                               + (["--frames", args.frames] if args.frames else []), check=True, env=env,
                               cwd=tempfile.gettempdir())
                results.setdefault(name, []).append(json.loads(out.read_text()))
    names = list(results)
    print(f"\n{'tree':24s} {'wall s':>8s} {'CPU s':>8s} {'wall / ACL 0.15 s':>18s}")
    for name in names:
        wall = min(r["wall"] for r in results[name])
        cpu = min(r["cpu"] for r in results[name])
        print(f"{name:24s} {wall:8.3f} {cpu:8.3f} {wall / ACL_SECONDS:18.2f}")
    reference = results[names[0]][0]["digests"]
    same = all(r["digests"] == reference for rs in results.values() for r in rs)
    print(f"\npayload bytes, stored L-inf error and file size of the 8 CMU-31 clips at {', '.join(BOUNDS)}: "
          + ("identical in every tree and round" if same else "DIFFERENT"))
    if not same:
        for key in reference:
            values = {n: results[n][0]["digests"].get(key) for n in names}
            if len(set(values.values())) > 1:
                print(f"  {key}: {values}")
    load = os.getloadavg()
    print(f"load at the end {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    subprocess.run([sys.executable, str(Path(__file__).resolve()), "--profile", "--clip", args.clip]
                   + (["--frames", args.frames] if args.frames else []), check=True,
                   env=dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), str(REPO / "plugins")])),
                   cwd=tempfile.gettempdir())
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
