"""Malformed BVH: a BVHFormatError naming the file and the right line for every case, from the library and
from the command line (exit code 1, one line, no traceback, no output file)."""

from __future__ import annotations

import pytest

from motionrep.errors import BVHFormatError, MotionrepError
from motionrep.io import parse_bvh, read_bvh

from helpers import SHARED_DATA, requires_shared, run_cli_caught

# line numbers of VALID, for reading the cases below
VALID = """HIERARCHY
ROOT Hips
{
\tOFFSET 0 0 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
\tJOINT Chest
\t{
\t\tOFFSET 0 10 0
\t\tCHANNELS 3 Zrotation Xrotation Yrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 5 0
\t\t}
\t}
}
MOTION
Frames: 3
Frame Time: 0.04
0 0 0 0 0 0 0 0 0
1 2 3 90 0 0 0 0 0
0 0 0 0 90 0 -90 0 0
"""
LINES = VALID.split("\n")


def edit(*changes: tuple[int, str | None], append: str = "") -> str:
    """VALID with 1-based lines replaced (None deletes the line), then ``append`` at the end."""
    lines = list(LINES)
    for number, text in sorted(changes, reverse=True):
        if text is None:
            del lines[number - 1]
        else:
            lines[number - 1] = text
    return "\n".join(lines) + append


CASES = {
    # name: (file bytes or text, line, words the message must contain)
    "truncated motion (a frame line missing)": (edit((21, None)), 21, "truncated motion: Frames: 3 but only 2"),
    "truncated in the middle of a line": (VALID[: VALID.index("0 0 0 0 90") + 10], 21, "has 5 values, expected 9"),
    "truncated in the hierarchy": (VALID[: VALID.index("CHANNELS 3")], 8, "never closed before the end of the file"),
    "truncated after the hierarchy": ("\n".join(LINES[:15]) + "\n", 15, "no MOTION section"),
    "no frame lines at all": (edit((19, None), (20, None), (21, None)), 19, "only 0 frame lines"),
    "wrong count of values (fewer)": (edit((20, "1 2 3 90 0 0 0 0")), 20, "has 8 values, expected 9"),
    "wrong count of values (more)": (edit((19, "0 0 0 0 0 0 0 0 0 0")), 19, "has 10 values, expected 9"),
    "unknown channel name": (edit((9, "\t\tCHANNELS 3 Zrotation Wrotation Yrotation")), 9,
                             "unknown channel 'Wrotation'"),
    "channel listed twice": (edit((9, "\t\tCHANNELS 3 Zrotation Zrotation Yrotation")), 9, "listed twice"),
    "CHANNELS count too large": (edit((5, "\tCHANNELS 7 Xposition Yposition Zposition Zrotation Xrotation Yrotation")),
                                 5, "says 7 but lists 6"),
    "CHANNELS count too small": (edit((9, "\t\tCHANNELS 2 Zrotation Xrotation Yrotation")), 9, "says 2 but lists 3"),
    "CHANNELS count missing": (edit((9, "\t\tCHANNELS")), 9, "has no count"),
    "brace never closed": (edit((14, None)), 15, "never closed"),
    "closing brace without opening": (edit((15, "}\n}")), 16, "'}' without a matching '{'"),
    "opening brace twice": (edit((7, "\t{\n\t{")), 8, "unexpected '{'"),
    "no brace after JOINT": (edit((7, "\tOFFSET 1 1 1")), 7, "expected '{' after JOINT Chest"),
    "no ROOT": (edit((2, "JOINT Hips")), 2, "expected ROOT, found 'JOINT'"),
    "no HIERARCHY": (edit((1, "HIERARCHIE")), 1, "expected HIERARCHY"),
    "text in OFFSET": (edit((8, "\t\tOFFSET 0 ten 0")), 8, "expected a number for OFFSET y of Chest, found 'ten'"),
    "OFFSET too short": (edit((8, "\t\tOFFSET 0 10")), 9, "expected a number for OFFSET z of Chest, found 'CHANNELS'"),
    "text as CHANNELS count": (edit((9, "\t\tCHANNELS three Zrotation Xrotation Yrotation")), 9,
                               "CHANNELS count of Chest must be an integer, found 'three'"),
    "text as Frames": (edit((17, "Frames: many")), 17, "Frames must be a whole number, found 'many'"),
    "fraction as Frames": (edit((17, "Frames: 3.0")), 17, "Frames must be a whole number, found '3.0'"),
    "underscore in Frames": (edit((17, "Frames: 0_3")), 17, "Frames must be a whole number, found '0_3'"),
    "underscore in OFFSET": (edit((8, "\t\tOFFSET 0 1_0 0")), 8,
                             "expected a number for OFFSET y of Chest, found '1_0'"),
    "other script's digit": (edit((9, "\t\tCHANNELS \uff13 Zrotation Xrotation Yrotation")), 9,
                             "CHANNELS count of Chest must be an integer"),
    "underscore in frame values": (edit((20, "1 2 3 9_0 0 0 0 0 0")), 20, "expected a number, found '9_0'"),
    "text as Frame Time": (edit((18, "Frame Time: fast")), 18, "Frame Time must be a number, found 'fast'"),
    "text in frame values": (edit((20, "1 2 x 90 0 0 0 0 0")), 20, "expected a number, found 'x'"),
    "junk glued to a number": (edit((21, "0 0 0 0 90 0 -90 0 0abc")), 21, "found '0abc'"),
    "NaN in OFFSET": (edit((12, "\t\t\tOFFSET 0 nan 0")), 12, "OFFSET y of End Site of Chest must be finite"),
    "inf in OFFSET": (edit((4, "\tOFFSET inf 0 0")), 4, "OFFSET x of Hips must be finite, found 'inf'"),
    "NaN in frame values": (edit((21, "0 0 0 0 90 0 -90 NaN 0")), 21, "'NaN' is not a finite number"),
    "inf in frame values": (edit((19, "0 0 0 -inf 0 0 0 0 0")), 19, "'-inf' is not a finite number"),
    "overflow in frame values": (edit((20, "1 2 3 1e999 0 0 0 0 0")), 20, "'1e999' is not a finite number"),
    "zero Frame Time": (edit((18, "Frame Time: 0")), 18, "Frame Time must be a finite number > 0, found '0'"),
    "negative Frame Time": (edit((18, "Frame Time: -0.04")), 18, "found '-0.04'"),
    "infinite Frame Time": (edit((18, "Frame Time: inf")), 18, "found 'inf'"),
    "Frames more than the lines": (edit((17, "Frames: 4")), 22, "truncated motion: Frames: 4 but only 3"),
    "Frames fewer than the lines": (edit((17, "Frames: 2")), 21, "more frame lines than Frames: 2"),
    "Frames: 0": (edit((17, "Frames: 0")), 17, "Frames must be at least 1, found 0"),
    "negative Frames": (edit((17, "Frames: -3")), 17, "Frames must be at least 1, found -3"),
    "missing Frames line": (edit((17, None)), 17, "expected 'Frames: <value>', found 'Frame Time: 0.04'"),
    "missing Frame Time line": (edit((18, None)), 18, "expected 'Frame Time: <value>', found '0 0 0"),
    "junk after Frames": (edit((17, "Frames: 3 frames")), 17, "unexpected 'frames' after Frames"),
    "MOTION without anything after it": ("\n".join(LINES[:16]) + "\n", 16, "missing 'Frames:' line after MOTION"),
    "duplicate joint names": (edit((6, "\tJOINT Hips")), 6, "duplicate joint name 'Hips' (first defined at line 2)"),
    "empty file": ("", 1, "file is empty"),
    "whitespace-only file": (" \n\t\n  \r\n", 1, "file is empty"),
    "binary garbage": (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", 1, "not a text file: invalid UTF-8 byte 0x89"),
    "control bytes": (edit((3, "{\x00")).encode(), 3, "not a text file: control byte 0x00"),
    "invalid UTF-8 in a name": (edit((6, "\tJOINT Ch\xffest")).encode("latin-1"), 6, "invalid UTF-8 byte 0xff"),
    "missing MOTION section": ("\n".join(LINES[:15]) + "\n\n", 15, "no MOTION section"),
    "Frames: 0 with no lines": ("\n".join(LINES[:16]) + "\nFrames: 0\nFrame Time: 0.04\n", 17, "at least 1"),
    "a second ROOT": (edit((15, "}\nROOT Other\n{\n\tOFFSET 0 0 0\n\tCHANNELS 0\n}")), 16, "more than one ROOT"),
    "End Site without OFFSET": (edit((12, None)), 12, "expected OFFSET in End Site of Chest, found '}'"),
    "End Site not closed": (edit((13, None)), 15, "ROOT Hips (line 2) is never closed before MOTION"),
    "End Site without braces": (edit((11, None), (13, None)), 11, "expected '{' after End Site, found 'OFFSET'"),
    "End without Site": (edit((10, "\t\tEnd")), 10, "expected 'End Site'"),
    "JOINT without a name": (edit((6, "\tJOINT")), 6, "JOINT without a name"),
    "JOINT without OFFSET": (edit((8, None)), 6, "JOINT Chest has no OFFSET"),
    "JOINT without CHANNELS": (edit((9, None)), 6, "JOINT Chest has no CHANNELS line"),
    "second OFFSET": (edit((9, "\t\tOFFSET 1 1 1\n\t\tCHANNELS 3 Zrotation Xrotation Yrotation")), 9, "second OFFSET"),
    "unexpected keyword": (edit((10, "\t\tEndSite")), 10, "unexpected 'EndSite' in JOINT Chest"),
}


def _as_bytes(content) -> bytes:
    return content if isinstance(content, bytes) else content.encode("utf-8")


@pytest.mark.parametrize("name", list(CASES))
def test_malformed_names_file_and_line(name, tmp_path):
    content, line, words = CASES[name]
    path = tmp_path / "bad file.bvh"
    path.write_bytes(_as_bytes(content))
    with pytest.raises(BVHFormatError) as info:
        read_bvh(path)
    err = info.value
    assert isinstance(err, MotionrepError)
    assert err.path == str(path)
    assert err.line == line, f"{name}: reported line {err.line}, expected {line}: {err}"
    assert words in err.message, f"{name}: {err.message!r}"
    assert str(err) == f"{path}:{line}: {err.message}"
    assert "\n" not in str(err)
    # from memory: the same line, "<memory>" for the name
    with pytest.raises(BVHFormatError) as info:
        parse_bvh(_as_bytes(content))
    assert info.value.line == line and str(info.value).startswith(f"<memory>:{line}: ")


def test_nesting_too_deep_is_a_format_error():
    depth = 1500
    text = "HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\nCHANNELS 0\n"
    text += "".join(f"JOINT j{k}\n{{\nOFFSET 0 1 0\nCHANNELS 0\n" for k in range(1, depth))
    text += "}\n" * depth + "MOTION\nFrames: 1\nFrame Time: 0.1\n\n"
    with pytest.raises(BVHFormatError, match="nested too deeply") as info:
        parse_bvh(text, "deep.bvh")
    assert info.value.line is not None and 1 < info.value.line < 4 * depth


def test_valid_base_reads():
    assert parse_bvh(VALID).num_frames == 3


def test_missing_file(tmp_path):
    with pytest.raises(BVHFormatError, match="cannot read file") as info:
        read_bvh(tmp_path / "nope.bvh")
    assert info.value.path == str(tmp_path / "nope.bvh")


@requires_shared
@pytest.mark.realdata
@pytest.mark.parametrize("name, line, words", [
    ("bvh-python_t-pose.bvh", 2, "expected ROOT, found 'JOINT'"),
    ("bvhio_bar.bvh", 135, "truncated motion: Frames: 3066 but only 0 frame lines"),
])
def test_real_malformed_files(name, line, words):
    path = SHARED_DATA / "edge" / "malformed" / name
    with pytest.raises(BVHFormatError) as info:
        read_bvh(path)
    assert info.value.line == line and words in info.value.message
    assert str(info.value).startswith(f"{path}:{line}: ")


@pytest.mark.parametrize("name", list(CASES))
def test_malformed_from_the_command_line(name, tmp_path):

    content, line, words = CASES[name]
    src = tmp_path / "in.bvh"
    src.write_bytes(_as_bytes(content))
    out = tmp_path / "out.bvh"
    result = run_cli_caught("convert", str(src), str(out))
    assert result.exit_code == 1, result.output
    assert "Traceback" not in result.output
    errors = [ln for ln in result.output.splitlines() if ln.startswith("Error: ")]
    assert len(errors) == 1 and errors[0].startswith(f"Error: {src}:{line}: "), result.output
    assert words in errors[0]
    assert not out.exists()
