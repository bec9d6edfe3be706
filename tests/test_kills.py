"""Kills leave nothing (issue 27): the workers of ``compress --jobs 2`` die with their client, and temporary
files of a killed ``convert``/``compress``/``merge`` are removed by the next run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import motionrep
from motionrep.io._atomic import remove_stale_files, remove_stale_folders
from motionrep.model.synthetic import synthetic_motion
from helpers import run_cli_caught

linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG and /proc are Linux's")


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_remove_stale_files_removes_only_dead_writers_temporaries(tmp_path):
    dead = _dead_pid()
    stale = tmp_path / f".db.h5.{dead}.abcd_123.tmp.h5"
    live = tmp_path / f".db.h5.{os.getppid()}.abcd_123.tmp.h5"
    mine = tmp_path / f".x.mrc.{os.getpid()}.abcd_123.tmp.mrc"
    other = tmp_path / f".notes.{dead}.abcd_123.tmp"  # not a name atomic_path makes (no target suffix)
    for p in (stale, live, mine, other):
        p.write_bytes(b"x")
    assert remove_stale_files(tmp_path) == 1
    assert not stale.exists() and live.exists() and mine.exists() and other.exists()


def test_remove_stale_folders(tmp_path):
    dead = _dead_pid()
    (tmp_path / f"motionrep-stdout-{dead}-xyz").mkdir()
    (tmp_path / f"motionrep-stdout-{os.getppid()}-xyz").mkdir()
    remove_stale_folders(tmp_path, "motionrep-stdout-")
    assert [p.name for p in tmp_path.iterdir()] == [f"motionrep-stdout-{os.getppid()}-xyz"]


def _clips(directory: Path, count: int, frames: int) -> None:
    directory.mkdir()
    for i in range(count):
        motionrep.write(synthetic_motion(frames=frames, seed=i), directory / f"c{i:02d}.bvh")


def _children(pid: int) -> list[int]:
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                out.append(int(entry.name))
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _motionrep(*args: str, cwd: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "motionrep", *args], cwd=cwd, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env=dict(os.environ, TMPDIR=str(cwd)))


@linux
@pytest.mark.slow
def test_sigkill_of_compress_jobs_2_leaves_no_worker(tmp_path):
    _clips(tmp_path / "in", 12, 300)
    client = _motionrep("compress", "in", "-o", "out/", "--jobs", "2", cwd=tmp_path)
    deadline = time.monotonic() + 60
    workers: list[int] = []
    while time.monotonic() < deadline and len(workers) < 2:
        time.sleep(0.2)
        workers = [c for c in _children(client.pid) if _alive(c)]
        workers = [c for c in workers if "multiprocessing" in Path(f"/proc/{c}/cmdline").read_bytes().decode(
            "utf-8", "replace")]
    assert len(workers) >= 2, "the workers never started"
    os.kill(client.pid, signal.SIGKILL)
    client.wait()
    time.sleep(2.0)
    assert [w for w in workers if _alive(w)] == []


@linux
@pytest.mark.slow
def test_sigkill_of_convert_to_database_then_next_run_leaves_no_temporary(tmp_path):
    _clips(tmp_path / "in", 30, 600)
    run = _motionrep("convert", "in", "db.h5", cwd=tmp_path)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not list(tmp_path.glob(".db.h5.*.tmp.h5")):
        time.sleep(0.05)
    assert list(tmp_path.glob(".db.h5.*.tmp.h5")), "convert never started writing"
    os.kill(run.pid, signal.SIGKILL)
    run.wait()
    assert list(tmp_path.glob(".db.h5.*.tmp.h5"))  # what the kill left
    # the next run removes it when it starts, even one that then fails (here: a usage error, exit 2)
    again = subprocess.run([sys.executable, "-m", "motionrep", "convert", "in/c00.bvh", "db.h5", "--format",
                            "bvh"], cwd=tmp_path, capture_output=True, env=dict(os.environ, TMPDIR=str(tmp_path)))
    assert again.returncode != 0
    leftovers = [p.name for p in tmp_path.iterdir() if p.name.startswith((".db.h5.", "motionrep-"))]
    assert leftovers == []


@pytest.mark.parametrize("command", ["merge", "compress"])
def test_merge_and_compress_remove_a_dead_writers_temporaries_when_they_start(tmp_path, command):


    _clips(tmp_path / "in", 2, 20)
    assert run_cli_caught("compress", str(tmp_path / "in"), "-o", str(tmp_path / "a.h5")).exit_code == 0
    stale = tmp_path / f".out.h5.{_dead_pid()}.abcd_123.tmp.h5"
    stale.write_bytes(b"left by a SIGKILL")
    args = (["merge", str(tmp_path / "a.h5"), "-o", str(tmp_path / "out.h5")] if command == "merge" else
            ["compress", str(tmp_path / "in"), "-o", str(tmp_path / "out.h5")])
    result = run_cli_caught(*args)
    assert result.exit_code == 0, result.output
    assert not stale.exists()


@linux
@pytest.mark.slow
def test_sigkill_of_a_fourier_encode_with_window_workers_leaves_no_worker(tmp_path):
    """The Fourier codecs' own window workers (a pebble pool of forked processes) die with the encoder at once,
    in the middle of a window (long windows, a tight bound: each trains for many seconds)."""
    motionrep.write(synthetic_motion(frames=900, seed=3), tmp_path / "long.bvh")
    client = _motionrep("compress", "long.bvh", "-o", "long.mrc", "--codec", "adaptive-fourier", "--max-error",
                        "0.05%", "-p", "window=300", "-p", "jobs=2", "-p", "max_k=40", cwd=tmp_path)
    deadline = time.monotonic() + 120
    workers: list[int] = []
    while time.monotonic() < deadline and len(workers) < 2:
        time.sleep(0.2)
        workers = [c for c in _children(client.pid) if _alive(c)]
    assert len(workers) >= 2, "the window workers never started"
    time.sleep(1.0)  # into their windows' training
    os.kill(client.pid, signal.SIGKILL)
    client.wait()
    time.sleep(0.5)
    assert [w for w in workers if _alive(w)] == []
