"""``-`` for every input format (issue 16): HDF5 databases and archives, NPZ and .glb files from standard input,
kept in a private temporary file within ``max_stdin_bytes``, removed on exit and on signals; clips from standard
input sent to workers that cannot read it."""

from __future__ import annotations

import concurrent.futures as cf
import io
import json
import os
import signal
import stat
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from motionrep.io.archive import Archive
from motionrep.cli._stdin import sniff, stdin_inputs
from motionrep.errors import FormatError, Interrupted
from motionrep.io import read, write, write_database
from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, synthetic_motion
from helpers import run_cli_caught


def run(*args, input: bytes | None = None, env: dict | None = None):
    return run_cli_caught(*args, input=input, env=env)


def error_line(result) -> str:
    lines = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert len(lines) == 1, result.output
    assert "Traceback" not in result.output
    return lines[0]


def archive_bytes(path: Path) -> dict[str, bytes]:
    with Archive(path) as a:
        return {n: a.read_bytes(n) for n in a.names}


@pytest.fixture
def files(tmp_path) -> dict[str, Path]:
    walk = synthetic_motion(humanoid_skeleton(), frames=40, fps=30.0)
    out = {"bvh": tmp_path / "walk.bvh", "npz": tmp_path / "walk.npz", "glb": tmp_path / "walk.glb",
           "db": tmp_path / "db.h5", "archive": tmp_path / "arch.h5"}
    write(walk, out["bvh"])
    write(walk, out["npz"])
    write(walk, out["glb"])
    write_database({"a": walk, "b": synthetic_motion(chain_skeleton(5), frames=30, fps=60.0, seed=3)}, out["db"])
    r = run("compress", out["db"], "-o", out["archive"], "--codec", "svd")
    assert r.exit_code == 0, r.output
    return out


def test_formats_are_told_by_their_first_bytes(files):
    for key, suffix in (("bvh", ".bvh"), ("npz", ".npz"), ("glb", ".glb"), ("db", ".h5"), ("archive", ".h5")):
        assert sniff(files[key].read_bytes()[:4096]) == suffix
    assert sniff(b"\x00" * 512 + b"\x89HDF\r\n\x1a\n") == ".h5"  # after a user block
    assert sniff(b"\xef\xbb\xbf\r\nhierarchy\n") == ".bvh"
    assert sniff(b"") is None and sniff(b"<html>") is None


def test_info_of_a_database_and_an_archive_from_standard_input(files):
    for key in ("db", "archive"):
        expected = json.loads(run("info", files[key], "--json").output)
        r = run("info", "-", "--json", input=files[key].read_bytes())
        assert r.exit_code == 0, r.output
        got = json.loads(r.output)
        assert got["file"] == "<stdin>" and expected["file"] == str(files[key])
        assert {k: v for k, v in got.items() if k != "file"} == {k: v for k, v in expected.items() if k != "file"}
    r = run("info", "-", "--clip", "b", "--json", input=files["db"].read_bytes())
    assert r.exit_code == 0 and json.loads(r.output)["frames"] == 30


def test_decompress_an_archive_from_standard_input(tmp_path, files):
    assert run("decompress", files["archive"], "-o", tmp_path / "from_file").exit_code == 0
    r = run("decompress", "-", "-o", tmp_path / "from_stdin", input=files["archive"].read_bytes())
    assert r.exit_code == 0, r.output
    from_file = {p.name: p.read_bytes() for p in (tmp_path / "from_file").iterdir()}
    assert {p.name: p.read_bytes() for p in (tmp_path / "from_stdin").iterdir()} == from_file
    assert sorted(from_file) == ["a.bvh", "b.bvh"]
    r = run("decompress", "-", "-o", "-", "--clip", "b", input=files["archive"].read_bytes())
    assert r.exit_code == 0 and r.stdout_bytes == from_file["b.bvh"]
    r = run("decompress", "-", "-o", tmp_path / "x", input=files["db"].read_bytes())  # motions, not compressed
    assert r.exit_code == 1 and error_line(r).startswith("Error: <stdin>: holds motions")
    assert not (tmp_path / "x").exists()


def test_evaluate_an_archive_from_standard_input(files):
    expected = json.loads(run("evaluate", files["archive"], files["db"], "--json").output)
    r = run("evaluate", "-", files["db"], "--json", input=files["archive"].read_bytes())
    assert r.exit_code == 0, r.output
    got = json.loads(r.output)
    assert got["reference"] == "<stdin>" and got["worst"] == expected["worst"]
    assert got["clips"] == expected["clips"]


def test_convert_and_compress_databases_npz_and_glb_from_standard_input(tmp_path, files):
    r = run("convert", "-", tmp_path / "out", input=files["db"].read_bytes())
    assert r.exit_code == 0, r.output
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["a.bvh", "b.bvh"]
    for key in ("npz", "glb"):
        r = run("convert", "-", tmp_path / f"{key}.bvh", input=files[key].read_bytes())
        assert r.exit_code == 0, r.output
        assert read(tmp_path / f"{key}.bvh").num_frames == 40
    r = run("compress", "-", "-o", tmp_path / "piped.h5", "--codec", "svd", input=files["db"].read_bytes())
    assert r.exit_code == 0, r.output
    assert archive_bytes(tmp_path / "piped.h5") == archive_bytes(files["archive"])  # the same as from the file
    r = run("compress", "-", "-o", tmp_path / "x.h5", input=files["archive"].read_bytes()[:5000])  # truncated
    assert r.exit_code == 1 and error_line(r).startswith("Error: <stdin>: ")
    assert not (tmp_path / "x.h5").exists()


def test_standard_input_errors_are_one_line(tmp_path, files):
    r = run("info", "-", input=b"")
    assert r.exit_code == 1 and "Error: <stdin>: is empty; this command reads BVH text" in error_line(r)
    r = run("info", "-", input=b"\x00" * 10000)
    assert r.exit_code == 1 and error_line(r).startswith("Error: <stdin>: is not BVH text")
    r = run("convert", "-", tmp_path / "x.bvh", input=files["db"].read_bytes()[:3000])  # truncated
    assert r.exit_code == 1 and error_line(r).startswith("Error: <stdin>: ") and not (tmp_path / "x.bvh").exists()
    r = run("decompress", "-", "-o", tmp_path / "y.bvh", input=files["npz"].read_bytes())
    assert r.exit_code == 1 and "Error: <stdin>: is an NPZ file; this command reads a .mrc file or an HDF5 file" \
        in error_line(r)


def test_the_size_limit_is_named(tmp_path, files, monkeypatch):
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    r = run("info", "-", input=files["db"].read_bytes(), env={"MOTIONREP_MAX_STDIN_BYTES": "8K"})
    assert r.exit_code == 1
    assert error_line(r) == ("Error: <stdin>: more than 8.0 KiB piped, the limit for standard input (raise "
                             "MOTIONREP_MAX_STDIN_BYTES to read it, or give the file's path)")
    assert not list(tmp_path.glob("motionrep-stdin-*"))
    r = run("info", "-", input=files["db"].read_bytes(), env={"MOTIONREP_MAX_STDIN_BYTES": "1M"})
    assert r.exit_code == 0, r.output


class _Pipe(io.BytesIO):
    """Standard input that gives a few bytes per read, as a pipe does."""

    def read(self, n: int = -1) -> bytes:
        return super().read(min(n, 1000) if n and n > 0 else 1000)

    def isatty(self) -> bool:
        return False

    @property
    def buffer(self):
        return self


def test_the_temporary_file_is_private_and_removed(tmp_path, files, monkeypatch):
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    data = files["db"].read_bytes()
    monkeypatch.setattr(sys, "stdin", _Pipe(data))
    with stdin_inputs([files["bvh"], "-"]) as paths:
        tmp = Path(paths[1])
        assert paths[0] == files["bvh"] and tmp.suffix == ".h5" and tmp.read_bytes() == data
        assert stat.S_IMODE(tmp.stat().st_mode) == 0o600 and stat.S_IMODE(tmp.parent.stat().st_mode) == 0o700
    assert not tmp.parent.exists()
    monkeypatch.setattr(sys, "stdin", _Pipe(data))
    with pytest.raises(Interrupted):
        with stdin_inputs(["-"]) as paths:
            raise Interrupted(signal.SIGTERM)
    assert not Path(paths[0]).parent.exists()
    # a directory a killed command left (SIGKILL cannot be caught) goes at the next '-'
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    stale = tmp_path / f"motionrep-stdin-{int(dead.stdout)}-abc"
    stale.mkdir()
    (stale / "stdin.bvh").write_bytes(b"x")
    monkeypatch.setattr(sys, "stdin", _Pipe(files["bvh"].read_bytes()))
    with stdin_inputs(["-"]):
        assert not stale.exists()
    monkeypatch.setattr(sys, "stdin", _Pipe(b"<html>"))
    with pytest.raises(FormatError, match="<stdin>: is not"):
        with stdin_inputs(["-"]):
            pass
    assert not list(tmp_path.glob("motionrep-stdin-*"))


def test_a_real_pipe_and_a_signal_while_reading_it(tmp_path, files):
    env = dict(os.environ, TMPDIR=str(tmp_path))
    with open(files["db"], "rb") as f:
        r = subprocess.run([sys.executable, "-m", "motionrep", "info", "-", "--json"], stdin=f,
                           capture_output=True, env=env, timeout=120)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["file"] == "<stdin>"
    # SIGTERM while standard input is being copied: exit 143, the temporary directory removed
    p = subprocess.Popen([sys.executable, "-m", "motionrep", "info", "-"], stdin=subprocess.PIPE,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    p.stdin.write(files["db"].read_bytes()[:6000])
    p.stdin.flush()
    deadline = time.monotonic() + 60
    while not list(tmp_path.glob("motionrep-stdin-*/stdin.h5")) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert list(tmp_path.glob("motionrep-stdin-*/stdin.h5"))
    p.send_signal(signal.SIGTERM)
    out, err = p.communicate(timeout=60)
    p.stdin.close()
    assert p.returncode == 143 and b"Traceback" not in err
    assert not list(tmp_path.glob("motionrep-stdin-*"))


def test_clips_from_standard_input_are_sent_to_the_workers(tmp_path, files, monkeypatch):
    """With ``send_data``, the clips of the named files are read by the client (here: the main thread) and
    sent; the workers (a thread pool) never open them; other files are read by the workers."""
    from motionrep.batch.engine import compress_clips
    from motionrep.pipeline.compress import Pipeline
    from motionrep.pipeline.sources import ClipRef, collect_clips

    refs = collect_clips([files["db"], files["bvh"]])
    opened: list[tuple[str, bool]] = []
    real = ClipRef.read_with_checksum

    def spy(self):
        opened.append((self.path, threading.current_thread() is threading.main_thread()))
        return real(self)

    monkeypatch.setattr(ClipRef, "read_with_checksum", spy)
    pipeline = Pipeline.build("svd", max_error="2%")
    with cf.ThreadPoolExecutor(2) as pool:
        outcomes = compress_clips(refs, pipeline, executor=pool, send_data=[str(files["db"])])
    assert all(o.status == "done" for o in outcomes), [o.summary for o in outcomes]
    assert sorted(opened) == sorted([(str(files["db"]), True), (str(files["db"]), True), (str(files["bvh"]), False)])
    with cf.ThreadPoolExecutor(2) as pool:
        assert [o.data for o in compress_clips(refs, pipeline, executor=pool)] == [o.data for o in outcomes]
