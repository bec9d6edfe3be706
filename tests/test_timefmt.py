"""motionrep.model.timefmt: one definition of duration, rates written as the file states them (issue 26)."""

from __future__ import annotations

import pytest

from motionrep.errors import ValidationError
from motionrep.model.synthetic import humanoid_skeleton, synthetic_motion
from motionrep.model.timefmt import (duration, duration_text, fps_text, frame_time, frame_time_text, rate_text,
                               seconds_text)
from helpers import run_cli_caught


def test_duration_is_frames_times_frame_time_everywhere():
    assert duration(120, 30.0) == 4.0 and duration(0, 30.0) == 0.0 and duration(1, 10.0) == 0.1
    motion = synthetic_motion(humanoid_skeleton(), frames=45, fps=30.0)
    assert motion.duration == duration(motion.num_frames, motion.fps) == 1.5


@pytest.mark.parametrize("fps, rate, frame", [
    (1 / 0.008333, "120", "0.008333"),  # BVH "Frame Time: 0.008333" means 120 fps, not 120.005
    (1 / 0.0333333, "30", "0.0333333"),
    (30.0, "30", "0.03333333"),  # a rate stored as a number: the frame time to 7 significant digits
    (29.97, "29.97", "0.0333667"),
    (30000 / 1001, "29.97", "0.03336667"),
    (24000 / 1001, "23.976", "0.04170833"),
    (1 / 0.016667, "60", "0.016667"),
    (7.5, "7.5", "0.1333333"),
    (25.0, "25", "0.04"),
    (0.5, "0.5", "2"),
])
def test_rates_as_the_file_states_them(fps, rate, frame):
    assert fps_text(fps) == rate
    assert frame_time_text(fps) == frame
    assert rate_text(fps) == f"{rate} fps (frame time {frame} s)"


def test_a_rate_that_differs_from_a_round_one_shows_the_difference():
    assert fps_text(120.4) == "120.4" and fps_text(119.88) == "119.88"


def test_frame_time_gives_the_stated_value_back():
    assert frame_time(1 / 0.008333) == 0.008333 and frame_time(100.0) == 0.01


def test_seconds_to_the_millisecond():
    assert duration_text(885, 1 / 0.008333) == "7.375 s"  # not 7.37471 s
    assert seconds_text(4.0) == "4 s" and seconds_text(0.5) == "0.5 s" and seconds_text(0.0) == "0 s"
    assert seconds_text(754.2) == "754.2 s (12 min 34.2 s)"


@pytest.mark.parametrize("bad", [0, -1.0, float("nan"), float("inf"), "x", None])
def test_bad_rates_are_refused(bad):
    with pytest.raises(ValidationError, match="frame rate"):
        fps_text(bad)


def test_info_and_compress_show_the_stated_frame_time(tmp_path):
    """A BVH with `Frame Time: 0.008333`: info says 120 fps and the duration to the millisecond, as does compress."""
    import re


    from motionrep.io import write

    path = tmp_path / "clip.bvh"
    write(synthetic_motion(humanoid_skeleton(), frames=885, fps=120.0), path)
    path.write_text(re.sub(r"Frame Time:.*", "Frame Time: 0.008333", path.read_text()))
    r = run_cli_caught("info", str(path))
    assert r.exit_code == 0, r.output
    lines = r.output.splitlines()
    assert "fps:        120 (frame time 0.008333 s)" in lines and "duration:   7.375 s" in lines
    r = run_cli_caught("compress", str(path), "-o", str(tmp_path / "c.mrc"), "--codec", "svd",
                                 "-p", "rank=2", "--max-error", "none")
    assert r.exit_code == 0, r.output
    assert "885 frames at 120 fps (7.375 s)" in r.output and "120.005" not in r.output
