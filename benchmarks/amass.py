"""AMASS -> BVH speed: a 2-minute clip at 120 fps (14,400 frames, SMPL-H's 52 joints) posed through a synthetic
body model of SMPL-H's layout (tests/test_io_amass.py makes both), converted by `motionrep convert clip.npz
clip.bvh --body-model model.npz` (a whole process: start-up, reading, posing, writing); also the library's read
and the BVH write alone.  Target: the command under 2 s.  Wall-clock and CPU medians, with the machine's load (CPU time is less inflated by
a loaded machine).

Run: python benchmarks/amass.py [--repeats N]   (results: benchmarks/results/amass.txt)
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))

from test_io_amass import amass_clip, smplh_model  # noqa: E402  (the tests' synthetic clip and model)


def median_seconds(run, repeats: int) -> tuple[float, float]:
    """Median wall-clock and CPU seconds (this process's and its children's: user + system) of ``run()``."""
    run()  # warm-up (numba's cache, the page cache)
    walls, cpus = [], []
    for _ in range(repeats):
        before = _cpu()
        start = time.perf_counter()
        run()
        walls.append(time.perf_counter() - start)
        cpus.append(_cpu() - before)
    return statistics.median(walls), statistics.median(cpus)


def _cpu() -> float:
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    from motionrep.io import read, write

    with tempfile.TemporaryDirectory() as tmp:
        clip, model, out = Path(tmp, "clip.npz"), Path(tmp, "model.npz"), Path(tmp, "clip.bvh")
        np.savez(clip, **amass_clip(frames=120 * 120, seed=2))
        np.savez(model, **smplh_model())
        command = [sys.executable, "-m", "motionrep", "convert", str(clip), str(out), "--body-model", str(model),
                   "--force"]
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), str(REPO / "plugins"),
                                                          os.environ.get("PYTHONPATH", "")]))
        cli = median_seconds(lambda: subprocess.run(command, check=True, capture_output=True, env=env), args.repeats)
        motion = read(clip, body_model=model)
        reading = median_seconds(lambda: read(clip, body_model=model), args.repeats)
        writing = median_seconds(lambda: write(motion, out), args.repeats)
        load = os.getloadavg()[0]
    lines = [
        f"AMASS -> BVH, 14,400 frames x 52 joints (2 min at 120 fps), median of {args.repeats}, load {load:.1f}",
        "                                     wall       CPU",
        f"  motionrep convert (whole process): {cli[0]:7.2f} s {cli[1]:7.2f} s   (target < 2 s wall: "
        f"{'met' if cli[0] < 2 else 'NOT met'})",
        f"  read(clip, body_model=)          : {reading[0]:7.3f} s {reading[1]:7.3f} s",
        f"  write(motion, 'clip.bvh')        : {writing[0]:7.3f} s {writing[1]:7.3f} s",
    ]
    print("\n".join(lines))
    (REPO / "benchmarks" / "results" / "amass.txt").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
