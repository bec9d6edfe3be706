"""AMASS -> BVH speed: a 2-minute clip at 120 fps (14,400 frames, SMPL-H's 52 joints) posed through a synthetic
body model of SMPL-H's layout (tests/test_io_amass.py makes both), converted by `motionrep convert clip.npz
clip.bvh --body-model model.npz` (a whole process: start-up, reading, posing, writing); also the library's read
and the BVH write alone.  Target: the command under 2 s.  Wall-clock medians, with the machine's load.

Run: python benchmarks/amass.py [--repeats N]   (results: benchmarks/results/amass.txt)
"""

from __future__ import annotations

import argparse
import os
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


def median_seconds(run, repeats: int) -> float:
    run()  # warm-up (numba's cache, the page cache)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


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
        f"  motionrep convert (whole process): {cli:.2f} s   (target < 2 s: {'met' if cli < 2 else 'NOT met'})",
        f"  read(clip, body_model=)          : {reading:.3f} s",
        f"  write(motion, 'clip.bvh')        : {writing:.3f} s",
    ]
    print("\n".join(lines))
    (REPO / "benchmarks" / "results" / "amass.txt").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
