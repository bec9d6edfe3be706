"""The BVH reader's frame block, read by one compiled pass (``motionrep._ccore``, C): every number syntax read
exactly as Python's ``float`` reads it, bit for bit; layout faults and junk named with the file and the line; the
Euler angles turned into the quaternions the conversion's arithmetic gives; and reading a file imports no numba.

(Until the C core, the reader had two paths, numba's and a numpy one for processes that had read little; the
tests that held them equal are now these, against ``float`` and against the arithmetic written out in
``test_ccore.py``.)"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from motionrep import Motion
from motionrep.errors import MotionrepError
from motionrep.io import parse_bvh
from motionrep.io._bvh import channel_values
from motionrep.io._numbers import parse_numbers, scan_block

from helpers import real_params
from test_bvh_malformed import CASES, VALID
from test_ccore import ref_euler


def read(data: bytes | str, path: str = "clip.bvh"):
    """``parse_bvh``: a Motion, or the error's type and text."""
    try:
        return parse_bvh(data, path)
    except MotionrepError as exc:
        return (type(exc).__name__, str(exc))


def bits(a: np.ndarray | None):
    if a is None:
        return None
    return a.view(np.uint64) if a.dtype == np.float64 else a


def assert_exact(motion: Motion, tokens: list[str]) -> None:
    """The motion's channel values are ``float`` of the tokens, bit for bit (signs of zero included), and its
    rotations the Euler conversion of them, bit for bit."""
    values = channel_values(motion)
    want = np.array([float(t) for t in tokens]).reshape(values.shape)
    assert np.array_equal(bits(values), bits(want))
    sk = motion.skeleton
    col = 0
    for j, chans in enumerate(sk.channels):
        rc = [col + k for k, c in enumerate(chans) if c.endswith("rotation")]
        col += len(chans)
        if not rc:
            continue
        order = sk.rotation_orders[j]
        axes = ["XYZ".index(a.upper()) for a in order]
        rows = np.array([ref_euler([row[c] for c in rc], axes, True) for row in want.tolist()])
        assert np.array_equal(bits(motion.rotations[:, j]), bits(rows)), sk.names[j]


# every number syntax a frame line may hold, and values the Euler conversion must treat alike
NUMBERS = ["0", "-0", "+0", "-0.000", "-0e0", "0e-5", "1", "-12.5", "+12.5", ".5", "-.5", "5.", "007.250", "1E5",
           "1e+05", "-2.5E-1", "1.e3", ".5e1", "-9.23872e-007", "5.1072e-06", "1e22", "1e-22", "1e23", "4.9e-324",
           "1e-400", "2.2250738585072014e-308", "123456789012345", "12345678901234567890", "0.30000000000000004",
           "3.14159265358979323846", "9007199254740993", "1e300", "-1.7976931348623157e308", "1.7976931348623157E308",
           "359.99999999999994", "-720", "720", "1080.5", "-450", "90", "-90", "180", "-180", "270", "45.000000001"]


def bvh_text(values: list[str], per_line: int = 9, separators=(" ",)) -> str:
    """The VALID skeleton (9 channels) with ``values`` as frame lines of 9 values (padded with 0)."""
    rows = [values[k:k + per_line] for k in range(0, len(values), per_line)]
    rows[-1] = rows[-1] + ["0"] * (per_line - len(rows[-1]))
    head = VALID[: VALID.index("Frames:")]
    lines = [separators[i % len(separators)].join(r) for i, r in enumerate(rows)]
    return head + f"Frames: {len(rows)}\nFrame Time: 0.0333333\n" + "\n".join(lines) + "\n"


def test_every_number_syntax_and_extreme_values_read_as_float_reads_them():
    rng = np.random.default_rng(3)
    values = NUMBERS + [NUMBERS[i] for i in rng.integers(0, len(NUMBERS), 9 * 40)]
    values += ["0"] * (-len(values) % 9)
    m = read(bvh_text(values, separators=(" ", "\t", " \x0b ", "\x0c", "  ")))
    assert isinstance(m, Motion)
    assert_exact(m, values)


def test_random_angles_of_every_size_read_exactly():
    rng = np.random.default_rng(7)
    angles = np.concatenate([rng.uniform(-180, 180, 900), rng.uniform(-1e6, 1e6, 90), rng.normal(0, 1e-3, 90),
                             np.array([0.0, -0.0, 90.0, -90.0, 180.0, -180.0, 360.0, 720.0, -540.0])])
    tokens = [repr(float(v)) for v in angles] + [f"{v:.6f}" for v in angles[:200]] + [f"{v:.3e}" for v in angles[:200]]
    tokens += ["0"] * (-len(tokens) % 9)
    assert_exact(read(bvh_text(tokens)), tokens)


@pytest.mark.parametrize("name", list(CASES))
def test_malformed_names_the_file_and_line(name):
    content, line, words = CASES[name]
    a = read(content, "bad file.bvh")
    assert not isinstance(a, Motion) and f"bad file.bvh:{line}: " in a[1] and words in a[1]


@pytest.mark.parametrize("edit, outcome", [
    (("0 0 0 0 90 0 -90 0 0", "0 0 0 0 90 0 -90 nan x"), "clip.bvh:21: expected a number, found 'x'"),
    (("0 0 0 0 90 0 -90 0 0", "0 0 0 0 90 0 -90 inf 0\n1 2 3 4 5 6 7 8 9"),
     "clip.bvh:22: more frame lines than Frames: 3 (line 22 is frame 4)"),  # one line too many: named first
    (("1 2 3 90 0 0 0 0 0", "1 2 3 90 0 0 0 0\n"), "clip.bvh:20: frame line has 8 values, expected 9 (one per channel)"),
    (("1 2 3 90 0 0 0 0 0", "1 2 3 90 0 0 0 0 0 1e999 \u0663"),
     "clip.bvh:20: frame line has 11 values, expected 9 (one per channel)"),
    (("1 2 3 90 0 0 0 0 0", "1 2 3 90 0 0 0 0 0\n\n\n \t \n"), None),  # blank lines between frames: read
    (("1 2 3 90 0 0 0 0 0", "1 2 3 9_0 0 \u0663 0 0 0"), "clip.bvh:20: expected a number, found '9_0'"),
])
def test_edited_frames(edit, outcome):
    old, new = edit
    got = read(VALID.replace(old, new))
    if outcome is None:
        assert isinstance(got, Motion) and got.num_frames == 3
    else:
        assert got == ("BVHFormatError", outcome)


@pytest.mark.parametrize("path", real_params())
def test_real_files_read_exactly(path):
    """Every value of every real clip is ``float`` of its token; the rotations of the first and last 40 frames are
    the Euler conversion's arithmetic, bit for bit."""
    data = path.read_bytes()
    m = read(data, str(path))
    assert isinstance(m, Motion), m
    text = data.replace(b"\r", b"\n")
    block = text[text.index(b"\n", text.index(b"Frame Time")) + 1:].split()
    tokens = [t.decode() for t in block]
    values = channel_values(m)
    assert np.array_equal(bits(values), bits(np.array([float(t) for t in tokens]).reshape(values.shape)))
    F, C = values.shape
    rows = list(range(min(F, 40))) + list(range(max(40, F - 40), F))
    sub = Motion(m.skeleton, m.fps, m.root_translation[rows], m.rotations[rows], m.joint_translations[rows],
                 euler_branch=m.euler_branch[rows], euler_angles=m.euler_angles[rows])
    assert_exact(sub, [tokens[r * C + c] for r in rows for c in range(C)])


def test_number_parser():
    tokens = NUMBERS + ["nan", "-inf", "Infinity", "123.456789012345678"]
    values, bad = parse_numbers("\n ".join(tokens).encode())
    want = np.array([float(t) for t in tokens])
    assert bad is None
    assert np.array_equal(np.isnan(values), np.isnan(want))
    assert np.array_equal(bits(values)[~np.isnan(want)], bits(want)[~np.isnan(want)])
    for junk in ["1_000", "0x10", "1e", "e1", ".", "-", "+.", "1.2.3", "--1", "1-2", "12a", "\u0663"]:
        assert parse_numbers(f"1.5\n{junk} 2".encode())[1] == 1, junk


def random_decimals(rng, n: int) -> list[str]:
    """Decimal tokens of every shape: signs, leading zeros, no integer or no fraction part, 1-20 significant digits
    (beyond 2**53 too), exponents (down to subnormals and up to the largest doubles)."""
    out = []
    for _ in range(n):
        sign = rng.choice(["", "", "-", "+"])
        whole = "".join(rng.choice(list("0123456789"), int(rng.integers(0, 11))))
        frac = "".join(rng.choice(list("0123456789"), int(rng.integers(0, 11))))
        dot = rng.random() < 0.8
        if not whole and not frac:
            whole = "7"
        text = sign + whole + ("." + frac if dot else frac)
        if rng.random() < 0.1:
            text += rng.choice(["e", "E"]) + rng.choice(["", "-", "+"]) + str(int(rng.integers(0, 330)))
        out.append(text)
    return out


@pytest.mark.parametrize("seed", range(4))
def test_random_decimals_are_float_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    tokens = random_decimals(rng, 20_000)
    values, bad = parse_numbers(" ".join(tokens).encode())
    assert bad is None
    assert np.array_equal(bits(values), bits(np.array([float(t) for t in tokens])))


@pytest.mark.slow
def test_many_random_decimals_bit_for_bit():
    rng = np.random.default_rng(99)
    tokens = random_decimals(rng, 250_000)
    values, bad = parse_numbers("\n".join(" ".join(tokens[k:k + 10]) for k in range(0, len(tokens), 10)).encode())
    assert bad is None and np.array_equal(bits(values), bits(np.array([float(t) for t in tokens])))


# (rows, first wrong line, its count, last data line, first data line, extra line, bad, nonfinite) for each of
# (width, rows_max) = (3, 2), (3, 1), (0, 2), (2, 5)
LAYOUTS = {
    b"1 2 3\n4 5 6\n": [(2, -1, 0, 1, 0, -1, None, None), (2, -1, 0, 1, 0, 1, None, None),
                        (2, 0, 3, 1, 0, -1, None, None), (2, 0, 3, 1, 0, -1, None, None)],
    b"\n\n1 2 3\n4 5\n7 8 9 10\n": [(3, 3, 2, 4, 2, 4, None, None), (3, 3, 2, 4, 2, 3, None, None),
                                   (3, 2, 3, 4, 2, 4, None, None), (3, 2, 3, 4, 2, -1, None, None)],
    b"1 2 3\n4 5 6\n7 8 9\n": [(3, -1, 0, 2, 0, 2, None, None), (3, -1, 0, 2, 0, 1, None, None),
                             (3, 0, 3, 2, 0, 2, None, None), (3, 0, 3, 2, 0, -1, None, None)],
    b"1 nan 3\n4 x 6\n": [(2, -1, 0, 1, 0, -1, (4, 1, "x"), (1, 0, "nan")), (2, -1, 0, 1, 0, 1, None, (1, 0, "nan")),
                          (2, 0, 3, 1, 0, -1, None, None), (2, 0, 3, 1, 0, -1, (3, 1, "x"), (1, 0, "nan"))],
    b"  \t\n": [(0, -1, 0, -1, -1, -1, None, None)] * 4,
    b"1 2 3": [(1, -1, 0, 0, 0, -1, None, None), (1, -1, 0, 0, 0, -1, None, None), (1, 0, 3, 0, 0, -1, None, None),
               (1, 0, 3, 0, 0, -1, None, None)],
    b"1\x00 2\x1f3\n4 5 6": [(2, -1, 0, 1, 0, -1, None, None), (2, -1, 0, 1, 0, 1, None, None),
                              (2, 0, 3, 1, 0, -1, None, None), (2, 0, 3, 1, 0, -1, None, None)],
    b"1 2 3\r\n4 5 6": [(2, -1, 0, 1, 0, -1, None, None), (2, -1, 0, 1, 0, 1, None, None),
                        (2, 0, 3, 1, 0, -1, None, None), (2, 0, 3, 1, 0, -1, None, None)],
}


@pytest.mark.parametrize("data", list(LAYOUTS))
def test_block_scan_layout_findings(data):
    u = np.frombuffer(data, np.uint8)
    for (width, rows_max), want in zip(((3, 2), (3, 1), (0, 2), (2, 5)), LAYOUTS[data]):
        a = scan_block(u, width, rows_max)
        assert (a.rows, a.first_wrong_line, a.wrong_count, a.last_data_line, a.first_data_line, a.extra_line,
                a.bad, a.nonfinite) == want, (data, width)
        if a.first_wrong_line < 0 and a.bad is None and a.rows <= rows_max:
            n = a.rows * width
            tokens = bytes(b if b > 32 else 32 for b in data).split()  # every byte <= 32 separates
            assert np.array_equal(bits(a.values[:n]), bits(np.array([float(t) for t in tokens][:n])))


def test_reading_fk_and_writing_import_no_numba(tmp_path):
    """Reading a file of any size, its FK and writing it back run the compiled core: numba is never imported (it
    was, through the compiled loops, for any process that read more than 48 MB)."""
    path = tmp_path / "clip.bvh"
    path.write_text(bvh_text(NUMBERS * 5))
    code = ("import sys, motionrep\n"
            "assert 'numba' not in sys.modules and 'numpy' not in sys.modules\n"
            "from motionrep.io import read_bvh, write_bvh\n"
            "from motionrep.model.kinematics import forward_kinematics\n"
            "from motionrep.present.info import info_dict\n"
            f"m = read_bvh({str(path)!r}); info_dict({str(path)!r}); forward_kinematics(m)\n"
            f"write_bvh(m, {str(tmp_path / 'out.bvh')!r})\n"
            "print(m.num_frames, sorted(k for k in sys.modules if k.split('.')[0] in ('numba', 'llvmlite')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["25", "[]"]
