"""Progress with an ETA on long work (issue 26): the batch heartbeat while no clip finishes, the codec's progress
inside one clip (the Fourier codecs' training, through the ``context.progress`` hook) with an ETA."""

from __future__ import annotations

import io
import time

import pytest

from motionrep.cli._common import BatchProgress, CodecProgress
from motionrep.model.synthetic import chain_skeleton, synthetic_motion
from helpers import run_cli_caught


def test_the_heartbeat_prints_while_no_item_finishes():
    stream = io.StringIO()
    with BatchProgress(3, "compressing", lambda x: f"clip {x}", every=0.3, stream=stream) as bar:
        bar.note("c0", "train K=3 loss=1e-3")
        time.sleep(1.2)  # nothing finishes for four periods
        quiet_part = stream.getvalue()
        bar.done("c0")
        bar.done("c1")
        bar.done("c2")
    beats = [line for line in quiet_part.splitlines() if line.startswith("[0/3] working")]
    assert len(beats) >= 2, quiet_part  # one every 0.3 s, whatever the thread's timing (at least 2 in 1.2 s)
    assert "elapsed" in beats[0] and "ETA" in beats[0] and beats[0].endswith("; c0: train K=3 loss=1e-3")
    after = stream.getvalue()
    time.sleep(0.5)
    assert stream.getvalue() == after  # the heartbeat stopped with the bar


def test_no_heartbeat_when_quiet():
    stream = io.StringIO()
    with BatchProgress(2, "x", every=0.1, stream=stream, quiet=True):
        time.sleep(0.4)
    assert stream.getvalue() == ""


def test_codec_progress_gives_an_upper_bound_eta_from_done():
    from motionrep.plugin.registry import get_codec

    clock = CodecProgress(get_codec("adaptive-fourier"))
    first = clock.text("train", {"K": 0, "done": 0.1})
    assert "10%" in first and "ETA" not in first  # no time measured yet
    time.sleep(0.2)
    line = clock.text("train", {"K": 2, "done": 0.5})
    assert "50%" in line and "ETA at most" in line
    clock.text("train", {"K": 0, "done": 0.01})  # a new fit (a window): the clock starts again
    assert clock.start == pytest.approx(time.monotonic(), abs=0.1)


def test_fourier_training_reports_its_progress_through_the_hook():
    """The plugin reports through ``context.progress`` (never prints): ``done`` grows from 0 to at most 1
    within each fit."""
    from motionrep.pipeline.compress import compress_motion

    seen = []
    motion = synthetic_motion(chain_skeleton(4), frames=40, fps=30, seed=3)
    compress_motion(motion, "adaptive-fourier", max_error="5%", params={"max_k": 4},
                    progress=lambda stage, fields: seen.append((stage, dict(fields))))
    done = [f["done"] for stage, f in seen if stage == "train"]
    assert done and all(0.0 <= d <= 1.0 for d in done)
    assert done == sorted(done)  # one network: the share only grows


def _heartbeats(tmp_path, monkeypatch, *extra: str) -> list[str]:
    """The heartbeat lines of a two-clip adaptive-fourier batch (one heartbeat every 0.3 s)."""

    from motionrep.io import write

    (tmp_path / "in").mkdir()
    for i in range(2):
        write(synthetic_motion(chain_skeleton(4), frames=120, fps=30, seed=i), tmp_path / "in" / f"c{i}.bvh")
    monkeypatch.setenv("MOTIONREP_PROGRESS_SECONDS", "0.3")
    r = run_cli_caught("compress", str(tmp_path / "in"), "-o", str(tmp_path / "out.h5"), "--codec",
                                 "adaptive-fourier", "--max-error", "none", "-p", "k=6", *extra)
    assert r.exit_code == 0, r.output
    return [line for line in r.stderr.splitlines() if "working" in line and "elapsed" in line]


def test_a_batch_in_this_process_shows_the_codec_progress_in_its_heartbeat(tmp_path, monkeypatch):
    beats = _heartbeats(tmp_path, monkeypatch, "-p", "iters=4000")
    assert beats and any("c0: train" in b for b in beats), beats


@pytest.mark.slow  # worker processes; the heartbeat of work in this process is the fast test above
def test_worker_processes_relay_the_codec_progress_to_the_heartbeat(tmp_path, monkeypatch):
    """`--jobs 2`: the workers' codec progress reaches the client through the pool's relay queue."""
    beats = _heartbeats(tmp_path, monkeypatch, "-p", "iters=6000", "--jobs", "2")
    assert any(": train " in b for b in beats), beats


def test_worker_progress_pickles_and_is_silent_without_a_relay():
    import pickle

    from motionrep.batch.executors import WorkerProgress

    relay = pickle.loads(pickle.dumps(WorkerProgress()))
    relay("c0", "train", {"K": 1})  # no queue in this process: nothing happens, nothing raises


def test_on_a_terminal_the_count_is_a_click_progress_bar_with_an_eta():
    import re

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    term = Terminal()
    with BatchProgress(4, "compressing", lambda x: f"clip {x} failed", every=0.0, stream=term) as bar:
        bar.done("a")
        time.sleep(1.1)  # click measures its ETA once a second
        bar.done("b", failed=True)
        bar.note("c", "train K=1")
        bar.done("c")
        bar.done("d")
    text = term.getvalue()
    assert "compressing  [" in text and "1/4" in text and "4/4" in text, text
    assert re.search(r"2/4  \d\d:\d\d:\d\d  1 failed, [0-9.]+/s", text), text  # position, click's ETA, the tail
    assert "\r\x1b[Kclip b failed\n" in text  # a failure on its own line above the bar
    assert text.endswith("\n")  # click ends its bar


def test_convert_and_render_share_the_one_mechanism():
    """Both draw through BatchProgress (no second style): convert's clips and render's frames."""
    from pathlib import Path

    import motionrep.cli.convert as convert
    import motionrep.cli.render as render

    for module in (convert, render):
        source = Path(module.__file__).read_text(encoding="utf-8")
        assert "BatchProgress(" in source and "progressbar(" not in source, module.__name__
