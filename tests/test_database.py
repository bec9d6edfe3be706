"""Whole databases: the overwrite policy, durable per-clip commits, ``--resume``, ``--timeout``, the totals,
interruption, reading back directories and archives, and ``motionrep merge``."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from motionrep.io.archive import read_archive
from motionrep.io import read, write, write_database
from motionrep.model.synthetic import chain_skeleton, synthetic_motion
from helpers import run_cli


run = run_cli  # helpers.run_cli: the one CLI runner of the tests


def _clips(directory: Path, count: int = 4, frames: int = 30, joints: int = 4) -> Path:
    (directory / "sub").mkdir(parents=True, exist_ok=True)
    for i in range(count):
        where = directory / "sub" if i % 2 else directory
        write(synthetic_motion(chain_skeleton(joints), frames=frames + i, fps=30, seed=i), where / f"c{i}.bvh")
    return directory


def _no_temp_files(*directories: Path) -> None:
    for d in directories:
        left = [p for p in d.rglob("*") if ".tmp" in p.name or p.name.endswith(".parts")]
        assert not left, left


def _committed(journal: Path) -> list[str]:
    """The clips committed to an archive's journal (not the hidden temporary file of one being written)."""
    return sorted(p.stem for p in journal.glob("*.mrc") if not p.name.startswith(".")) if journal.is_dir() else []


def _statuses(output: str) -> dict[str, str]:
    return {name: c["status"] for name, c in json.loads(output)["clips"].items()}


# ---------------------------------------------------------------------------------------------------------------
# --force, the one overwrite policy
# ---------------------------------------------------------------------------------------------------------------
def test_an_existing_output_needs_force(tmp_path):
    src = _clips(tmp_path / "clips")
    one, archive = tmp_path / "one.mrc", tmp_path / "all.h5"
    assert run("compress", src / "c0.bvh", "-o", one, "--codec", "svd").exit_code == 0
    before = one.read_bytes()
    r = run("compress", src / "c0.bvh", "-o", one, "--codec", "svd", "-p", "rank=2", "--max-error", "none")
    assert r.exit_code == 1 and "one.mrc: exists; use --force" in r.output and one.read_bytes() == before
    r = run("compress", src / "c0.bvh", "-o", one, "--codec", "svd", "-p", "rank=2", "--max-error", "none",
            "--force")
    assert r.exit_code == 0 and one.read_bytes() != before

    assert run("compress", src, "-o", archive, "--codec", "svd").exit_code == 0
    r = run("compress", src / "sub", "-o", archive, "--codec", "svd")
    assert r.exit_code == 1 and "--force" in r.output and "--resume" in r.output
    assert sorted(read_archive(archive)) == ["c0", "c2", "sub__c1", "sub__c3"]
    assert run("compress", src / "sub", "-o", archive, "--codec", "svd", "--force").exit_code == 0
    assert sorted(read_archive(archive)) == ["c1", "c3"]  # overwritten: only this run's clips

    out = tmp_path / "mrc"
    assert run("compress", src, "-o", out, "--codec", "svd").exit_code == 0
    (out / "mine.txt").write_text("kept")
    r = run("compress", src, "-o", out, "--codec", "svd")
    assert r.exit_code == 1 and "already holds 4 of these clips" in r.output
    assert run("compress", src, "-o", out, "--codec", "svd", "--force").exit_code == 0
    assert (out / "mine.txt").read_text() == "kept"  # --force overwrites clips, never other files

    back = tmp_path / "back.bvh"
    assert run("decompress", one, "-o", back).exit_code == 0
    r = run("decompress", one, "-o", back)
    assert r.exit_code == 1 and "--force" in r.output
    assert run("decompress", one, "-o", back, "--force").exit_code == 0
    r = run("compress", src, "-o", out, "--codec", "svd", "--force", "--resume")
    assert r.exit_code == 2


# ---------------------------------------------------------------------------------------------------------------
# --resume
# ---------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", [".h5", ""])
def test_resume_keeps_unchanged_clips_and_redoes_the_others(tmp_path, suffix):
    src = _clips(tmp_path / "clips")
    out = tmp_path / f"out{suffix}"
    r = run("compress", src, "-o", out, "--codec", "svd", "--json")
    assert r.exit_code == 0, r.output
    assert set(_statuses(r.output).values()) == {"done"}
    # one source changed, one added
    write(synthetic_motion(chain_skeleton(4), frames=33, fps=30, seed=99), src / "c2.bvh")
    write(synthetic_motion(chain_skeleton(3), frames=20, fps=30, seed=7), src / "new.bvh")
    r = run("compress", src, "-o", out, "--codec", "svd", "--json", "--resume")
    assert r.exit_code == 0, r.output
    assert _statuses(r.output) == {"c0": "skipped", "c2": "done", "new": "done", "sub__c1": "skipped",
                                   "sub__c3": "skipped"}
    totals = json.loads(r.output)["totals"]
    assert (totals["clips"], totals["compressed"], totals["kept"], totals["failed"]) == (5, 2, 3, 0)
    sources = sorted(src.rglob("*.bvh"))
    assert totals["source_mb"] == pytest.approx(sum(p.stat().st_size for p in sources) / 1e6)  # kept ones too
    # another setting: refused, naming what changed, and nothing touched; redone when told
    before = {p: p.read_bytes() for p in ([out] if out.is_file() else sorted(out.iterdir()))}
    r = run("compress", src, "-o", out, "--codec", "svd", "--resume", "--max-error", "1%")
    assert r.exit_code == 2 and "--recompress-changed" in r.output, r.output
    assert "max_error '2%' stored, '1%' now" in r.output, r.output
    assert before == {p: p.read_bytes() for p in before}
    r = run("compress", src, "-o", out, "--codec", "svd", "-p", "rank=2", "--resume")
    assert r.exit_code == 2 and "parameters rank=" in r.output, r.output
    r = run("compress", src, "-o", out, "--codec", "svd", "--json", "--resume", "--max-error", "1%",
            "--recompress-changed")
    assert set(_statuses(r.output).values()) == {"done"}
    r = run("compress", src, "-o", out, "--codec", "svd", "--json", "--resume", "--max-error", "1%")
    assert set(_statuses(r.output).values()) == {"skipped"}
    _no_temp_files(tmp_path)


def test_a_setting_is_identified_by_the_digest_of_its_spec():
    """``Pipeline.digest()``: the SHA-256 of the canonical setting; the same for the same setting however it was
    given, another for any change, and stored in every container."""
    import hashlib

    from motionrep.model.bound import MaxError
    from motionrep.pipeline.compress import Pipeline, setting_digest

    a = Pipeline.build("svd", params={"rank": "3"}, max_error="2%", seed=1)
    same = Pipeline.build("svd", "root-quat-axis-angle", {"rank": 3}, MaxError(2.0, True), 1)
    assert a.digest() == same.digest() == setting_digest(dict(reversed(list(a.setting().items()))))
    canonical = json.dumps(a.setting(), sort_keys=True, separators=(",", ":"))
    assert a.digest() == hashlib.sha256(canonical.encode()).hexdigest()
    others = [Pipeline.build("svd", params={"rank": 4}, max_error="2%", seed=1),
              Pipeline.build("svd", params={"rank": 3}, max_error="2.5%", seed=1),
              Pipeline.build("svd", params={"rank": 3}, max_error="2", seed=1),
              Pipeline.build("svd", params={"rank": 3}, max_error="2%", seed=2),
              Pipeline.build("transform", max_error="2%", seed=1)]
    assert len({a.digest()} | {p.digest() for p in others}) == 6
    free = Pipeline.build("svd", max_error="2%")
    motion = synthetic_motion(chain_skeleton(3), frames=12, seed=2)
    assert free.compress(motion).container.extra["setting_sha256"] == free.digest()


@pytest.mark.parametrize("suffix", [".h5", ""])
def test_resume_keeps_the_clips_of_an_output_written_before_the_digest(tmp_path, suffix):
    """An output of version-1 containers (no stored digest, the bound as text) resumes: their digest is derived from
    the setting they state; a changed setting is still refused naming what changed."""
    from helpers import mrc_version_1
    from motionrep.io.archive import write_archive

    src = _clips(tmp_path / "clips", count=3)
    out = tmp_path / f"out{suffix}"
    r = run("compress", src, "-o", out, "--codec", "svd", "--json")
    assert r.exit_code == 0, r.output
    if suffix:
        from motionrep.io.archive import Archive

        with Archive(out) as archive:
            old = {name: mrc_version_1(archive.read_bytes(name)) for name in archive.names}
        write_archive(sorted(old.items()), out)
    else:
        for p in out.iterdir():
            p.write_bytes(mrc_version_1(p.read_bytes()))
    r = run("compress", src, "-o", out, "--codec", "svd", "--json", "--resume")
    assert r.exit_code == 0, r.output
    assert set(_statuses(r.output).values()) == {"skipped"}
    r = run("compress", src, "-o", out, "--codec", "svd", "--resume", "--seed", "3")
    assert r.exit_code == 2 and "seed 0 stored, 3 now" in r.output and "--recompress-changed" in r.output, r.output


def test_a_killed_run_leaves_a_journal_that_resume_finishes(tmp_path):
    """A run killed after two clips (simulated: the store is never closed) keeps them in the journal."""
    from motionrep.batch.engine import compress_clips
    from motionrep.pipeline.compress import Pipeline
    from motionrep.pipeline.sources import collect_clips
    from motionrep.batch.store import journal_path, open_store

    src = _clips(tmp_path / "clips", count=5)
    out = tmp_path / "out.h5"
    refs = collect_clips([src])
    store = open_store(out)

    class Killed(Exception):
        pass

    def commit(outcome):
        store.commit(outcome.name, outcome.data)
        if len(store.committed) == 2:
            raise Killed

    with pytest.raises(Killed):
        compress_clips(refs, Pipeline.build("svd"), on_done=commit)
    journal = journal_path(out)
    assert not out.exists() and len(_committed(journal)) == 2
    r = run("compress", src, "-o", out, "--codec", "svd")
    assert r.exit_code == 1 and "interrupted run left 2 finished clips" in r.output
    r = run("compress", src, "-o", out, "--codec", "svd", "--resume", "--json")
    assert r.exit_code == 0, r.output
    statuses = _statuses(r.output)
    assert sorted(statuses.values()) == ["done"] * 3 + ["skipped"] * 2
    assert sorted(read_archive(out)) == sorted(statuses) and not journal.exists()
    # the same bytes as one uninterrupted run
    whole = tmp_path / "whole.h5"
    assert run("compress", src, "-o", whole, "--codec", "svd").exit_code == 0
    from motionrep.io.archive import Archive

    with Archive(out) as a, Archive(whole) as b:
        assert all(a.read_bytes(n) == b.read_bytes(n) for n in b.names)


# ---------------------------------------------------------------------------------------------------------------
# totals, failures, exit code
# ---------------------------------------------------------------------------------------------------------------
def test_totals_name_every_failure_and_the_others_are_kept(tmp_path):
    src = _clips(tmp_path / "clips", count=3)
    (src / "bad.bvh").write_text("HIERARCHY\nROOT hip\n{\n")
    (src / "worse.bvh").write_text("not a bvh file\n")
    out = tmp_path / "out.h5"
    r = run("compress", src, "-o", out, "--codec", "svd", "--json")
    assert r.exit_code == 1
    d = json.loads(r.output[:r.output.rindex("}") + 1])
    t = d["totals"]
    assert (t["clips"], t["compressed"], t["failed"]) == (5, 3, 2)
    assert [f["clip"] for f in t["failures"]] == ["bad", "worse"]
    assert all("bad.bvh" in f["reason"] or "worse.bvh" in f["reason"] for f in t["failures"])
    kept = read_archive(out)
    assert sorted(kept) == ["c0", "c2", "sub__c1"]
    clips = {n: c for n, c in d["clips"].items() if c["status"] == "done"}
    compressed = sum(c["bytes"] for c in clips.values())
    bone_frames = sum(c["frames"] * (c["joints"] + c["end_sites"]) for c in clips.values())
    assert t["compressed_mb"] == pytest.approx(compressed / 1e6)
    # one definition each (motionrep.pipeline.figures): the file's bits divide the containers, the payload's the arrays
    assert t["file_bits_per_bone_frame"] == pytest.approx(8 * compressed / bone_frames)
    payload = sum(c["figures"]["payload_bytes"] for c in clips.values())
    assert t["payload_bits_per_bone_frame"] == pytest.approx(8 * payload / bone_frames)
    assert "bits_per_bone_frame" not in t  # the ambiguous name is gone
    raw = sum(c["frames"] * c["figures"]["num_channels"] * 4 for c in clips.values())
    assert t["raw_mb"] == pytest.approx(raw / 1e6) and t["ratio"] == pytest.approx(raw / compressed)
    worst = max(clips, key=lambda n: clips[n]["evaluation"]["max_error_percent"])
    assert t["worst"]["clip"] == worst
    assert t["wall_seconds"] > 0 and t["cpu_seconds"] > 0
    r = run("compress", src, "-o", tmp_path / "text", "--codec", "svd")
    assert r.exit_code == 1
    for needle in ("clips:        5 (3 compressed, 2 failed)", "FAILED bad:", "FAILED worse:",
                   "payload bits/bone/frame", "file bits/bone/frame",
                   "worst error:", "s wall", "2 of 5 clips failed"):
        assert needle in r.output, r.output


def test_progress_without_a_terminal_names_failures_and_gives_an_eta():
    import io

    from motionrep.cli._common import BatchProgress

    stream = io.StringIO()
    with BatchProgress(4, "compressing", lambda x: f"clip {x}", every=3600, stream=stream) as bar:
        bar.done("a")
        bar.done("b", failed=True)
        bar.done("c")
        bar.done("d")
    lines = stream.getvalue().splitlines()
    assert lines[0].startswith("[1/4] clip a; ") and "ETA" in lines[0]
    assert lines[1].startswith("[2/4] clip b; 1 failed") and "ETA" in lines[1]
    assert lines[2].startswith("[4/4] clip d; 1 failed") and "ETA" not in lines[2]
    assert len(lines) == 3  # clip c: within `every` seconds of the last line


# ---------------------------------------------------------------------------------------------------------------
# --timeout
# ---------------------------------------------------------------------------------------------------------------
def test_time_limit_stops_python_work_in_any_thread():
    from motionrep.batch.engine import time_limit
    from motionrep.errors import TimeLimitError

    def spin():
        with time_limit(0.2):
            while True:
                pass

    start = time.monotonic()
    with pytest.raises(TimeLimitError, match="time limit of 0.2 s"):
        spin()
    assert time.monotonic() - start < 5
    caught = []

    def in_thread():
        try:
            spin()
        except TimeLimitError as exc:
            caught.append(exc)

    t = threading.Thread(target=in_thread)
    t.start()
    t.join(10)
    assert len(caught) == 1
    with time_limit(5):  # finished in time: nothing raised, later
        pass
    time.sleep(0.05)


def test_time_limit_is_raised_again_when_python_drops_it():
    """Python prints and drops an exception raised in a garbage collector's callback (a weakref's): the limit
    must still stop the block (a slow clip once ran to the end and the batch exited 0)."""
    from motionrep.batch.engine import time_limit
    from motionrep.errors import TimeLimitError

    dropped = []
    start = time.monotonic()
    with pytest.raises(TimeLimitError):
        with time_limit(0.2):
            while True:
                try:
                    while True:
                        pass
                except BaseException as exc:  # noqa: BLE001 - stands for the callback that drops it
                    if dropped:
                        raise
                    dropped.append(exc)
    assert len(dropped) == 1 and time.monotonic() - start < 5


_DROPPED_TIME_LIMIT = """
import weakref
from motionrep.batch.engine import time_limit
from motionrep.errors import TimeLimitError
from motionrep.batch.executors import _TimeUp

class Thing:
    pass

def callback(_ref):
    raise _TimeUp

def other(_ref):
    raise ValueError("a report that is not the time limit's")

try:
    with time_limit(0.2):
        refs = [weakref.ref(Thing(), callback)]  # the object dies at once: the callback's _TimeUp is dropped
        while True:
            pass
except TimeLimitError:
    print("stopped")
kept = weakref.ref(Thing(), other)  # its callback runs now: Python reports it on stderr
"""


def test_a_dropped_time_limit_prints_no_traceback():
    """A time limit that lands in a weakref's callback is dropped by Python with an "Exception ignored" report on
    stderr: the user must not see that traceback; other such reports are still printed."""
    r = subprocess.run([sys.executable, "-c", _DROPPED_TIME_LIMIT], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stdout.strip() == "stopped"
    assert "_TimeUp" not in r.stderr
    assert "a report that is not the time limit's" in r.stderr


def test_timeout_fails_the_slow_clip_and_the_others_go_on(tmp_path):
    src = tmp_path / "clips"
    src.mkdir()
    write(synthetic_motion(chain_skeleton(3), frames=20, fps=30, seed=1), src / "short.bvh")
    # several seconds of svd: a limit that lands in a garbage-collector callback is dropped and raised again
    # later, and the clip must still be running then (3,000 frames once finished first, and the run exited 0)
    write(synthetic_motion(chain_skeleton(30), frames=12000, fps=120, seed=2), src / "long.npz")
    out = tmp_path / "out"
    r = run("compress", src, "-o", out, "--codec", "svd", "--timeout", "0.3", "--json")
    assert r.exit_code == 1
    d = json.loads(r.output[:r.output.rindex("}") + 1])
    assert d["clips"]["short"]["status"] == "done"
    assert d["clips"]["long"]["status"] == "failed" and "time limit of 0.3 s (--timeout)" in d["clips"]["long"]["error"]
    assert "parameters" not in d["clips"]["long"]  # the library's mention, rewritten into the flag by the CLI
    assert sorted(p.name for p in out.iterdir()) == ["short.mrc"]


# ---------------------------------------------------------------------------------------------------------------
# reading back what was written
# ---------------------------------------------------------------------------------------------------------------
def test_decompress_and_evaluate_read_directories_and_archives(tmp_path):
    src = _clips(tmp_path / "clips", count=3)
    mrc, archive = tmp_path / "mrc", tmp_path / "all.h5"
    assert run("compress", src, "-o", mrc, "--codec", "svd").exit_code == 0
    assert run("compress", src, "-o", archive, "--codec", "svd").exit_code == 0
    r = run("evaluate", src, mrc, "--json")
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    assert [c["clip"] for c in d["clips"]] == ["c0", "c2", "sub__c1"]
    stored = read_archive(archive)
    for c in d["clips"]:
        assert c["max_error"] == pytest.approx(stored[c["clip"]].evaluation["max_error"], rel=1e-12)
    assert run("evaluate", src, archive).exit_code == 0
    r = run("evaluate", src, mrc, "--clip", "sub__c1", "--json")
    assert r.exit_code == 0 and json.loads(r.output)["max_error"] == pytest.approx(
        stored["sub__c1"].evaluation["max_error"], rel=1e-12)
    (mrc / "c2.mrc").unlink()
    r = run("evaluate", src, mrc)
    assert r.exit_code == 1 and "only in the reference: c2" in r.output

    out = tmp_path / "decoded"
    r = run("decompress", mrc, "-o", out)
    assert r.exit_code == 0, r.output
    assert sorted(p.name for p in out.iterdir()) == ["c0.bvh", "sub__c1.bvh"]
    assert read(out / "sub__c1.bvh").num_frames == 31
    db = tmp_path / "decoded.h5"
    assert run("decompress", archive, "-o", db).exit_code == 0
    plain = tmp_path / "plain"
    plain.mkdir()
    write_database({"x": synthetic_motion(chain_skeleton(3), frames=10)}, plain / "motions.h5")
    r = run("decompress", plain, "-o", tmp_path / "nothing")
    assert r.exit_code == 1 and "holds motions, not compressed clips" in r.output


def _merge_in_python(a: Path, other: Path, tmp_path: Path) -> None:
    """The clash policy is the library's (motionrep.batch.merge): the same outcomes without the command line."""
    from motionrep.batch.merge import plan_merge
    from motionrep.errors import FormatError, ValidationError
    from motionrep.io.archive import Archive

    with pytest.raises(FormatError, match=r"clash with different contents: .*; use on_clash=first\|last\|prefix"):
        plan_merge([a, other])
    with pytest.raises(ValidationError, match="on_clash must be one of error, first, last, prefix"):
        plan_merge([a, other], on_clash="newest")
    plan = plan_merge([a, other], on_clash="last")
    assert plan.names == ["c0", "c2"]
    plan.write(tmp_path / "py.h5")
    with Archive(tmp_path / "py.h5") as m, Archive(other) as o:
        assert m.read_bytes("c0") == o.read_bytes("c0")
    assert plan_merge([a, other], on_clash="prefix").names == ["a__c0", "a__c2", "other__c0", "other__c2"]


def test_merge_joins_shards_and_refuses_clashes(tmp_path):
    src = _clips(tmp_path / "clips", count=4)
    a, b, both = tmp_path / "a.h5", tmp_path / "b.h5", tmp_path / "both.h5"
    assert run("compress", src / "c0.bvh", src / "c2.bvh", "-o", a, "--codec", "svd").exit_code == 0
    assert run("compress", src / "sub", src / "c2.bvh", "-o", b, "--codec", "svd").exit_code == 0
    r = run("merge", a, b, "-o", both)  # c2 in both, the same bytes: not a clash
    assert r.exit_code == 0, r.output
    merged, parts = read_archive(both), {**read_archive(a), **read_archive(b)}
    assert sorted(merged) == ["c0", "c1", "c2", "c3"]
    from motionrep.io.archive import Archive

    with Archive(both) as m, Archive(a) as pa, Archive(b) as pb:
        for name in m.names:
            assert m.read_bytes(name) == (pa if name in pa.names else pb).read_bytes(name)
    assert set(parts) == set(merged)
    r = run("merge", a, b, "-o", both)
    assert r.exit_code == 1 and "--force" in r.output

    other = tmp_path / "other.h5"  # c0 again, compressed differently
    assert run("compress", src / "c0.bvh", src / "c2.bvh", "-o", other, "--codec", "svd", "--max-error",
               "1%").exit_code == 0
    r = run("merge", a, other, "-o", tmp_path / "x.h5")
    assert r.exit_code == 1 and "clash" in r.output and "c0 (" in r.output and not (tmp_path / "x.h5").exists()
    assert "use --on-clash first|last|prefix" in r.output
    for policy, source in (("first", a), ("last", other)):
        out = tmp_path / f"{policy}.h5"
        assert run("merge", a, other, "-o", out, "--on-clash", policy).exit_code == 0
        with Archive(out) as m, Archive(source) as s:
            assert m.read_bytes("c0") == s.read_bytes("c0")
    out = tmp_path / "prefix.h5"
    assert run("merge", a, other, "-o", out, "--on-clash", "prefix").exit_code == 0
    assert sorted(read_archive(out)) == ["a__c0", "a__c2", "other__c0", "other__c2"]
    _merge_in_python(a, other, tmp_path)
    mrcdir = tmp_path / "mrcdir"
    assert run("merge", a, b, "-o", mrcdir).exit_code == 0
    assert sorted(p.name for p in mrcdir.iterdir()) == ["c0.mrc", "c1.mrc", "c2.mrc", "c3.mrc"]
    assert run("merge", mrcdir, "-o", tmp_path / "again.h5").exit_code == 0
    assert sorted(read_archive(tmp_path / "again.h5")) == ["c0", "c1", "c2", "c3"]


# ---------------------------------------------------------------------------------------------------------------
# signals
# ---------------------------------------------------------------------------------------------------------------
def _start(args: list[str], cwd: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "motionrep", *map(str, args)], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)


def _wait_for(predicate, seconds: float) -> None:
    end = time.monotonic() + seconds
    while not predicate():
        if time.monotonic() > end:
            raise AssertionError("timed out")
        time.sleep(0.05)


def _long_clips(directory: Path, count: int, frames: int = 1500) -> Path:
    directory.mkdir()
    for i in range(count):
        write(synthetic_motion(chain_skeleton(25), frames=frames, fps=120, seed=i), directory / f"c{i:02d}.bvh")
    return directory


def _interrupt(tmp_path: Path, sig: int, jobs: int, group: bool, count: int = 16, frames: int = 1500) -> None:
    from motionrep.batch.store import journal_path

    src = _long_clips(tmp_path / "clips", count, frames)
    out = tmp_path / "out.h5"
    journal = journal_path(out)
    p = _start(["compress", src, "-o", out, "--codec", "svd", "--jobs", jobs], tmp_path)
    try:
        _wait_for(lambda: _committed(journal) or p.poll() is not None, 240)
        assert p.poll() is None, p.communicate()
        os.killpg(p.pid, sig) if group else p.send_signal(sig)
        stdout, stderr = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 128 + sig, stderr
    assert "Traceback" not in stderr and "Error" not in stderr, stderr
    lines = [ln for ln in stderr.strip().splitlines() if not ln.startswith("[")]  # not the progress lines
    assert len(lines) == 1 and lines[0].startswith("Interrupted ("), stderr  # one line
    assert "kept in" in lines[0] and "--resume" in lines[0]
    kept = read_archive(out)
    assert 1 <= len(kept) < count
    _no_temp_files(tmp_path)
    r = run("compress", src, "-o", out, "--codec", "svd", "--resume", "--json")
    statuses = _statuses(r.output)
    assert sum(s == "skipped" for s in statuses.values()) == len(kept)
    assert len(read_archive(out)) == count


def test_sigterm_keeps_finished_clips_and_exits_143(tmp_path):
    _interrupt(tmp_path, signal.SIGTERM, jobs=1, group=False, count=6, frames=600)


@pytest.mark.slow  # two spawned worker processes
def test_ctrl_c_with_two_jobs_one_line_no_traceback(tmp_path):
    _interrupt(tmp_path, signal.SIGINT, jobs=2, group=True)


@pytest.mark.slow  # two spawned worker processes, and a killed client
def test_resume_after_the_client_is_killed(tmp_path):
    from motionrep.batch.store import journal_path

    src = _long_clips(tmp_path / "clips", 10)
    out = tmp_path / "out.h5"
    journal = journal_path(out)
    p = _start(["compress", src, "-o", out, "--codec", "svd", "--jobs", "2"], tmp_path)
    _wait_for(lambda: len(_committed(journal)) >= 2 or p.poll() is not None, 240)
    os.killpg(p.pid, signal.SIGKILL)
    p.communicate()
    done = _committed(journal)
    assert 2 <= len(done) < 10 and not out.exists()
    r = run("compress", src, "-o", out, "--codec", "svd", "--resume", "--jobs", "2", "--json")
    assert r.exit_code == 0, r.output
    statuses = _statuses(r.output)
    assert sorted(n for n, s in statuses.items() if s == "skipped") == done
    assert len(read_archive(out)) == 10 and not journal.exists()
