"""Start-up time of the command line: `motionrep --help`, `motionrep info walk.bvh` and `motionrep info walk.mrc`
(target: under 0.3 s), and of `import motionrep` and opening a clip with the runtime decoder, beside
`python -c pass` and `python -c "import numpy"` measured in the same run, with the machine's load.

Run: python benchmarks/startup.py [--repeats N]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def wall(cmd: list[str], repeats: int) -> float:
    """Median wall-clock seconds of ``cmd`` over ``repeats`` runs (one warm-up run first)."""
    subprocess.run(cmd, capture_output=True, check=True)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        subprocess.run(cmd, capture_output=True, check=True)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=15)
    args = parser.parse_args()
    exe = shutil.which("motionrep") or sys.executable
    prefix = [exe] if exe.endswith("motionrep") else [sys.executable, "-m", "motionrep"]
    with tempfile.TemporaryDirectory() as tmp:
        walk = Path(tmp) / "walk.bvh"
        subprocess.run(prefix + ["example", str(walk)], capture_output=True, check=True)
        mrc = Path(tmp) / "walk.mrc"
        subprocess.run(prefix + ["compress", str(walk), "-o", str(mrc)], capture_output=True, check=True)
        rows = [
            ("python -c pass", [sys.executable, "-c", "pass"]),
            ("python -c 'import numpy'", [sys.executable, "-c", "import numpy"]),
            ("motionrep --help", prefix + ["--help"]),
            ("motionrep info walk.bvh", prefix + ["info", str(walk)]),
            ("motionrep info walk.mrc", prefix + ["info", str(mrc)]),
            ("python -c 'import motionrep'", [sys.executable, "-c", "import motionrep"]),
            ("motionrep.open(walk.mrc)", [sys.executable, "-c", f"import motionrep; motionrep.open({str(mrc)!r})"]),
            ("... and clip.pose(0.1)", [sys.executable, "-c",
                                        f"import motionrep; motionrep.open({str(mrc)!r}).pose(0.1)"]),
        ]
        load = os.getloadavg()
        print(f"load average before: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} CPUs")
        for name, cmd in rows:
            print(f"{name:<28} {wall(cmd, args.repeats):.3f} s (median of {args.repeats})")
        load = os.getloadavg()
        print(f"load average after:  {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")


if __name__ == "__main__":
    main()
