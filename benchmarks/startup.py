"""Whole-process time of the command line (issue 24): `motionrep info`, `decompress` to BVH, `compress` and
`evaluate` of two BVH files on a 1000-1300-frame CMU clip of 31 joints (`cmu/bvh11/131_03.bvh`, 1102 frames,
when ../shared/data is there; else the shipped example clip, said in the results), warm caches, each also as a
ratio to `python -c "import numpy"` measured in the same run; `--help`, `info` of the shipped example clip as BVH
and `.mrc`, `import motionrep`, opening a clip with the runtime decoder and its first pose; and the first use on
a machine: the quick start's `motionrep compress walk.bvh` (the shipped demo clip, `motionrep example walk.bvh`)
with an empty numba cache (``NUMBA_CACHE_DIR`` set to a fresh directory for each run).

Medians of ``--repeats`` runs after one warm-up, wall-clock time and the CPU time (user + system) of the same
runs, which a loaded machine inflates less, with the load average (``os.getloadavg``) before and after.  With
``--base REV`` (default ``main``) the same commands also run on that revision's code (``git archive`` of its
``motionrep/`` and ``plugins/`` into a temporary directory, its compiled extensions built there from its own
sources, put first on ``PYTHONPATH``), interleaved run by
run with this checkout's, so both see the same load: the before / after of a change.

The package's Python files are byte-compiled first (`compileall`), as `pip install` does: with
PYTHONDONTWRITEBYTECODE set (this development machine sets it), an editable install would otherwise compile
motionrep's source in every process, which is not what a user's installation does.

Run: nice -n 10 python benchmarks/startup.py [--repeats N] [--cold-repeats N] [--base REV | --no-base]
Writes benchmarks/results/startup.json and startup.md.
"""

from __future__ import annotations

import argparse
import compileall
import json
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
RESULTS = REPO / "benchmarks" / "results"
#: a CMU clip of the issue's size (1000-1300 frames, 31 joints), if the shared data is there
REAL_CLIP = REPO.parent / "shared" / "data" / "cmu" / "bvh11" / "131_03.bvh"
#: issue 24's targets, whole process, warm caches (seconds)
TARGETS = {"info": 0.25, "decompress": 0.5, "compress": 0.8, "evaluate": 0.5, "first compress": 3.0}


def run_once(cmd: list[str], env: dict[str, str], said: list[str] | None = None) -> tuple[float, float]:
    """Wall-clock and CPU seconds (user + system of the child) of one run of ``cmd``; its stderr appended to
    ``said`` when given."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    # outside any checkout: `python -m` and `-c` put the working directory first on sys.path, which would import
    # the checkout's motionrep whatever PYTHONPATH says
    done = subprocess.run(cmd, capture_output=True, env=env, cwd=tempfile.gettempdir())
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed: {done.stderr.decode(errors='replace')[-500:]}")
    if said is not None:
        said.append(done.stderr.decode(errors="replace"))
    return wall, after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime


def code_env(code: Path | None) -> dict[str, str]:
    """The environment of a child running ``code``'s motionrep (None: this checkout)."""
    env = dict(os.environ)
    root = code if code is not None else REPO
    env["PYTHONPATH"] = os.pathsep.join([str(root), str(root / "plugins")])
    return env


def export_revision(rev: str, into: Path) -> Path | None:
    """``rev``'s motionrep and plugins in ``into``, with its compiled extensions built in place from its own
    sources (else this checkout's installed ones would be imported), or None when git cannot give them."""
    archive = subprocess.run(["git", "-C", str(REPO), "archive", rev, "motionrep", "plugins", "setup.py",
                              "pyproject.toml"], capture_output=True)
    if archive.returncode:
        print(f"--base {rev}: {archive.stderr.decode().strip()}; measuring this checkout only", file=sys.stderr)
        return None
    into.mkdir(parents=True)
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive.stdout, check=True)
    subprocess.run([sys.executable, "setup.py", "-q", "build_ext", "--inplace"], cwd=into, check=True,
                   capture_output=True)
    return into


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--cold-repeats", type=int, default=2, help="runs of the first compress (empty cache)")
    parser.add_argument("--base", default="main", help="the revision to measure beside this checkout")
    parser.add_argument("--no-base", action="store_true", help="measure this checkout only")
    parser.add_argument("--no-write", action="store_true", help="print only; do not write benchmarks/results")
    args = parser.parse_args()
    head = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True).stdout.strip()
    dirty = bool(subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "motionrep", "plugins"],
                                capture_output=True, text=True).stdout.strip())
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        trees: dict[str, Path | None] = {}
        if not args.no_base:
            base = export_revision(args.base, tmp / "base")
            if base is not None:
                trees[f"base ({args.base})"] = base
        trees[f"this ({head}{'+' if dirty else ''})"] = None
        for root in trees.values():
            top = root if root is not None else REPO
            for package in [top / "motionrep"] + sorted((top / "plugins").glob("motionrep_*")):
                compileall.compile_dir(str(package), quiet=1)
        this_env = code_env(None)
        mr = [sys.executable, "-m", "motionrep"]
        walk, walk_mrc = tmp / "walk.bvh", tmp / "walk.mrc"
        subprocess.run(mr + ["example", str(walk)], capture_output=True, check=True, env=this_env)
        subprocess.run(mr + ["compress", str(walk), "-o", str(walk_mrc)], capture_output=True, check=True,
                       env=this_env)
        walk_h5 = tmp / "walk.h5"
        subprocess.run(mr + ["convert", str(walk), str(walk_h5)], capture_output=True, check=True, env=this_env)
        clip = REAL_CLIP if REAL_CLIP.exists() else walk
        clip_mrc, clip_out, cand = tmp / "clip.mrc", tmp / "clip_out.bvh", tmp / "clip_cand.bvh"
        subprocess.run(mr + ["compress", str(clip), "-o", str(clip_mrc)], capture_output=True, check=True,
                       env=this_env)
        subprocess.run(mr + ["decompress", str(clip_mrc), "-o", str(cand)], capture_output=True, check=True,
                       env=this_env)
        label = clip.name
        rows = [
            ("python -c pass", "python", [sys.executable, "-c", "pass"]),
            ("python -c 'import numpy'", "numpy", [sys.executable, "-c", "import numpy"]),
            ("motionrep --help", None, mr + ["--help"]),
            (f"motionrep info {label}", "info", mr + ["info", str(clip)]),
            (f"motionrep decompress {label[:-4]}.mrc -o x.bvh", "decompress",
             mr + ["decompress", str(clip_mrc), "-o", str(clip_out), "--force"]),
            (f"motionrep compress {label} -o x.mrc", "compress",
             mr + ["compress", str(clip), "-o", str(tmp / "x.mrc"), "--force"]),
            (f"motionrep evaluate {label} decoded.bvh", "evaluate", mr + ["evaluate", str(clip), str(cand)]),
            ("motionrep info walk.bvh", None, mr + ["info", str(walk)]),
            ("motionrep info walk.mrc", None, mr + ["info", str(walk_mrc)]),
            ("motionrep info walk.h5", None, mr + ["info", str(walk_h5)]),
            ("python -c 'import motionrep'", None, [sys.executable, "-c", "import motionrep"]),
            ("motionrep.open(walk.mrc).pose(0.1)", None,
             [sys.executable, "-c", f"import motionrep; motionrep.open({str(walk_mrc)!r}).pose(0.1)"]),
        ]
        load_before = os.getloadavg()
        print(f"load average before: {load_before[0]:.2f} {load_before[1]:.2f} {load_before[2]:.2f} on "
              f"{os.cpu_count()} CPUs; medians of {args.repeats} runs; clip {clip}", flush=True)
        results: dict[str, dict] = {name: {} for name in trees}
        print(f"{'command':<52}" + "".join(f"{name[:24]:>26}" for name in trees))
        for title, key, cmd in rows:
            envs = {name: code_env(root) for name, root in trees.items()}
            for name in trees:  # warm-up (the numba cache of each tree is filled here)
                run_once(cmd, envs[name])
            runs: dict[str, list[tuple[float, float]]] = {name: [] for name in trees}
            for _ in range(args.repeats):
                for name in trees:
                    runs[name].append(run_once(cmd, envs[name]))
            cells = []
            for name in trees:
                wall = statistics.median(w for w, _ in runs[name])
                cpu = statistics.median(c for _, c in runs[name])
                results[name][title] = {"key": key, "wall": wall, "cpu": cpu, "walls": [w for w, _ in runs[name]]}
                cells.append(f"{wall:7.3f} s / {cpu:6.3f} CPU")
            print(f"{title:<52}" + "".join(f"{c:>26}" for c in cells), flush=True)
        cold_title = "first compress walk.bvh, empty numba cache"
        cold_runs: dict[str, list[tuple[float, float]]] = {name: [] for name in trees}
        cold_stderr: dict[str, list[str]] = {name: [] for name in trees}
        cold_cmd = mr + ["compress", str(walk), "-o", str(tmp / "cold.mrc"), "--force"]
        for i in range(args.cold_repeats):
            for t, (name, root) in enumerate(trees.items()):
                env = code_env(root)
                env["NUMBA_CACHE_DIR"] = str(tmp / f"numba-cold-{t}-{i}")  # fresh: nothing cached
                cold_runs[name].append(run_once(cold_cmd, env, cold_stderr[name]))
        for name in trees:
            results[name][cold_title] = {
                "key": "first compress", "wall": statistics.median(w for w, _ in cold_runs[name]),
                "cpu": statistics.median(c for _, c in cold_runs[name]), "walls": [w for w, _ in cold_runs[name]],
                "stderr": cold_stderr[name][-1]}
        print(f"{cold_title + f' ({args.cold_repeats} runs)':<52}" + "".join(
            f"{results[n][cold_title]['wall']:7.3f} s / {results[n][cold_title]['cpu']:6.3f} CPU" .rjust(26)
            for n in trees))
        load_after = os.getloadavg()
        print(f"load average after:  {load_after[0]:.2f} {load_after[1]:.2f} {load_after[2]:.2f}")
    for name in trees:
        numpy_wall = results[name]["python -c 'import numpy'"]["wall"]
        for row in results[name].values():
            row["x_numpy"] = row["wall"] / numpy_wall
            target = TARGETS.get(row["key"] or "")
            if target is not None:
                row["target"] = target
                row["met"] = row["wall"] <= target
    report = {
        "when": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "clip": str(clip.relative_to(REPO.parent))
        if clip == REAL_CLIP else "walk.bvh (shipped example; ../shared/data absent)",
        "load_before": load_before, "load_after": load_after, "cpus": os.cpu_count(), "repeats": args.repeats,
        "cold_repeats": args.cold_repeats, "code": list(trees), "results": results,
    }
    if not args.no_write:
        RESULTS.mkdir(exist_ok=True)
        (RESULTS / "startup.json").write_text(json.dumps(report, indent=1) + "\n")
        (RESULTS / "startup.md").write_text(markdown(report))
        print(f"wrote {RESULTS / 'startup.json'} and startup.md")


def markdown(report: dict) -> str:
    """The results as a Markdown table: one wall / CPU / x-numpy column group per code tree."""
    trees = report["code"]
    lb, la = report["load_before"], report["load_after"]
    lines = [
        "# Start-up: whole-process times (`benchmarks/startup.py`)", "",
        f"{report['when']}, clip `{report['clip']}`, {report['cpus']} CPUs, load average {lb[0]:.2f} / {lb[1]:.2f}"
        f" / {lb[2]:.2f} before and {la[0]:.2f} / {la[1]:.2f} / {la[2]:.2f} after (1 / 5 / 15 min); medians of "
        f"{report['repeats']} runs after a warm-up (the first compress: {report['cold_repeats']} runs, each with "
        "a fresh `NUMBA_CACHE_DIR`), the code trees interleaved run by run. `x numpy`: wall time over `python -c "
        "\"import numpy\"` in the same run. Target: issue 24's.", "",
        "| command | target | " + " | ".join(f"{t}: wall | CPU | x numpy" for t in trees) + " |",
        "|---|---:|" + "---:|---:|---:|" * len(trees),
    ]
    for title in report["results"][trees[0]]:
        cells = []
        target = None
        for t in trees:
            row = report["results"][t][title]
            target = row.get("target")
            mark = "" if "met" not in row else (" (met)" if row["met"] else " (not met)")
            cells.append(f"{row['wall']:.3f} s{mark} | {row['cpu']:.3f} s | {row['x_numpy']:.2f}")
        lines.append(f"| `{title}` | {'' if target is None else f'<= {target:g} s'} | " + " | ".join(cells) + " |")
    last = report["results"][trees[-1]]
    cold = next((r for r in last.values() if r["key"] == "first compress"), None)
    if cold is not None:
        said = [line for line in cold["stderr"].splitlines() if line.strip()]
        lines += ["", f"What the first compress printed on stderr ({trees[-1]}):", ""]
        lines += [f"    {line}" for line in said] or ["    (nothing)"]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
