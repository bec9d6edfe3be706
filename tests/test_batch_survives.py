"""A batch survives its worst clip (issue 27): whatever one clip raises -- motionrep's errors, a bug's
TypeError, MemoryError, RecursionError -- or a worker process that dies, in-process (``jobs=1``) and in worker
processes (``jobs=2``), is that clip's reported failure; the others are compressed."""

from __future__ import annotations

import os
import types

import pytest

import motionrep
from motionrep.batch.engine import compress_clips, run_batch
from motionrep.pipeline.sources import ClipRef
from motionrep.model.synthetic import synthetic_motion
from helpers import run_cli_caught

#: frames of a clip -> what compressing it does (module level: worker processes import this module)
_RAISES = {11: MemoryError, 12: TypeError, 14: RecursionError, 16: KeyError}
_CRASH = 13


class FlakyPipeline:
    """A pipeline that fails in a chosen way for clips of some frame counts, else compresses with transform."""

    codec = types.SimpleNamespace(name="transform")

    def __init__(self, crash: bool):
        self.crash = crash

    def compress(self, motion, **kwargs):
        kind = _RAISES.get(motion.num_frames)
        if kind is not None:
            raise kind(f"crafted failure for {motion.num_frames} frames")
        if motion.num_frames == _CRASH and self.crash:
            os._exit(3)  # a worker dying (as the out-of-memory killer would kill it)
        from motionrep.pipeline.compress import Pipeline

        return Pipeline.build("transform").compress(motion, **kwargs)


def _clips(tmp_path, frames):
    refs = []
    for f in frames:
        path = tmp_path / f"clip{f}.bvh"
        motionrep.write(synthetic_motion(frames=f, seed=f), path)
        refs.append(ClipRef(path.stem, str(path)))
    return refs


# worker processes in the slow run; the fast smoke test of a dying worker is the broken-pool test below
@pytest.mark.parametrize("jobs", [1, pytest.param(2, marks=pytest.mark.slow)])
def test_every_kind_of_failure_is_one_clips_failure(tmp_path, jobs):
    frames = [10, 11, 12, 13, 14, 15, 16, 17]
    refs = _clips(tmp_path, frames)
    outcomes = compress_clips(refs, FlakyPipeline(crash=jobs > 1), jobs=jobs)
    status = {o.name: o.status for o in outcomes}
    failed = {f"clip{f}" for f in _RAISES} | ({f"clip{_CRASH}"} if jobs > 1 else set())
    assert {n for n, s in status.items() if s == "failed"} == failed
    assert all(status[n] == "done" for n in status if n not in failed)
    for o in outcomes:
        if o.failed:
            assert o.summary["source"] in o.summary["error"] and "\n" not in o.summary["error"]
    memory = next(o for o in outcomes if o.name == "clip11")
    assert "not enough memory" in memory.summary["error"]
    if jobs > 1:
        crash = next(o for o in outcomes if o.name == f"clip{_CRASH}")
        assert "worker process died" in crash.summary["error"]


def _work(x):
    if x == 3:
        os._exit(1)
    if x == 5:
        raise ValueError("five")
    return x * 10


def test_run_batch_restarts_a_broken_pool_and_isolates_the_culprit():
    out = run_batch(_work, range(8), jobs=2, on_error=lambda item, exc: f"failed {item} {type(exc).__name__}")
    assert out == [0, 10, 20, "failed 3 BrokenProcessPool", 40, "failed 5 ValueError", 60, 70]


def test_run_batch_without_on_error_still_raises():
    with pytest.raises(ValueError):
        run_batch(_work, [5], jobs=1)


def test_cli_compress_dir_goes_on_after_a_bad_clip(tmp_path):


    src = tmp_path / "in"
    src.mkdir()
    _clips(src, [10, 12])
    (src / "bad.bvh").write_text("HIERARCHY\nROOT a\n{\n")
    result = run_cli_caught("compress", str(src), "-o", str(tmp_path / "out") + "/", "--jobs", "1")
    assert result.exit_code == 1, result.output
    assert "1 of 3 clips failed" in result.output
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["clip10.mrc", "clip12.mrc"]


def test_the_outcome_of_a_clip_is_typed(tmp_path):
    """What crosses the process boundary is a ClipOutcome carrying the CompressResult (or a ClipFailure), read
    through its fields; ``summary`` is the one place it becomes JSON."""
    from motionrep.batch.engine import ClipFailure, ClipOutcome
    from motionrep.pipeline.compress import CompressResult, Pipeline

    refs = _clips(tmp_path, [10, 11])
    done, failed = compress_clips(refs, FlakyPipeline(crash=False))
    assert isinstance(done, ClipOutcome) and isinstance(done.result, CompressResult) and done.failure is None
    assert done.data == done.result.data and done.source == refs[0].source and len(done.source_sha256) == 64
    assert done.summary["bytes"] == len(done.data) and done.summary["source_sha256"] == done.source_sha256
    assert failed.result is None and failed.failure == ClipFailure(failed.failure.message, "MemoryError")
    assert failed.summary["type"] == "MemoryError" and failed.data is None
    unbounded = compress_clips(refs[:1], Pipeline.build("svd", max_error=None))[0]
    assert unbounded.failure.type == "ParameterError" and unbounded.failure.parameters == ("max_error=None",)
    assert "max_error=None" in unbounded.failure.message  # a library error names the parameter; the CLI, the flag


def _sleeps(x):
    import time

    if x == 1:
        time.sleep(120)  # one call, in C: no exception raised in this thread could stop it before it returns
    return x


@pytest.mark.slow  # starts worker processes
def test_a_worker_over_its_time_limit_is_killed_even_inside_compiled_code():
    import time

    from motionrep.errors import TimeLimitError

    start = time.monotonic()
    out = run_batch(_sleeps, [0, 1, 2, 3], jobs=2, timeout=1.0, on_error=lambda item, exc: exc)
    assert out[0] == 0 and out[2:] == [2, 3]
    assert isinstance(out[1], TimeLimitError) and "time limit of 1 s (timeout=)" in str(out[1])
    assert time.monotonic() - start < 60  # the sleeping worker was killed, not waited for
