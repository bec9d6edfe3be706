"""Mutated BVH text fed to parse_bvh gives a Motion or a MotionrepError -- never any other exception."""

from __future__ import annotations

import re

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motionrep import Motion
from motionrep.errors import BVHFormatError, MotionrepError
from motionrep.io import parse_bvh

BASE = """HIERARCHY
ROOT mixamorig:Hips
{
\tOFFSET 1.5 90 -2
\tCHANNELS 6 Xposition Yposition Zposition Yrotation Xrotation Zrotation
\tJOINT Spine {
\t\tOFFSET 0 10 0
\t\tCHANNELS 5 Xposition Yposition Zposition Xrotation Zrotation
\t\tJOINT Head
\t\t{
\t\t\tOFFSET 0 8 0
\t\t\tCHANNELS 0
\t\t\tEnd Site
\t\t\t{
\t\t\t\tOFFSET 0 9 0
\t\t\t}
\t\t}
\t}
\tJOINT Left Leg
\t{
\t\tOFFSET 4 -5 0
\t\tCHANNELS 2 Yrotation Yposition
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 -40 0
\t\t}
\t}
}
MOTION
Frames: 3
Frame Time: 0.0333333
1.5 90 -2 10 -20 30.5 0 10 0 5 -5 12 3.5
1.6 91 -2.1 12 -21 31.5 0.1 10 0.2 6 -6 13 4.5e-1
1.7 92 -2.2 14 -22 32.5 0.2 10 0.4 7 -7 14 -5.25E+0
"""

WORDS = ["ROOT", "JOINT", "End", "Site", "{", "}", "OFFSET", "CHANNELS", "MOTION", "Frames:", "Frame", "Time:",
         "Xrotation", "Yposition", "HIERARCHY", "nan", "inf", "-", ".", "1e999", "abc", "0", "-0", "3", "1e5",
         "\ufeff", "\t", "\r", "\r\n", "é", "mixamorig:Hips"]
GARBAGE = st.binary(min_size=1, max_size=8)


def _tokens(text: str) -> list[str]:
    return re.split(r"(\s+)", text)  # words and the whitespace between them, so joining gives the text back


@st.composite
def mutated(draw) -> bytes:
    text = BASE
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["delete-token", "duplicate-token", "replace-token", "number-to-word",
                                     "delete-line", "duplicate-line", "swap-lines", "garbage", "truncate"]))
        if kind in ("delete-token", "duplicate-token", "replace-token", "number-to-word"):
            parts = _tokens(text)
            words = [i for i, p in enumerate(parts) if p and not p.isspace()]
            if kind == "number-to-word":
                numbers = [i for i in words if re.fullmatch(r"[-+0-9.eE]+", parts[i])] or words
                i = draw(st.sampled_from(numbers))
                parts[i] = draw(st.sampled_from(["one", "x", "NaN", "inf", "1.2.3", "--4", "", "0x10", "1_0"]))
            else:
                i = draw(st.sampled_from(words))
                if kind == "delete-token":
                    parts[i] = ""
                elif kind == "duplicate-token":
                    parts[i] = parts[i] + " " + parts[i]
                else:
                    parts[i] = draw(st.sampled_from(WORDS))
            text = "".join(parts)
        elif kind in ("delete-line", "duplicate-line", "swap-lines"):
            lines = text.split("\n")
            i = draw(st.integers(0, len(lines) - 1))
            if kind == "delete-line":
                del lines[i]
            elif kind == "duplicate-line":
                lines.insert(i, lines[i])
            else:
                j = draw(st.integers(0, len(lines) - 1))
                lines[i], lines[j] = lines[j], lines[i]
            text = "\n".join(lines)
        elif kind == "garbage":
            data = text.encode("utf-8")
            at = draw(st.integers(0, len(data)))
            return data[:at] + draw(GARBAGE) + data[at:]
        else:
            data = text.encode("utf-8")
            return data[: draw(st.integers(0, len(data)))]
    return text.encode("utf-8")


def test_base_is_valid():
    m = parse_bvh(BASE)
    assert m.num_frames == 3 and m.skeleton.names[-1] == "Left Leg"


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated())
def test_mutated_text_gives_a_motion_or_a_motionrep_error(data):
    try:
        motion = parse_bvh(data, "fuzz.bvh")
    except BVHFormatError as exc:
        assert exc.path == "fuzz.bvh"
        assert exc.line is None or 1 <= exc.line <= data.count(b"\n") + 2
        assert "\n" not in str(exc)
        return
    except MotionrepError:
        return
    assert isinstance(motion, Motion)
    assert np.all(np.isfinite(motion.rotations)) and np.all(np.isfinite(motion.root_translation))
