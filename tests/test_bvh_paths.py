"""The BVH reader's two paths -- compiled loops (numba) and numpy (a process that has read little, so that reading
one clip never imports numba) -- give the same motion, bit for bit, and the same error, file and line, for the
same text; and reading a small file does not import numba."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings

from motionrep import Motion
from motionrep.errors import MotionrepError
from motionrep.io import parse_bvh
from motionrep.io import _numbers
from motionrep.io._numbers import parse_numbers, scan_block
from motionrep.io._plain_rows import parse_plain_rows
from motionrep.jit import sincos, sincos_numpy
from motionrep.model.poseplan import EULER, EULER_DEGREES, PosePlan, decode_euler_numpy, decode_planned

from helpers import real_params
from test_bvh_fuzz import mutated
from test_bvh_malformed import CASES, VALID


def read_both(data: bytes | str, path: str = "clip.bvh"):
    """``parse_bvh`` through each path: a Motion or the error's type and text, for each."""
    out = []
    for compiled in (False, True):
        try:
            out.append(parse_bvh(data, path, compiled=compiled))
        except MotionrepError as exc:
            out.append((type(exc).__name__, str(exc)))
    return out


def bits(a: np.ndarray | None):
    if a is None:
        return None
    return a.view(np.uint64) if a.dtype == np.float64 else a


def assert_same(numpy_path, compiled_path) -> None:
    assert type(numpy_path) is type(compiled_path), (numpy_path, compiled_path)
    if not isinstance(numpy_path, Motion):
        assert numpy_path == compiled_path  # the same error class, message, file and line
        return
    a, b = numpy_path, compiled_path
    assert a.skeleton == b.skeleton and a.fps == b.fps
    for name in ("root_translation", "rotations", "joint_translations", "euler_angles", "euler_branch"):
        x, y = getattr(a, name), getattr(b, name)
        assert np.array_equal(bits(x), bits(y)), name  # bit for bit: signs of zero included


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


def test_every_number_syntax_and_extreme_values_read_alike():
    rng = np.random.default_rng(3)
    values = NUMBERS + [NUMBERS[i] for i in rng.integers(0, len(NUMBERS), 9 * 40)]
    a, b = read_both(bvh_text(values, separators=(" ", "\t", " \x0b ", "\x0c", "  ")))
    assert isinstance(a, Motion)
    assert_same(a, b)
    # and both are float(token): the first value of each column
    assert np.array_equal(bits(a.euler_angles[0]), bits(np.array([float(t) for t in NUMBERS[3:9]])))


def test_random_angles_of_every_size_read_alike():
    rng = np.random.default_rng(7)
    angles = np.concatenate([rng.uniform(-180, 180, 900), rng.uniform(-1e6, 1e6, 90), rng.normal(0, 1e-3, 90),
                             np.array([0.0, -0.0, 90.0, -90.0, 180.0, -180.0, 360.0, 720.0, -540.0])])
    tokens = [repr(float(v)) for v in angles] + [f"{v:.6f}" for v in angles[:200]] + [f"{v:.3e}" for v in angles[:200]]
    assert_same(*read_both(bvh_text(tokens)))


@pytest.mark.parametrize("name", list(CASES))
def test_malformed_gives_the_same_error_on_both_paths(name):
    content, line, words = CASES[name]
    a, b = read_both(content, "bad file.bvh")
    assert_same(a, b)
    assert not isinstance(a, Motion) and f"bad file.bvh:{line}: " in a[1] and words in a[1]


@pytest.mark.parametrize("edit", [
    ("0 0 0 0 90 0 -90 0 0", "0 0 0 0 90 0 -90 nan x"),  # a NaN before junk: the junk is named (both paths)
    ("0 0 0 0 90 0 -90 0 0", "0 0 0 0 90 0 -90 inf 0\n1 2 3 4 5 6 7 8 9"),  # one line too many (named first)
    ("1 2 3 90 0 0 0 0 0", "1 2 3 90 0 0 0 0\n"),  # a short line, then the frames run out
    ("1 2 3 90 0 0 0 0 0", "1 2 3 90 0 0 0 0 0 1e999 \u0663"),  # too many values, some not numbers
    ("1 2 3 90 0 0 0 0 0", "1 2 3 90 0 0 0 0 0\n\n\n \t \n"),  # blank lines between frames
    ("1 2 3 90 0 0 0 0 0", "1 2 3 9_0 0 \u0663 0 0 0"),  # text that is not ASCII or has '_': the slow branch
])
def test_edited_frames_read_alike(edit):
    old, new = edit
    assert_same(*read_both(VALID.replace(old, new)))


@pytest.mark.parametrize("batch", [1, 5, 9, 1 << 16])
def test_batches_of_the_numpy_path_change_nothing(batch, monkeypatch):
    monkeypatch.setattr(_numbers, "_BATCH", batch)  # tokens converted at a time
    texts = [bvh_text(NUMBERS * 3), VALID.replace("1 2 3 90 0 0 0 0 0", "1 2 3 90 0 0 0 nan 0"),
             VALID.replace("0 0 0 0 90 0 -90 0 0", "0 0 0 0 90 0 -90 inf 0").replace("1 2 3 90", "1 inf 3 x"),
             VALID.replace("1 2 3 90 0 0 0 0 0", "1 2 3 90 0 0 0 0"), VALID.replace("-90 0 0", "-90 0 0 junk")]
    for text in texts:
        assert_same(*read_both(text))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated())
def test_mutated_text_reads_alike(data):
    assert_same(*read_both(data, "fuzz.bvh"))


@pytest.mark.parametrize("path", real_params())
def test_real_files_read_alike(path):
    assert_same(*read_both(path.read_bytes(), str(path)))


@pytest.mark.parametrize("compiled", [False, True])
def test_number_parser_on_both_paths(compiled):
    tokens = NUMBERS + ["nan", "-inf", "Infinity", "123.456789012345678"]
    values, bad = parse_numbers("\n ".join(tokens).encode(), compiled=compiled)
    want = np.array([float(t) for t in tokens])
    assert bad is None
    assert np.array_equal(np.isnan(values), np.isnan(want))
    assert np.array_equal(bits(values)[~np.isnan(want)], bits(want)[~np.isnan(want)])
    for junk in ["1_000", "0x10", "1e", "e1", ".", "-", "+.", "1.2.3", "--1", "1-2", "12a", "\u0663"]:
        assert parse_numbers(f"1.5\n{junk} 2".encode(), compiled=compiled)[1] == 1, junk


def random_decimals(rng, n: int) -> list[str]:
    """Decimal tokens of every shape the plain-row parser meets: signs, leading zeros, no integer or no fraction
    part, 1-20 significant digits (beyond 2**53 too), tokens of 16 and 17 bytes, exponents (down to subnormals
    and up to the largest doubles)."""
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


def plain_block(tokens: list[str], width: int, rng) -> bytes:
    """``tokens`` as lines of ``width``, with random separators, blank lines and maybe no final line feed."""
    seps = [" ", "  ", "\t", " \x0b", "\x0c ", " \t "]
    lines = []
    for k in range(0, len(tokens), width):
        lines.append(rng.choice(["", " ", "\t"]) + "".join(t + str(rng.choice(seps)) for t in tokens[k:k + width]))
        if rng.random() < 0.05:
            lines.append(str(rng.choice(["", "  ", "\t \x0b"])))
    return ("\n".join(lines) + str(rng.choice(["", "\n", "\n\n"]))).encode()


@pytest.mark.parametrize("seed", range(4))
def test_plain_rows_are_float_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    width = int(rng.integers(1, 40))
    tokens = random_decimals(rng, width * 300)
    tokens[:len(NUMBERS)] = [t for t in NUMBERS if "e" not in t.lower() or float(t) - float(t) == 0.0]
    tokens = [t for t in tokens if abs(float(t)) < float("inf")]
    tokens = tokens[:len(tokens) // width * width]
    values = parse_plain_rows(plain_block(tokens, width, rng), len(tokens) // width, width)
    assert values is not None
    assert np.array_equal(bits(values), bits(np.array([float(t) for t in tokens])))


@pytest.mark.slow
def test_plain_rows_on_random_decimals_bit_for_bit():
    """250,000 random decimals (a million also passed, but took two minutes of the CI's slow step)."""
    rng = np.random.default_rng(99)
    tokens = [t for t in random_decimals(rng, 250_000) if abs(float(t)) < float("inf")]
    tokens = tokens[:len(tokens) // 10 * 10]
    values = parse_plain_rows(plain_block(tokens, 10, rng), len(tokens) // 10, 10)
    assert np.array_equal(bits(values), bits(np.array([float(t) for t in tokens])))


@pytest.mark.parametrize("block", [
    b"1 2 3\n4 5\n", b"1 2 3\n4 5 6 7\n", b"1 2 3\n4 5 6\n7 8 9\n", b"1 2 3\n", b"1 2 3\r\n4 5 6\r\n",
    b"1 nan 3\n4 5 6\n", b"1 inf 3\n4 5 6\n", b"1 1e400 3\n4 5 6\n", b"1 2_0 3\n4 5 6\n", b"1 1-2 3\n4 5 6\n",
    b"1 1.2.3 3\n4 5 6\n", b"1 . 3\n4 5 6\n", b"1 - 3\n4 5 6\n", b"1 +. 3\n4 5 6\n", b"1 e5 3\n4 5 6\n",
    b"1 1e 3\n4 5 6\n", b"1 --1 3\n4 5 6\n", b"1 0x1p3 3\n4 5 6\n", b"1 2 3\n4 5 \xd9\xa3\n", b"1 2 3 4 5 6\n",
    b"1 2 3\x004 5 6\n", b"1 +-2 3\n4 5 6\n", b"1 2. 3.e\n4 5 6\n", b"1 2 3\n4 5 6\n" + b"\n" * 40])
def test_plain_rows_give_up_on_any_doubt(block):
    """Each of these is for the exact path to read or to name: the plain-row parser returns None."""
    assert parse_plain_rows(block.ljust(20, b" "), 2 if len(block) < 40 else 20, 3) is None


def test_the_numpy_path_reads_plain_frames_without_float(monkeypatch):
    text = bvh_text([f"{v:.6f}" for v in np.random.default_rng(1).uniform(-500, 500, 9 * 50)])
    want = parse_bvh(text, compiled=True)
    monkeypatch.setattr(_numbers, "_scan_numpy", None)  # the exact numpy path is not used at all
    assert_same(parse_bvh(text, compiled=False), want)


def test_block_scans_agree_on_layout_findings():
    cases = [b"1 2 3\n4 5 6\n", b"\n\n1 2 3\n4 5\n7 8 9 10\n", b"1 2 3\n4 5 6\n7 8 9\n", b"1 nan 3\n4 x 6\n",
             b"  \t\n", b"1 2 3", b"1\x00 2\x1f3\n4 5 6", b"1 2 3\r\n4 5 6"]
    for data in cases:
        u = np.frombuffer(data, np.uint8)
        for width, rows_max in ((3, 2), (3, 1), (0, 2), (2, 5)):
            a = scan_block(u, width, rows_max, compiled=False)
            b = scan_block(u, width, rows_max, compiled=True)
            assert (a.rows, a.first_wrong_line, a.wrong_count, a.last_data_line, a.first_data_line, a.extra_line,
                    a.bad, a.nonfinite) == (b.rows, b.first_wrong_line, b.wrong_count, b.last_data_line,
                                            b.first_data_line, b.extra_line, b.bad, b.nonfinite), (data, width)
            if a.first_wrong_line < 0 and a.bad is None and a.rows <= rows_max:
                n = a.rows * width
                assert np.array_equal(bits(a.values[:n]), bits(b.values[:n]))


def test_sincos_numpy_is_the_kernel_bit_for_bit():
    rng = np.random.default_rng(11)
    x = np.concatenate([rng.uniform(-10, 10, 4000), rng.uniform(-1e7, 1e7, 1000), rng.normal(0, 1e-8, 500),
                        np.arange(-16, 17) * (np.pi / 4), [0.0, -0.0, 1e300, -1e300, 5e-324]])
    s, c = sincos_numpy(x)
    compiled = np.array([sincos(v) for v in x.tolist()])  # the kernel numba compiles
    with np.errstate(all="ignore"):
        source = np.array([sincos.py_func(v) for v in x.tolist()])  # its source, run by Python
    for want in (compiled, source):
        assert np.array_equal(bits(s), bits(want[:, 0])) and np.array_equal(bits(c), bits(want[:, 1]))


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_euler_numpy_is_the_kernel_bit_for_bit(dtype):
    rng = np.random.default_rng(5)
    T, D = 333, 12
    features = np.concatenate([rng.uniform(-400, 400, (T - 3, D)), np.full((1, D), -0.0), np.full((1, D), 1e300),
                               np.full((1, D), 720.0)])
    kinds = np.array([EULER_DEGREES, EULER_DEGREES, EULER, EULER_DEGREES, EULER], np.int64)
    columns = np.array([[0, 1, 2, -1, -1, -1], [5, 3, -1, -1, -1, -1], [4, 6, 7, -1, -1, -1], [8, -1, -1, -1, -1, -1],
                        [11, 10, 9, -1, -1, -1]], np.int64)
    axes = np.array([[2, 0, 1], [0, 0, -1], [1, 2, 0], [1, -1, -1], [0, 1, 2]], np.int64)
    plan = PosePlan(width=D, num_joints=7, kinds=kinds, columns=columns, axes=axes,
                    joints=np.array([0, 2, 3, 5, 6], np.int64), parents=np.arange(7, dtype=np.int64) - 1,
                    translation_columns=np.zeros((0, 3), np.int64), translation_values=np.zeros((0, 3)))
    a, b = np.full((T, 7, 4), 7.0, dtype), np.full((T, 7, 4), 7.0, dtype)
    decode_euler_numpy(features, plan, a)
    decode_planned(features, plan, b, None, None, check_finite=False, keep_unplanned=True)
    assert np.array_equal(a.view(np.uint8), b.view(np.uint8))
    assert (a[:, [1, 4]] == 7.0).all()  # joints without an entry are left as they are


def test_the_numpy_path_has_a_budget(monkeypatch):
    monkeypatch.setattr(_numbers, "NUMPY_PATH_BUDGET", 1000)
    monkeypatch.setattr(_numbers, "_numpy_path_bytes", 0)
    monkeypatch.setattr("motionrep.jit.numba_loaded", lambda: False)
    assert _numbers.use_compiled(600) is False
    assert _numbers.use_compiled(300) is False
    assert _numbers.use_compiled(200) is True  # 1100 bytes would pass the budget: from now on, compiled
    assert _numbers.use_compiled(5000) is True
    monkeypatch.setattr(_numbers, "_numpy_path_bytes", 0)
    monkeypatch.setattr("motionrep.jit.numba_loaded", lambda: True)
    assert _numbers.use_compiled(10) is True  # numba's start-up already paid


def test_reading_a_small_file_does_not_import_numba(tmp_path):
    path = tmp_path / "small.bvh"
    path.write_text(bvh_text(NUMBERS * 5))
    code = ("import sys, motionrep\n"
            "assert 'numba' not in sys.modules and 'numpy' not in sys.modules\n"
            "from motionrep.io import read_bvh\n"
            "from motionrep.present.info import info_dict\n"
            f"m = read_bvh({str(path)!r}); info_dict({str(path)!r})\n"
            "print(m.num_frames, sorted(k for k in sys.modules if k.split('.')[0] in ('numba', 'scipy', 'llvmlite')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["25", "[]"]
