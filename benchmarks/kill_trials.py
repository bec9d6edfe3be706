"""Kill trials (issue 27): SIGKILL ``compress --jobs 2``, ``convert DIR db.h5`` and ``merge`` in the middle of
their work, then count what the kill left: worker processes still alive two seconds later (orphans), and
temporary files once the next run of the same command has started and finished.

    python benchmarks/kill_trials.py [--trials 10] [--json benchmarks/results/kill_trials.json]

Each trial runs the command on small synthetic clips in a fresh directory (``TMPDIR`` inside it, so the stdin
and staging folders are counted too), kills it with SIGKILL after a random delay once it has started working
(a worker process exists, or its temporary output appeared), waits two seconds, records the processes it had
started that are still alive, then runs the same command again to completion (every run has ``--force``) and counts the
temporary files left in the directory tree (``.<name>.<pid>.*.tmp*`` of ``atomic_path``, ``motionrep-*``
folders).  Linux only (``/proc``).
"""

from __future__ import annotations

import argparse
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _descendants(pid: int) -> list[int]:
    parents: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                parents[int(entry.name)] = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                pass
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        kids = [c for c, parent in parents.items() if parent == p]
        out += kids
        todo += kids
    return out


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _temporaries(root: Path) -> list[str]:
    found = []
    for p in root.rglob("*"):
        name = p.name
        if (name.startswith(".") and ".tmp" in name) or name.startswith("motionrep-"):
            found.append(str(p.relative_to(root)))
    return found


def _env(work: Path) -> dict[str, str]:
    path = os.pathsep.join([str(ROOT), str(ROOT / "plugins"), os.environ.get("PYTHONPATH", "")])
    return dict(os.environ, TMPDIR=str(work / "tmp"), PYTHONPATH=path)


def _prepare(work: Path) -> None:
    sys.path[:0] = [str(ROOT), str(ROOT / "plugins")]
    import motionrep
    from motionrep.model.synthetic import synthetic_motion

    (work / "clips").mkdir(parents=True)
    for i in range(16):
        motionrep.write(synthetic_motion(frames=400, seed=i), work / "clips" / f"c{i:02d}.bvh")
    for half, names in (("a", range(0, 8)), ("b", range(8, 16))):
        (work / half).mkdir()
        for i in names:
            (work / half / f"c{i:02d}.bvh").symlink_to(work / "clips" / f"c{i:02d}.bvh")
        subprocess.run([sys.executable, "-m", "motionrep", "compress", str(work / half), "-o",
                        str(work / f"{half}.h5")], check=True, env=_env(work), capture_output=True)


COMMANDS = {
    "compress --jobs 2": ["compress", "clips", "-o", "out.h5", "--jobs", "2", "--force"],
    "convert DIR db.h5": ["convert", "clips", "db.h5", "--force"],
    "merge": ["merge", "a.h5", "b.h5", "-o", "merged.h5", "--force"],
}


def _trial(work: Path, args: list[str], rng: random.Random) -> dict:
    env = _env(work)
    cmd = [sys.executable, "-m", "motionrep", *args]
    proc = subprocess.Popen(cmd, cwd=work, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    started = time.monotonic()
    seen: set[int] = set()
    delay = rng.uniform(0.2, 2.0)
    while time.monotonic() - started < 60 and proc.poll() is None:
        seen.update(_descendants(proc.pid))
        working = bool(seen) or bool(_temporaries(work))
        if working and time.monotonic() - started > delay:
            break
        time.sleep(0.02)
    seen.update(_descendants(proc.pid))
    killed = proc.poll() is None
    if killed:
        os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    left_after_kill = _temporaries(work)
    time.sleep(2.0)
    orphans = [p for p in seen if _alive(p)]
    for p in orphans:  # ours: end them so the next trial starts clean (counted above)
        try:
            os.kill(p, signal.SIGKILL)
        except OSError:
            pass
    again = subprocess.run(cmd, cwd=work, env=env, capture_output=True, timeout=600)
    left = _temporaries(work)
    return {"killed_mid_run": killed, "trial_seconds": round(time.monotonic() - started, 2),
            "processes_started": len(seen), "orphans": len(orphans), "temporaries_after_kill": len(left_after_kill),
            "next_run_exit": again.returncode, "temporaries_after_next_run": len(left), "left": left[:5]}


def main(argv: list[str] | None = None) -> int:
    if not sys.platform.startswith("linux"):
        print("kill trials need Linux (/proc)", file=sys.stderr)
        return 2
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--trials", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    rng = random.Random(args.seed)
    report: dict = {}
    with tempfile.TemporaryDirectory(prefix="kill-trials-") as tmp:
        work = Path(tmp)
        (work / "tmp").mkdir()
        _prepare(work)
        for name, command in COMMANDS.items():
            trials = [_trial(work, command, rng) for _ in range(args.trials)]
            report[name] = {
                "trials": len(trials), "killed_mid_run": sum(t["killed_mid_run"] for t in trials),
                "orphans": sum(t["orphans"] for t in trials),
                "trials_with_temporaries_after_kill": sum(bool(t["temporaries_after_kill"]) for t in trials),
                "temporaries_after_next_run": sum(t["temporaries_after_next_run"] for t in trials),
                "next_run_failures": sum(t["next_run_exit"] != 0 for t in trials), "detail": trials}
            summary = {k: v for k, v in report[name].items() if k != "detail"}
            print(name, json.dumps(summary), flush=True)
    if args.json is not None:
        args.json.write_text(json.dumps(report, indent=2) + "\n")
    bad = sum(r["orphans"] + r["temporaries_after_next_run"] for r in report.values())
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
