"""Outputs on the command line (issue 14): --append to a database (never a silent replacement), Ctrl-C, SIGTERM
and SIGHUP during an HDF5 write leaving nothing behind, kept permissions, errors naming the output, resampling
that keeps the clip's last frame.  (The --force policy itself is tested with the commands that share it.)"""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
import time

import numpy as np
import pytest

from motionrep import read
from motionrep.io import atomic_path, list_clips, write
from motionrep.model.ops import resample_times, resampled_count
from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, synthetic_motion
from helpers import run_cli_caught


def run(*args):
    return run_cli_caught(*args)


def one_error_line(result, *needles):
    assert result.exit_code == 1, result.output
    lines = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert len(lines) == 1, result.output
    for n in needles:
        assert n in lines[0], lines[0]


@pytest.fixture
def clips(tmp_path):
    d = tmp_path / "in"
    d.mkdir()
    for i, name in enumerate(["a", "b"]):
        write(synthetic_motion(chain_skeleton(3), frames=5 + i, seed=i), d / f"{name}.npz")
    return d


# ---- --append ------------------------------------------------------------------------------------------------
def test_database_append_and_force(clips, tmp_path):
    db = tmp_path / "db.h5"
    assert run("convert", clips / "a.npz", db).exit_code == 0
    one_error_line(run("convert", clips / "b.npz", db), "db.h5: exists", "--force", "--append")
    assert list_clips(db) == ["a"]
    assert run("convert", clips / "b.npz", db, "--append").exit_code == 0
    assert list_clips(db) == ["a", "b"]
    before = read(db, clip="a")
    one_error_line(run("convert", clips / "a.npz", db, "--append"), "already holds clip a", "--force")
    other = tmp_path / "other"
    other.mkdir()
    write(synthetic_motion(chain_skeleton(3), frames=9, seed=7), other / "a.npz")
    assert run("convert", other / "a.npz", db, "--append", "--force").exit_code == 0
    assert list_clips(db) == ["b", "a"] and read(db, clip="a").num_frames == 9
    assert read(db, clip="b").num_frames == 6 and before.num_frames == 5
    # --append applies to databases only
    assert run("convert", clips / "a.npz", tmp_path / "x.npz", "--append").exit_code == 2


def test_database_append_copies_the_kept_clips_exactly(clips, tmp_path):
    db = tmp_path / "db.h5"
    assert run("convert", clips / "a.npz", db).exit_code == 0
    kept = read(db, clip="a")
    assert run("convert", clips / "b.npz", db, "--append").exit_code == 0
    again = read(db, clip="a")
    np.testing.assert_array_equal(again.rotations, kept.rotations)
    np.testing.assert_array_equal(again.root_translation, kept.root_translation)


# ---- files: permissions, errors naming the output, leftovers of killed writers --------------------------------
@pytest.mark.skipif(os.name != "posix", reason="POSIX permissions")
def test_a_replaced_file_keeps_its_permissions(clips, tmp_path):
    out = tmp_path / "a.npz"
    out.write_text("x")
    out.chmod(0o600)
    assert run("convert", clips / "a.npz", out, "--force").exit_code == 0
    assert stat.S_IMODE(out.stat().st_mode) == 0o600


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root writes anywhere")
def test_a_read_only_directory_is_named_not_the_temporary_file(clips, tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        result = run("convert", clips / "a.npz", ro / "a.bvh")
        one_error_line(result, str(ro / "a.bvh"), "ermission denied")
        assert ".tmp" not in result.output
    finally:
        ro.chmod(0o700)


def test_atomic_path_names_the_target_in_errors_and_removes_leftovers_of_dead_writers(tmp_path):
    target = tmp_path / "x.bvh"
    with pytest.raises(OSError) as info:
        with atomic_path(tmp_path / "missing-dir" / "x.bvh"):
            pass
    assert info.value.filename == str(tmp_path / "missing-dir" / "x.bvh")
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    stale = tmp_path / f".x.bvh.{int(dead.stdout)}.abc123.tmp.bvh"
    stale.write_text("half a file")
    mine = tmp_path / f".x.bvh.{os.getpid()}.zzz.tmp.bvh"
    mine.write_text("another writer in this process")
    with atomic_path(target) as tmp:
        tmp.write_text("done")
    assert target.read_text() == "done" and not stale.exists() and mine.exists()


# ---- signals ---------------------------------------------------------------------------------------------------
@pytest.mark.skipif(os.name != "posix", reason="POSIX signals")
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT])
def test_a_signal_during_an_hdf5_write_leaves_nothing_and_exits_128_plus_signum(tmp_path, signum):
    src = tmp_path / "big.npz"
    write(synthetic_motion(humanoid_skeleton(), frames=60_000, seed=1), src)
    out = tmp_path / "out.h5"
    proc = subprocess.Popen([sys.executable, "-m", "motionrep", "convert", str(src), str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:  # wait for the temporary file: writing has begun
        if any(p.name.startswith(".out.h5.") for p in tmp_path.iterdir()):
            break
        time.sleep(0.005)
    else:
        proc.kill()
        pytest.skip("the write finished before a signal could be sent (a very fast machine)")
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 128 + signum, err
    assert "Interrupted" in err and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.npz"]


# ---- decompress --fps ------------------------------------------------------------------------------------------
def test_resampling_keeps_the_last_frame_of_a_clip_whose_rate_has_few_digits():
    fps = 1 / 0.0083333  # 120.0048: a 277-frame clip spans 2.29991 s, 69 intervals at 30 fps (68.9997)
    assert resampled_count(277, fps, 30.0) == 70
    times = resample_times(277, fps, 30.0)
    assert times[-1] == 1.0 and np.all(np.diff(times) > 0)
    assert resampled_count(31, 30.0, 60.0) == 61 and resampled_count(10, 30.0, 7.0) == 3


def test_decompress_fps_keeps_the_clip_duration(tmp_path):
    from motionrep.pipeline.compress import compress_motion

    m = synthetic_motion(chain_skeleton(3), frames=277, fps=1 / 0.0083333, seed=4)
    mrc = tmp_path / "c.mrc"
    mrc.write_bytes(compress_motion(m, "svd", max_error=None, params={"rank": 3}).data)
    assert run("decompress", mrc, "-o", tmp_path / "d.npz", "--fps", "30").exit_code == 0
    d = read(tmp_path / "d.npz")
    assert d.num_frames == 70 and abs((d.num_frames - 1) / d.fps - (m.num_frames - 1) / m.fps) < 0.5 / 30
