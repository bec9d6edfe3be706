"""BVH reading and writing: real files, hand-written fixtures with known answers, BVH -> BVH round trips that
reproduce channel values and FK positions, the writer's layout and options, and the exact number parser."""

from __future__ import annotations

import io
import os

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from motionrep import Motion, Skeleton
from motionrep.model._pose import DEFAULT_JOINT_CHANNELS, DEFAULT_ROOT_CHANNELS
from motionrep.errors import ValidationError
from motionrep.io import format_bvh, parse_bvh, read_bvh, write_bvh
from motionrep.io._bvh import _format_fixed, channel_values
from motionrep.io._numbers import parse_numbers
from motionrep.model.kinematics import character_height, global_positions
from motionrep.model.rotations import euler_to_quat
from motionrep.model.synthetic import humanoid_skeleton, synthetic_motion

from helpers import real_params, run_cli_caught


# ---- helpers ---------------------------------------------------------------------------------------------------
def source_values(text: str) -> np.ndarray:
    """The frame values of BVH text, parsed independently of motionrep (np.loadtxt of the frame lines)."""
    text = text.replace("\r\n", "\n").replace("\r", "\n")
    lines = text.split("\n")
    k = next(i for i, line in enumerate(lines) if line.strip().startswith("Frame Time"))
    frames = int(next(line for line in lines if line.strip().startswith("Frames")).split(":")[1])
    block = "\n".join(lines[k + 1:])
    values = np.loadtxt(io.StringIO(block), ndmin=2) if block.strip() else np.zeros((frames, 0))
    assert values.shape[0] == frames
    return values


def frame_values(data: bytes) -> np.ndarray:
    """Every frame value of BVH bytes, each exactly ``float(token)`` (the bulk parser, itself tested against
    ``float`` below)."""
    data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    start = data.index(b"\n", data.index(b"Frame Time")) + 1
    values, bad = parse_numbers(data[start:])
    assert bad is None
    return values


def rotation_columns(skeleton: Skeleton) -> np.ndarray:
    return np.array([c.endswith("rotation") for ch in skeleton.channels for c in ch], bool)


def gimbal_free(skeleton: Skeleton, values: np.ndarray, margin: float = 1e-3) -> np.ndarray:
    """``(F, C)`` mask of the rotation values away from gimbal lock (three-axis joints only)."""
    ok = np.ones(values.shape, bool)
    col = 0
    for chans, order in zip(skeleton.channels, skeleton.rotation_orders):
        rot = [col + i for i, c in enumerate(chans) if c.endswith("rotation")]
        if len(order) == 3:
            middle = np.deg2rad(values[:, rot[1]])
            near = (np.abs(np.sin(middle)) if order[0] == order[2] else np.abs(np.cos(middle))) < np.deg2rad(margin)
            ok[near[:, None] & np.isin(np.arange(values.shape[1]), rot)[None]] = False
        col += len(chans)
    return ok


def assert_channels_match(skeleton: Skeleton, got: np.ndarray, want: np.ndarray, atol: float = 1e-6) -> None:
    """Position channels equal, rotation channels equal modulo 360 (away from gimbal lock)."""
    assert got.shape == want.shape
    diff = got - want
    rot = rotation_columns(skeleton)
    diff[:, rot] = (diff[:, rot] + 180.0) % 360.0 - 180.0
    mask = gimbal_free(skeleton, want)
    worst = np.abs(np.where(mask, diff, 0.0)).max(initial=0.0)
    assert worst <= atol, f"channel values differ by {worst:.3g}"


def assert_same_pose(a: Motion, b: Motion, tol_fraction: float = 1e-6) -> None:
    assert a.skeleton.names == b.skeleton.names
    height = max(character_height(a.skeleton), 1e-9)
    err = np.abs(global_positions(a) - global_positions(b)).max() / height
    assert err <= tol_fraction, f"FK positions differ by {err:.3g} x height"


def expected_local_pose(skeleton: Skeleton, values: np.ndarray):
    """Local rotations (scipy) and translations per joint from channel values, by the documented rules:
    rotation channels are intrinsic Euler angles in the listed order (degrees); a position channel replaces
    that axis of the joint's OFFSET."""
    F = values.shape[0]
    rots, trans = [], []
    col = 0
    for j, chans in enumerate(skeleton.channels):
        t = np.broadcast_to(skeleton.offsets[j], (F, 3)).copy()
        axes, angles = "", []
        for c in chans:
            if c.endswith("position"):
                t[:, "XYZ".index(c[0])] = values[:, col]
            else:
                axes += c[0]
                angles.append(values[:, col])
            col += 1
        rots.append(Rotation.from_euler(axes, np.stack(angles, -1), degrees=True) if axes
                    else Rotation.identity(F))
        trans.append(t)
    return rots, np.stack(trans, axis=1)


def check_reader_semantics(motion: Motion, values: np.ndarray) -> None:
    rots, trans = expected_local_pose(motion.skeleton, values)
    np.testing.assert_allclose(motion.local_translations(), trans, atol=1e-12)
    for j, r in enumerate(rots):
        q, want = motion.rotations[:, j], r.as_quat()
        d = np.minimum(np.abs(q - want).max(-1), np.abs(q + want).max(-1))
        assert d.max() <= 1e-12, motion.skeleton.names[j]


# ---- real files --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("path", real_params())
def test_real_file_reads_and_round_trips(path):
    text = path.read_bytes().decode("utf-8-sig")
    motion = read_bvh(path)
    src = source_values(text)
    sk = motion.skeleton
    assert src.shape == (motion.num_frames, sk.num_channels)
    assert motion.fps > 0 and np.isfinite(motion.fps)
    # reading: the channel values come back (no rounding at all here)
    assert_channels_match(sk, channel_values(motion), src, atol=1e-9)
    # BVH -> BVH -> BVH: every channel value bit for bit (the file's own angles: full turns beyond +-180, the
    # Euler branch, signs of zero), the frame rate, and the text is stable from the first rewrite on
    text2 = format_bvh(motion)
    again = parse_bvh(text2)
    assert again.skeleton == sk
    assert again.fps == motion.fps
    assert np.array_equal(frame_values(text2.encode()).view(np.uint64), frame_values(path.read_bytes()).view(np.uint64))
    text3 = format_bvh(again)
    assert text3 == text2
    assert_same_pose(motion, again, 1e-12)


@pytest.mark.parametrize("path", real_params())
def test_number_parser_is_bit_identical_to_float_on_real_files(path):
    data = path.read_bytes()
    start = data.index(b"\n", data.index(b"Frame Time")) + 1
    values, bad = parse_numbers(data[start:])
    assert bad is None
    want = np.array([float(t) for t in data[start:].split()])
    assert np.array_equal(values.view(np.uint64), want.view(np.uint64))  # bit for bit, signs of zero included


def test_number_parser_on_every_syntax():
    tokens = ["0", "-0", "+0", "-0.000000", "1", "12.5", "-12.5", "+12.5", ".5", "-.5", "5.", "-5.", "007.250",
              "123456789012345", "1234567890123456", "12345678901234567890", "0.1", "0.30000000000000004",
              "3.14159265358979323846", "9007199254740993", "-9.23872e-007", "5.1072e-06", "1E5", "1e+05", "-2.5E-1",
              "1.e3", ".5e1", "1e22", "1e-22", "1e23", "4.9e-324", "1e-400", "1.7976931348623157e308", "nan", "-inf",
              "Infinity", "123.456789012345678"]
    text = " ".join(tokens).encode()
    values, bad = parse_numbers(text)
    assert bad is None
    want = np.array([float(t) for t in tokens])
    same = (values.view(np.uint64) == want.view(np.uint64)) | (np.isnan(values) & np.isnan(want))
    assert same.all(), [t for t, s in zip(tokens, same) if not s]
    for junk in ["1_000", "0x10", "1e", "e1", ".", "-", "+.", "1.2.3", "--1", "1-2", "12a", "\u0663".encode().decode()]:
        _, bad = parse_numbers(f"1.5 {junk} 2".encode())
        assert bad == 1, junk


@pytest.mark.parametrize("decimals", range(0, 17))
def test_number_parser_fixed_decimals(decimals):
    # every token with the same number of decimals (the common case, parsed with one '.' column), random signs
    # and integer digits, some too long for the fast path; more than one chunk of tokens
    rng = np.random.default_rng(decimals)
    n = 20000
    ints = rng.integers(0, 10 ** rng.integers(1, 9, n))
    fracs = rng.integers(0, 10 ** min(decimals, 18), n) if decimals else np.zeros(n, int)
    signs = rng.choice(["", "-", "+"], n, p=[0.5, 0.45, 0.05])
    tokens = [f"{s}{i}.{f:0{decimals}d}" if decimals else f"{s}{i}." for s, i, f in zip(signs, ints, fracs)]
    tokens[5] = "-0." + "0" * decimals
    tokens[7] = "7" if decimals % 2 else ".5"  # odd ones out
    text = "\n".join(" ".join(tokens[k:k + 50]) for k in range(0, n, 50)).encode()
    values, bad = parse_numbers(text)
    assert bad is None
    want = np.array([float(t) for t in tokens])
    assert np.array_equal(values.view(np.uint64), want.view(np.uint64))


# ---- hand-written fixtures -------------------------------------------------------------------------------------
ANALYTIC = """HIERARCHY
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


def test_analytic_fixture():
    m = parse_bvh(ANALYTIC, "analytic.bvh")
    assert m.num_frames == 3 and m.fps == pytest.approx(25.0)
    assert m.skeleton.names == ("Hips", "Chest")
    pos = global_positions(m)
    np.testing.assert_allclose(pos[0], [[0, 0, 0], [0, 10, 0], [0, 15, 0]], atol=1e-12)
    # a 90 degree Zrotation of the root carries the chest (10 up) to 10 along -X
    np.testing.assert_allclose(pos[1], [[1, 2, 3], [-9, 2, 3], [-14, 2, 3]], atol=1e-12)
    # Xrotation 90 at the root lifts the chest to +Z; the chest's Zrotation -90 turns its end site to +X
    np.testing.assert_allclose(pos[2], [[0, 0, 0], [0, 0, 10], [5, 0, 10]], atol=1e-12)
    assert character_height(m.skeleton) == pytest.approx(15.0)
    assert_channels_match(m.skeleton, channel_values(parse_bvh(format_bvh(m))), source_values(ANALYTIC), 0.0)


EVERYTHING_HEADER = """HIERARCHY
ROOT mixamorig:Hips
{
\tOFFSET 1.5 90 -2
\tCHANNELS 6 Xposition Yposition Zposition Yrotation Xrotation Zrotation
\tJOINT mixamorig:Spine {
\t\tOFFSET 0 10 0
\t\tCHANNELS 3 Xrotation Yrotation Zrotation
\t\tJOINT Neck Base
\t\t{
\t\t\tOFFSET 0 12 1
\t\t\tCHANNELS 5 Xposition Yposition Zposition Xrotation Zrotation
\t\t\tJOINT Head
\t\t\t{
\t\t\t\tOFFSET 0 8 0
\t\t\t\tCHANNELS 0
\t\t\t\tEnd Site
\t\t\t\t{
\t\t\t\t\tOFFSET 0 9 0
\t\t\t\t}
\t\t\t}
\t\t}
\t\tJOINT LeftArm
\t\t{
\t\t\tOFFSET 5 8 0
\t\t\tCHANNELS 4 Zrotation Yrotation Xrotation Yposition
\t\t\tJOINT LeftHand
\t\t\t{
\t\t\t\tOFFSET 20 0 0
\t\t\t\tCHANNELS 1 Yrotation
\t\t\t\tEnd Site
\t\t\t\t{
\t\t\t\t\tOFFSET 8 0 0
\t\t\t\t}
\t\t\t}
\t\t}
\t\tJOINT RightArm
\t\t{
\t\t\tOFFSET -5 8 0
\t\t\tCHANNELS 3 Xrotation Zrotation Yrotation
\t\t\tEnd Site
\t\t\t{
\t\t\t\tOFFSET -20 0 0
\t\t\t}
\t\t}
\t}
\tJOINT LeftLeg
\t{
\t\tOFFSET 4 -5 0
\t\tCHANNELS 3 Yrotation Zrotation Xrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 -40 0
\t\t}
\t}
\tJOINT RightLeg
\t{
\t\tOFFSET -4 -5 0
\t\tCHANNELS 3 Zrotation Xrotation Yrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 -40 0
\t\t}
\t}
}
"""
EVERYTHING_CHANNELS = 28


def everything_values(frames: int = 40, seed: int = 0) -> np.ndarray:
    """Smooth channel values for EVERYTHING_HEADER: middle angles within (-80, 80), positions near the OFFSETs."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * np.pi, frames)[:, None]
    values = 70 * np.sin(t * rng.uniform(0.5, 2, EVERYTHING_CHANNELS) + rng.uniform(0, 6, EVERYTHING_CHANNELS))
    values[:, 0:3] = [1.5, 90, -2] + 5 * np.sin(t + [0, 1, 2])  # root position
    values[:, 9:12] = [0, 12, 1] + np.sin(t * 3)  # Neck Base positions
    values[:, 17] = 8 + np.cos(t[:, 0])  # LeftArm Yposition
    values[:, 3] += 200 * t[:, 0]  # the root turns more than a full turn about Y
    return values


def bvh_text(header: str, values: np.ndarray, frame_time: str = "0.0333333", fmt=lambda v: repr(float(v)),
             sep: str = " ", eol: str = "\n", frame_line_gap: str = "") -> str:
    lines = [sep.join(fmt(v) for v in row) for row in values]
    body = (eol + frame_line_gap).join(lines)
    text = header + f"MOTION\nFrames: {values.shape[0]}\nFrame Time: {frame_time}\n" + body + "\n"
    return text.replace("\n", eol)


def test_everything_fixture_reads_by_the_documented_rules():
    values = everything_values()
    text = bvh_text(EVERYTHING_HEADER, values)
    m = parse_bvh(text, "everything.bvh")
    sk = m.skeleton
    assert sk.names == ("mixamorig:Hips", "mixamorig:Spine", "Neck Base", "Head", "LeftArm", "LeftHand",
                        "RightArm", "LeftLeg", "RightLeg")
    assert sk.parents.tolist() == [-1, 0, 1, 2, 1, 4, 1, 0, 0]
    assert sk.rotation_orders == ("YXZ", "XYZ", "XZ", "", "ZYX", "Y", "XZY", "YZX", "ZXY")
    assert sk.position_axes == ("XYZ", "", "XYZ", "", "Y", "", "", "", "")
    assert sk.translated_joints.tolist() == [2, 4]
    assert sk.num_channels == EVERYTHING_CHANNELS
    assert sk.end_site_parents.tolist() == [3, 5, 6, 7, 8]
    np.testing.assert_array_equal(sk.end_site_offsets[0], [0, 9, 0])
    check_reader_semantics(m, values)
    # LeftArm has only Yposition: X and Z stay at its OFFSET
    np.testing.assert_array_equal(m.joint_translations[:, 1, [0, 2]], np.broadcast_to([5.0, 0.0], (40, 2)))
    np.testing.assert_array_equal(m.joint_translations[:, 1, 1], values[:, 17])
    # BVH -> BVH gives the very channel values back (the root's Y rotation unwrapped past 360 too)
    again = parse_bvh(format_bvh(m))
    assert again.skeleton == sk
    assert_channels_match(sk, channel_values(again), values, atol=1e-6)
    assert_same_pose(m, again, 1e-7)  # six decimals
    np.testing.assert_allclose(channel_values(m), values, atol=1e-9)  # unwrapped: not even modulo 360


@pytest.mark.parametrize("variant", ["crlf", "cr", "tabs", "sci", "blank-lines", "bom", "mixed-whitespace"])
def test_text_variants_read_the_same(variant):
    values = everything_values(frames=12, seed=1)
    plain = parse_bvh(bvh_text(EVERYTHING_HEADER, values))
    kwargs = {
        "crlf": dict(eol="\r\n"),
        "cr": dict(eol="\r"),
        "tabs": dict(sep="\t"),
        "sci": dict(fmt=lambda v: f"{v:.16e}"),
        "blank-lines": dict(frame_line_gap="\n  \n"),
        "bom": {},
        "mixed-whitespace": dict(sep=" \t  "),
    }[variant]
    text = bvh_text(EVERYTHING_HEADER, values, **kwargs)
    if variant == "bom":
        text = "\ufeff" + text
    if variant == "tabs":
        text = text.replace("\t", "  ").replace("CHANNELS 6", "CHANNELS\t6")
    m = parse_bvh(text.encode("utf-8"), f"{variant}.bvh")
    assert m.skeleton == plain.skeleton
    np.testing.assert_array_equal(m.rotations, plain.rotations)
    np.testing.assert_array_equal(m.local_translations(), plain.local_translations())
    assert m.fps == plain.fps


def test_brace_on_keyword_lines_spaced_names_and_channel_case():
    text = ("HIERARCHY\nROOT Hips {\n OFFSET 0 0 0\n CHANNELS 3 xposition YPOSITION Zposition\n"
            " JOINT Left \t Arm {\n  OFFSET 1 0 0\n  CHANNELS 1 zRotation\n  End Site {\n   OFFSET 2 0 0\n  }\n }\n}\n"
            "MOTION\n\nFrames : 1\n\nFrame   Time:0.5\n\n1 2 3 90\n\n")
    m = parse_bvh(text)
    assert m.skeleton.names == ("Hips", "Left Arm")
    assert m.skeleton.channels == (("Xposition", "Yposition", "Zposition"), ("Zrotation",))
    assert m.fps == 2.0
    np.testing.assert_allclose(global_positions(m)[0], [[1, 2, 3], [2, 2, 3], [2, 4, 3]], atol=1e-12)
    assert "CHANNELS 1 Zrotation" in format_bvh(m)


def test_three_channel_root_crlf_one_frame_sci_notation(tmp_path):
    text = ("\ufeffHIERARCHY\r\nROOT\tpelvis\r\n{\r\n\tOFFSET\t0.0\t1e2\t-2.5E-1\r\n"
            "\tCHANNELS 3 Zrotation Yrotation Xrotation\r\n\tEnd Site\r\n\t{\r\n\t\tOFFSET 0 1.0e+1 0\r\n\t}\r\n}\r\n"
            "MOTION\r\nFrames:\t1\r\nFrame Time:\t8.333333e-3\r\n9.0e1\t0\t-0\r\n")
    path = tmp_path / "root3.bvh"
    path.write_bytes(text.encode("utf-8"))
    m = read_bvh(path)
    assert m.num_frames == 1 and m.fps == pytest.approx(1 / 8.333333e-3)
    assert m.skeleton.position_axes == ("",) and m.skeleton.rotation_orders == ("ZYX",)
    np.testing.assert_array_equal(m.root_translation, [[0.0, 100.0, -0.25]])  # the root stays at its OFFSET
    np.testing.assert_allclose(global_positions(m)[0], [[0, 100, -0.25], [-10, 100, -0.25]], atol=1e-12)
    out = tmp_path / "out.bvh"
    write_bvh(m, out)
    written = out.read_text()
    assert "CHANNELS 3 Zrotation Yrotation Xrotation" in written and "\r" not in written
    assert_channels_match(m.skeleton, channel_values(read_bvh(out)), np.array([[90.0, 0.0, 0.0]]), 1e-6)


def test_second_euler_solution_round_trips():
    # middle angles beyond 90 degrees: the same rotation has another solution; the file's numbers come back
    values = np.array([[0, 0, 0, 170, 120, -30, 10, 100, -175], [0, 0, 0, 175, 125, -35, 5, 95, 179]], float)
    text = ANALYTIC.split("MOTION")[0] + "MOTION\nFrames: 2\nFrame Time: 0.04\n" + "\n".join(
        " ".join(f"{v:g}" for v in row) for row in values) + "\n"
    m = parse_bvh(text)
    assert m.euler_branch[:, 0].all() and m.euler_branch[:, 1].all()
    assert np.array_equal(channel_values(m), values)  # the file's very numbers (Motion.euler_angles)
    assert np.array_equal(channel_values(parse_bvh(format_bvh(m))), values)
    # with the branch hint alone: the same solution, unwrapped over frames
    branch_only = m.replace(euler_angles=None)
    got = channel_values(branch_only)
    assert_channels_match(m.skeleton, got, values, atol=1e-9)  # the same numbers modulo 360...
    assert got[1, 8] == pytest.approx(-181.0)  # ...unwrapped over frames: -175 -> -181, not -175 -> 179
    again = parse_bvh(format_bvh(branch_only))
    assert_channels_match(m.skeleton, channel_values(again), values, atol=1e-9)
    # without either hint the writer takes the first solution: the same pose, other numbers
    plain = m.replace(euler_branch=None, euler_angles=None)
    other = channel_values(plain)
    assert np.abs(other - values).max() > 50
    assert_same_pose(m, parse_bvh(format_bvh(plain)), 1e-6)


# ---- writer ----------------------------------------------------------------------------------------------------
def test_writer_default_layout_decimals_and_frame_time():
    sk = humanoid_skeleton()
    bare = Skeleton(sk.names, sk.parents, sk.offsets, end_site_parents=sk.end_site_parents,
                    end_site_offsets=sk.end_site_offsets)  # no channel layout given
    m = synthetic_motion(bare, frames=5, fps=120.0)
    text = format_bvh(m, decimals=3)
    lines = text.splitlines()
    assert lines[0] == "HIERARCHY" and lines[1] == "ROOT Hips"
    assert f"CHANNELS 6 {' '.join(DEFAULT_ROOT_CHANNELS)}" in text
    assert text.count(f"CHANNELS 3 {' '.join(DEFAULT_JOINT_CHANNELS)}") == 14
    # 15 digits would read back as 120.00000000000004 fps: the writer takes the 16 that give 120 exactly
    assert "Frames: 5" in lines and "Frame Time: 0.008333333333333333" in lines
    frame_lines = lines[lines.index("Frame Time: 0.008333333333333333") + 1:]
    assert len(frame_lines) == 5
    for token in " ".join(frame_lines).split():
        assert len(token.split(".")[1]) == 3, token
    assert "-0.000 " not in text  # no negative zeros
    again = parse_bvh(text)
    assert again.skeleton.channels == bare.channels and again.fps == 120.0
    assert_same_pose(m, again, 1e-5)
    with pytest.raises(ValidationError, match="decimals must be an integer from 0 to 17"):
        format_bvh(m, decimals=18)
    with pytest.raises(ValidationError, match="decimals"):
        format_bvh(m, decimals=2.5)


def test_writer_refuses_what_the_layout_cannot_hold(tmp_path):
    sk = Skeleton(("root", "arm"), [-1, 0], [[0, 0, 0], [0, 10, 0]],
                  channels=(("Xposition", "Yposition", "Zposition", "Zrotation"), ()))
    rot = np.zeros((2, 2, 4))
    rot[..., 3] = 1.0
    ok = Motion(sk, 30.0, np.zeros((2, 3)), rot)
    assert "CHANNELS 0" in format_bvh(ok)
    turned = rot.copy()
    turned[1, 1] = euler_to_quat([30.0], "X", degrees=True)
    with pytest.raises(ValidationError, match="joint 'arm' rotates but has no rotation channels"):
        format_bvh(Motion(sk, 30.0, np.zeros((2, 3)), turned))
    tilted = rot.copy()
    tilted[1, 0] = euler_to_quat([30.0], "X", degrees=True)
    with pytest.raises(ValidationError, match="rotates about another axis"):
        format_bvh(Motion(sk, 30.0, np.zeros((2, 3)), tilted))
    root3 = Skeleton(("root",), [-1], [[0, 0, 0]], channels=(("Zrotation", "Xrotation", "Yrotation"),))
    moving = Motion(root3, 30.0, [[0, 0, 0], [0, 1, 0]], np.tile([0, 0, 0, 1.0], (2, 1, 1)))
    target = tmp_path / "out.bvh"
    target.write_text("old content")
    with pytest.raises(ValidationError, match="joint 'root' moves along Y but has no Yposition channel"):
        write_bvh(moving, target)
    assert target.read_text() == "old content"  # never a partial file
    with pytest.raises(ValidationError):
        write_bvh(moving, tmp_path / "new.bvh")
    assert sorted(os.listdir(tmp_path)) == ["out.bvh"]


def test_writer_reorders_joints_depth_first():
    # joints listed breadth first: the writer emits them depth first, the pose is kept
    sk = Skeleton(("root", "a", "b", "a1", "b1"), [-1, 0, 0, 1, 2],
                  [[0, 0, 0], [1, 0, 0], [-1, 0, 0], [0, 2, 0], [0, 3, 0]],
                  end_site_parents=[3, 4], end_site_offsets=[[0, 1, 0], [0, 1, 0]])
    m = synthetic_motion(sk, frames=8)
    again = parse_bvh(format_bvh(m))
    assert again.skeleton.names == ("root", "a", "a1", "b", "b1")
    order = [0, 1, 3, 2, 4]
    pos, pos2 = global_positions(m), global_positions(again)
    np.testing.assert_allclose(pos2[:, :5], pos[:, order], atol=1e-5)
    np.testing.assert_allclose(pos2[:, 5:], pos[:, 5:], atol=1e-5)


@pytest.mark.parametrize("decimals", [0, 1, 3, 6, 9, 12])
def test_frame_values_are_formatted_as_printf_does(decimals):
    rng = np.random.default_rng(decimals)
    values = rng.normal(size=(40, 9)) * 10.0 ** rng.integers(-4, min(7, 14 - decimals), (40, 9))
    values[0, :8] = [0.0, -0.0, -1e-9, 0.5, -0.5, 2.5, 999.99999999, -99.999999999]
    rounded = np.round(values, decimals) + 0.0
    buf = io.StringIO()
    np.savetxt(buf, rounded, fmt=f"%.{decimals}f", delimiter=" ")
    assert _format_fixed(rounded, decimals).decode("ascii") == buf.getvalue()
    assert _format_fixed(np.array([[1e12]]), 6) is None  # beyond exact integers: the writer uses savetxt


def test_huge_values_are_written_exactly_enough():
    sk = Skeleton(("root",), [-1], [[0, 0, 0]])
    m = Motion(sk, 30.0, [[1e12, -3.5e15, 0.25]], [[[0, 0, 0, 1.0]]])
    again = parse_bvh(format_bvh(m))
    np.testing.assert_array_equal(again.root_translation, m.root_translation)


def test_offsets_and_frame_time_are_written_exactly():
    sk = Skeleton(("root", "c"), [-1, 0], [[0.1, 1 / 3, -2.5e-7], [1e-20, 123456.789, 0]])
    m = Motion(sk, 1 / 0.0416667, np.zeros((1, 3)) + [0.1, 1 / 3, -2.5e-7], np.tile([0, 0, 0, 1.0], (1, 2, 1)))
    text = format_bvh(m)
    again = parse_bvh(text)
    np.testing.assert_array_equal(again.skeleton.offsets, sk.offsets)  # shortest exact decimals
    assert "Frame Time: 0.0416667\n" in text
    assert again.fps == pytest.approx(m.fps, rel=1e-14)


# ---- the command line ------------------------------------------------------------------------------------------
def test_cli_convert_bvh_to_bvh(tmp_path):

    values = everything_values(frames=20, seed=3)
    src = tmp_path / "in.bvh"
    src.write_text(bvh_text(EVERYTHING_HEADER, values, eol="\r\n"))
    out = tmp_path / "out.bvh"
    result = run_cli_caught("convert", str(src), str(out))
    assert result.exit_code == 0, result.output
    m = read_bvh(out)
    assert_channels_match(m.skeleton, channel_values(m), values, atol=1e-6)
    assert_channels_match(m.skeleton, source_values(out.read_text()), values, atol=1e-6)


def test_rotation_channels_between_position_channels():
    """A joint's rotation channels need not be next to each other: each angle is read from its own column."""
    text = """HIERARCHY
ROOT Hips
{
\tOFFSET 0 0 0
\tCHANNELS 6 Zrotation Xposition Xrotation Yposition Yrotation Zposition
\tJOINT Arm
\t{
\t\tOFFSET 0 10 0
\t\tCHANNELS 4 Yrotation Xposition Zrotation Xrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 5 0
\t\t}
\t}
}
MOTION
Frames: 2
Frame Time: 0.04
10 1 20 2 30 3 40 0.5 50 60
-15 4 25 5 -35 6 45 -0.5 55 -65
"""
    m = parse_bvh(text)
    values = np.array([[10, 1, 20, 2, 30, 3, 40, 0.5, 50, 60], [-15, 4, 25, 5, -35, 6, 45, -0.5, 55, -65]], float)
    want_root = Rotation.from_euler("ZXY", values[:, [0, 2, 4]], degrees=True).as_quat()
    want_arm = Rotation.from_euler("YZX", values[:, [6, 8, 9]], degrees=True).as_quat()
    for got, want in ((m.rotations[:, 0], want_root), (m.rotations[:, 1], want_arm)):
        assert np.allclose(np.abs(np.sum(got * want, axis=-1)), 1.0, atol=1e-12)
    np.testing.assert_array_equal(m.root_translation, values[:, [1, 3, 5]])
    np.testing.assert_array_equal(m.joint_translations[:, 0], np.stack([values[:, 7], [10.0, 10.0], [0, 0]], 1))
