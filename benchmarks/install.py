"""What a user gets from `pip install .` (issue 24): the size of a fresh virtual environment, by distribution, and
the quick start's first `motionrep compress walk.bvh` in it (a fresh install: no numba cache, no byte-code beyond
what pip wrote, nothing warmed up), then the same command again.

Each tree (this checkout, and with ``--base REV`` that revision, default ``main``) is exported with ``git archive``
(this checkout: its committed HEAD plus nothing else, so commit first), installed with ``pip install DIR`` (not
editable: what a user of a release gets) into its own new venv under a temporary directory, and measured there.
Sizes are the bytes of the files under the venv's ``site-packages`` (``du``-like, apparent sizes), per
distribution from pip's RECORD files; the install time includes building motionrep's C extensions.

Run: nice -n 10 python benchmarks/install.py [--base REV | --no-base] [--repeats N]
Writes benchmarks/results/install.json and install.md.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
RESULTS = REPO / "benchmarks" / "results"
TARGET_FIRST_COMPRESS = 3.0  # seconds, issue 24
BEFORE_MB = 575  # the figure for a fresh venv before the compiled core


def _run(cmd: list[str], **kw) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, capture_output=True, text=True, **kw)


def _export(rev: str, into: Path) -> str:
    """``git archive`` of ``rev`` into ``into``; returns the commit's short hash."""
    into.mkdir(parents=True)
    commit = _run(["git", "-C", str(REPO), "rev-parse", "--short=12", rev], check=True).stdout.strip()
    archive = subprocess.Popen(["git", "-C", str(REPO), "archive", commit], stdout=subprocess.PIPE)
    subprocess.run(["tar", "-x", "-C", str(into)], stdin=archive.stdout, check=True)
    archive.wait()
    return commit


def _site_packages(venv: Path) -> Path:
    return next((venv / "lib").glob("python*/site-packages"))


def _sizes(site: Path) -> dict[str, int]:
    """Bytes per installed distribution (its RECORD's files), plus what no RECORD names (``(other)``)."""
    per: dict[str, int] = {}
    claimed: set[Path] = set()
    for record in site.glob("*.dist-info/RECORD"):
        name = record.parent.name.split("-")[0]
        total = 0
        with open(record, newline="") as f:
            for row in csv.reader(f):
                if not row:
                    continue
                path = (site / row[0]).resolve()
                if path.is_file() and path not in claimed:
                    claimed.add(path)
                    total += path.stat().st_size
        per[name] = total
    other = sum(p.stat().st_size for p in site.rglob("*") if p.is_file() and p.resolve() not in claimed)
    per["(other)"] = other
    return per


def _venv_bytes(venv: Path) -> int:
    return sum(p.stat().st_size for p in venv.rglob("*") if p.is_file() and not p.is_symlink())


def _measure(label: str, rev: str, work: Path, repeats: int) -> dict:
    tree = work / f"{label}-src"
    commit = _export(rev, tree)
    venv = work / f"{label}-venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    python = venv / "bin" / "python"
    env = dict(os.environ, PIP_DISABLE_PIP_VERSION_CHECK="1")
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # a user's pip writes byte-code
    env.pop("NUMBA_CACHE_DIR", None)
    env.pop("PYTHONPATH", None)
    t0 = time.perf_counter()
    done = _run([str(python), "-m", "pip", "install", "-q", str(tree)], env=env)
    install_s = time.perf_counter() - t0
    if done.returncode:
        raise SystemExit(f"pip install of {label} failed:\n{done.stderr[-2000:]}")
    sizes = _sizes(_site_packages(venv))
    runs = []
    scratch = work / f"{label}-scratch"
    scratch.mkdir()
    motionrep = str(venv / "bin" / "motionrep")
    _run([motionrep, "example", "walk.bvh"], cwd=scratch, env=env, check=True)
    stderr_first = ""
    for i in range(repeats + 1):
        out = scratch / f"walk{i}.mrc"
        t0 = time.perf_counter()
        done = _run([motionrep, "compress", "walk.bvh", "-o", out.name], cwd=scratch, env=env)
        runs.append(time.perf_counter() - t0)
        if done.returncode:
            raise SystemExit(f"compress in {label} failed:\n{done.stderr[-2000:]}")
        if i == 0:
            stderr_first = done.stderr
    return {"label": label, "rev": rev, "commit": commit, "install_s": round(install_s, 1),
            "venv_bytes": _venv_bytes(venv), "site_packages": sizes,
            "first_compress_s": round(runs[0], 3), "warm_compress_s": round(statistics.median(runs[1:]), 3),
            "first_compress_stderr": stderr_first}


def _md(results: list[dict], load: tuple, load_after: tuple) -> str:
    mb = lambda b: f"{b / 1e6:.0f} MB"  # noqa: E731
    lines = ["# Fresh install: size and first use (`benchmarks/install.py`)", "",
             f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} CPUs, load average "
             f"{' / '.join(f'{x:.2f}' for x in load)} before and {' / '.join(f'{x:.2f}' for x in load_after)} after. "
             "Each tree installed with `pip install DIR` (not editable) into a new venv; the quick start's "
             "`motionrep example walk.bvh` then `motionrep compress walk.bvh -o walk.mrc`, the first run in the "
             f"fresh install (target <= {TARGET_FIRST_COMPRESS:.0f} s) and the median of the later runs. The issue's "
             f"figure before the compiled core: {BEFORE_MB} MB.", "",
             "| tree | commit | venv | site-packages | pip install | first compress | later compress |",
             "|---|---|---:|---:|---:|---:|---:|"]
    for r in results:
        met = "met" if r["first_compress_s"] <= TARGET_FIRST_COMPRESS else "NOT met"
        lines.append(f"| {r['label']} | {r['commit']} | {mb(r['venv_bytes'])} | {mb(sum(r['site_packages'].values()))} "
                     f"| {r['install_s']} s | {r['first_compress_s']} s ({met}) | {r['warm_compress_s']} s |")
    names = sorted({n for r in results for n in r["site_packages"]},
                   key=lambda n: -max(r["site_packages"].get(n, 0) for r in results))
    lines += ["", "Largest distributions in site-packages:", "",
              "| distribution | " + " | ".join(r["label"] for r in results) + " |",
              "|---|" + "---:|" * len(results)]
    for n in names[:12]:
        lines.append(f"| {n} | " + " | ".join(mb(r["site_packages"].get(n, 0)) if n in r["site_packages"] else "-"
                                              for r in results) + " |")
    for r in results:
        said = r["first_compress_stderr"].strip() or "(nothing)"
        lines += ["", f"What the first compress printed on stderr ({r['label']}):", "",
                  "\n".join("    " + line for line in said.splitlines())]
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", default="main", help="revision measured beside this checkout's HEAD")
    ap.add_argument("--no-base", action="store_true")
    ap.add_argument("--repeats", type=int, default=3, help="later compress runs (median)")
    args = ap.parse_args()
    load = os.getloadavg()
    results = []
    with tempfile.TemporaryDirectory(prefix="motionrep-install-") as tmp:
        work = Path(tmp)
        if not args.no_base:
            results.append(_measure("base", args.base, work, args.repeats))
        results.append(_measure("this", "HEAD", work, args.repeats))
        shutil.rmtree(work, ignore_errors=True)
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "install.json").write_text(json.dumps({"load": load, "results": results}, indent=1) + "\n")
    text = _md(results, load, os.getloadavg())
    (RESULTS / "install.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
