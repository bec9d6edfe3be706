"""Start-up time of the command line: `motionrep --help` and `motionrep info` on the shipped example clip as BVH,
NPZ, HDF5 and `.mrc`, and on a real CMU clip when ../shared/data is there (target: under 0.3 s), and of `import
motionrep` and opening a clip with the runtime decoder, beside `python -c pass` and `python -c "import numpy"`
measured in the same run, with the machine's load; wall-clock medians and the CPU time (user + system) of the same
runs, which a loaded machine inflates less.

The package's Python files are byte-compiled first (`compileall`), as `pip install` does: with
PYTHONDONTWRITEBYTECODE set (this development machine sets it), an editable install would otherwise compile
motionrep's source in every process, which is not what a user's installation does.

Run: python benchmarks/startup.py [--repeats N]
"""

from __future__ import annotations

import argparse
import compileall
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
#: a real clip of typical size (CMU 12_01 walk, 31 joints, 394 kB), if the shared data is there
REAL_CLIP = REPO.parent / "shared" / "data" / "cmu" / "pybvh" / "cmu_12_01_walk.bvh"


def timed(cmd: list[str], repeats: int) -> tuple[float, float]:
    """Median wall-clock seconds and median CPU seconds (user + system of the child) of ``cmd`` over ``repeats``
    runs (one warm-up run first)."""
    subprocess.run(cmd, capture_output=True, check=True)
    walls, cpus = [], []
    for _ in range(repeats):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        subprocess.run(cmd, capture_output=True, check=True)
        walls.append(time.perf_counter() - start)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return statistics.median(walls), statistics.median(cpus)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=15)
    args = parser.parse_args()
    for package in [REPO / "motionrep"] + sorted((REPO / "plugins").glob("motionrep_*")):
        compileall.compile_dir(str(package), quiet=1)
    exe = shutil.which("motionrep") or sys.executable
    prefix = [exe] if exe.endswith("motionrep") else [sys.executable, "-m", "motionrep"]
    with tempfile.TemporaryDirectory() as tmp:
        walk = Path(tmp) / "walk.bvh"
        subprocess.run(prefix + ["example", str(walk)], capture_output=True, check=True)
        mrc, npz, h5 = Path(tmp) / "walk.mrc", Path(tmp) / "walk.npz", Path(tmp) / "walk.h5"
        subprocess.run(prefix + ["compress", str(walk), "-o", str(mrc)], capture_output=True, check=True)
        subprocess.run(prefix + ["convert", str(walk), str(npz)], capture_output=True, check=True)
        subprocess.run(prefix + ["convert", str(walk), str(h5)], capture_output=True, check=True)
        rows = [
            ("python -c pass", [sys.executable, "-c", "pass"]),
            ("python -c 'import numpy'", [sys.executable, "-c", "import numpy"]),
            ("motionrep --help", prefix + ["--help"]),
            ("motionrep info walk.bvh", prefix + ["info", str(walk)]),
            ("motionrep info walk.npz", prefix + ["info", str(npz)]),
            ("motionrep info walk.h5", prefix + ["info", str(h5)]),
            ("motionrep info walk.mrc", prefix + ["info", str(mrc)]),
        ]
        if REAL_CLIP.exists():
            rows.append((f"motionrep info {REAL_CLIP.name}", prefix + ["info", str(REAL_CLIP)]))
        rows += [
            ("python -c 'import motionrep'", [sys.executable, "-c", "import motionrep"]),
            ("motionrep.open(walk.mrc)", [sys.executable, "-c", f"import motionrep; motionrep.open({str(mrc)!r})"]),
            ("... and clip.pose(0.1)", [sys.executable, "-c",
                                        f"import motionrep; motionrep.open({str(mrc)!r}).pose(0.1)"]),
        ]
        load = os.getloadavg()
        print(f"load average before: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} CPUs; "
              f"medians of {args.repeats} runs")
        print(f"{'command':<36} {'wall':>8} {'CPU':>8}")
        for name, cmd in rows:
            wall, cpu = timed(cmd, args.repeats)
            print(f"{name:<36} {wall:7.3f}s {cpu:7.3f}s")
        load = os.getloadavg()
        print(f"load average after:  {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")


if __name__ == "__main__":
    main()
