"""motionrep.plugin.coding: quantisation, the integer model, the range coder and step bisection."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from motionrep.plugin.coding import (MAX_MAGNITUDE, IntegerDecoder, IntegerEncoder, MatrixModel, Model, decode_integers,
                              dequantize, encode_integers, fit_matrix_model, fit_model, largest_passing,
                              largest_passing_each, quantize, step_scale)
from motionrep.errors import ParameterError, PayloadError

# Bytes written by motionrep 0.1.0 for GOLDEN_GROUPS(); they must decode to the same integers forever (files in
# the wild hold such bytes), and encoding must keep giving them (a changed coder would change every file).
GOLDEN = bytes.fromhex(
    "00ff45799db58663f52086ffc8c9d53e645f28205a6aee95ea2f5f10fc7e0040174a8653ad7a375e759ca9cb34a0025349259bff1d"
    "054e98b51387dfca1803e1993965bf4bc67d3dd9c096fb09c649cc4defbbab462289ef14c2dbf8fa995ced403c524e0000780054caad"
    "22a26370ed")


def golden_groups() -> list[np.ndarray]:
    rng = np.random.default_rng(42)
    v = np.round(rng.laplace(0, 3, 200)).astype(np.int64)
    v[::5] = 0
    v[7] = 1000
    v[8] = -(2 ** 40 + 3)
    return [v, np.zeros(50, np.int64), np.arange(-5, 6)]


# Bytes of encode_matrices(golden_matrices()) (the Fourier codec's payload version 4 uses them): stable forever too.
GOLDEN_MATRICES = bytes.fromhex(
    "631700609146b2113134e3c7d2039bc4a8cf1b77cb16263f5cc5aa861b252683dd7a5f9c6fdf3e9c253c6253da272e0176831e051e"
    "c235e2cbd7b73b1465729fa63479f4e33a2c1cfa00dffe38525363d6504df8c811d3445956f72b2313ae01e6f98a38d4e6108b0cc4"
    "51abff2fd9eeacd409ec61017a0dac106c02247d6649fd4d7cf3e03e1eadb4bcac5a6cdef29ddf3e1ead91e1f4c3914d5e5f436f5e"
    "3bebcc48b1468a1dc815a58fe31bc2be143868ae274b5151fa4750edef54bb061b67c2c61161872f3187d7269dcfed73e661872f31"
    "87d7269df7b815e7385c446eb5191c5fc7170e7773ec6e0639c6da7301fcecb90f50f71c11209278f70075cf13562089c184151563"
    "60634000000060")


def golden_matrices() -> list[np.ndarray]:
    """Rows of very different magnitudes (one per row), their transpose (one per column), a plain matrix (one
    model), an empty one and a vector."""
    rng = np.random.default_rng(43)
    rows = np.round(rng.laplace(0, 1, (12, 9)) * (2.0 ** rng.integers(0, 12, (12, 1)))).astype(np.int64)
    rows[4] = 0
    rows[7, 3] = -(2 ** 33 + 5)
    cols = rows[:9, :].T.copy()
    flat = np.round(rng.laplace(0, 4, (5, 6))).astype(np.int64)
    return [rows, cols, flat, np.zeros((0, 3), np.int64), np.arange(-3, 4)[None, :]]


def round_trip(values: np.ndarray, model: Model | None = None) -> tuple[bytes, np.ndarray]:
    model = model or fit_model(values)
    enc = IntegerEncoder()
    enc.encode_models([model])
    enc.encode(values, model)
    data = enc.to_bytes()
    dec = IntegerDecoder(data)
    (back,) = dec.decode_models(1)
    assert back == model
    out = dec.decode(values.size, back)
    dec.finish()
    return data, out


def test_golden_bytes_are_stable():
    groups = golden_groups()
    assert encode_integers(groups) == GOLDEN
    out = decode_integers(GOLDEN, [g.size for g in groups])
    for a, b in zip(out, groups):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("scale", [0.0, 0.05, 0.4, 1.0, 3.0, 20.0, 300.0, 1e5, 1e9, 1e15])
def test_round_trip_and_cost(scale):
    rng = np.random.default_rng(int(scale * 10) % 1000)
    v = np.round(rng.laplace(0, scale, 3000)).astype(np.int64) if scale else np.zeros(3000, np.int64)
    v[::9] = 0
    model = fit_model(v)
    data, out = round_trip(v, model)
    np.testing.assert_array_equal(out, v)
    # the coder comes within a few bytes of the model's ideal code length (2 model bytes + word padding)
    assert abs(len(data) - (model.cost(v) / 8 + 2)) <= 8
    # and the fitted model is at least as good as its neighbours
    for dz, dd in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        z, d = model.zero + dz, model.decay + dd
        if 0 <= z <= 255 and 0 <= d <= 255:
            assert model.cost(v) <= Model(z, d).cost(v) + 1e-6


def test_extreme_values_and_shapes():
    v = np.array([[0, 1, -1, 15, 16, -17], [2 ** 40 + 5, -MAX_MAGNITUDE, 2 ** 53 + 1, 2 ** 53 - 1, 31, -32]])
    for model in (fit_model(v), Model(255, 0), Model(0, 255)):
        _, out = round_trip(v, model)  # any model codes any value, a poor one at more bits
        np.testing.assert_array_equal(out, v.reshape(-1))
    with pytest.raises(ParameterError):
        IntegerEncoder().encode(np.array([MAX_MAGNITUDE + 1]), Model(0, 0))
    with pytest.raises(ParameterError):
        IntegerEncoder().encode(np.array([0.5]), Model(0, 0))


def test_empty_groups_and_raw_fields():
    enc = IntegerEncoder()
    enc.encode(np.zeros(0, np.int64), Model(3, 4))
    enc.encode_raw([0, 1, 2 ** 40 - 1, 12345], 40)
    enc.encode_raw([1, 0, 1], 1)
    data = enc.to_bytes()
    dec = IntegerDecoder(data)
    assert dec.decode(0, Model(3, 4)).size == 0
    np.testing.assert_array_equal(dec.decode_raw(4, 40), [0, 1, 2 ** 40 - 1, 12345])
    np.testing.assert_array_equal(dec.decode_raw(3, 1), [1, 0, 1])
    dec.finish()
    assert IntegerEncoder().to_bytes() == b""
    with pytest.raises(ParameterError):
        IntegerEncoder().encode_raw([4], 2)
    with pytest.raises(ParameterError):
        IntegerEncoder().encode_raw([0], 63)


def test_damaged_data_gives_payload_errors():
    with pytest.raises(PayloadError, match="32-bit words"):
        IntegerDecoder(b"\x00\x01\x02")
    groups = golden_groups()
    counts = [g.size for g in groups]
    with pytest.raises(PayloadError, match="left over"):
        decode_integers(GOLDEN + b"\x12\x34\x56\x78" * 4, counts)
    with pytest.raises(PayloadError):
        IntegerDecoder(GOLDEN).decode(-1, Model(0, 0))
    assert issubclass(PayloadError, ValueError)


def test_model_validation_and_probabilities():
    for bad in (-1, 256, 1.5, True, "3"):
        with pytest.raises(ParameterError):
            Model(bad, 0)
        with pytest.raises(ParameterError):
            Model(0, bad)
    for z, d in ((0, 0), (255, 255), (128, 77)):
        p = Model(z, d).probabilities
        assert p.shape == (74,) and np.all(p >= 0) and abs(p.sum() - 1) < 1e-12
    assert Model(255, 0).probabilities[0] > 0.9999 and Model(0, 0).probabilities[0] < 1e-4
    assert fit_model([]) == Model(255, 0)


def test_quantize_dead_zone_and_errors():
    x = np.array([-2.6, -0.55, -0.4, 0.0, 0.3, 0.5, 0.74, 1.49, 2.5])
    np.testing.assert_array_equal(quantize(x, 1.0), [-3, -1, 0, 0, 0, 1, 1, 1, 3])
    np.testing.assert_array_equal(quantize(x, 1.0, rounding=0.25), [-2, 0, 0, 0, 0, 0, 0, 1, 2])
    np.testing.assert_array_equal(quantize(x, np.full(9, 0.5)), [-5, -1, -1, 0, 1, 1, 1, 3, 5])
    np.testing.assert_allclose(dequantize(quantize(x, 0.1), 0.1), x, atol=0.05 + 1e-12)
    for step in (0.0, -1.0, np.nan, np.inf):
        with pytest.raises(ParameterError):
            quantize(x, step)
    with pytest.raises(ParameterError):
        quantize([np.nan], 1.0)
    with pytest.raises(ParameterError):
        quantize(x, 1.0, rounding=1.0)
    with pytest.raises(ParameterError):
        quantize([1e300], 1e-300)


def test_step_scale_is_exact():
    assert step_scale(0) == 1.0 and step_scale(8) == 2.0 and step_scale(-16) == 0.25
    i = np.arange(-100, 100)
    np.testing.assert_allclose(step_scale(i), 2.0 ** (i / 8), rtol=4e-16)
    assert isinstance(step_scale(3), float)


def test_largest_passing():
    assert largest_passing(lambda i: i <= 37, -100, 100) == 37
    assert largest_passing(lambda i: True, -5, 5) == 5
    assert largest_passing(lambda i: False, -5, 5) is None
    calls = []
    largest_passing(lambda i: calls.append(i) or i <= 500, 0, 1024)
    assert len(calls) <= 13
    with pytest.raises(ParameterError):
        largest_passing(lambda i: True, 3, 2)


def test_largest_passing_each_in_lockstep():
    limits = np.array([3, -200, 50, 7, 10])
    seen = []

    def passes(idx):
        seen.append(idx.copy())
        return idx <= limits

    out = largest_passing_each(passes, [-10] * 5, [10, 10, 10, 100, 10])
    np.testing.assert_array_equal(out, [3, -11, 10, 7, 10])
    assert len(seen) <= 2 + 8  # both ends, then bisection of the widest range (110 -> 7 steps)
    # entries that are settled are tested at their answer while the others move on
    assert all(s[1] == -11 and s[4] == 10 for s in seen[2:])
    with pytest.raises(ParameterError):
        largest_passing_each(passes, [0, 0], [1])


def test_largest_passing_each_tests_low_only_when_an_entry_fails_high():
    """Every entry passes at its high end: one call, the high ends; one fails there: low is tested next."""
    seen = []

    def passes(idx):
        seen.append(idx.copy())
        return idx <= 5

    np.testing.assert_array_equal(largest_passing_each(passes, [-10, -3], [4, 5]), [4, 5])
    assert len(seen) == 1
    seen.clear()
    np.testing.assert_array_equal(largest_passing_each(passes, [-10, -3], [4, 9]), [4, 5])
    np.testing.assert_array_equal(seen[1], [-10, -3])


def test_largest_passing_each_without_testing_the_ends():
    """test_ends=False: neither low nor high is ever tested (high taken to fail, low to pass), two calls fewer;
    an entry that never passes ends at low, one whose limit is at or above high at high - 1."""
    limits = np.array([3, -200, 50, 7, -10])
    seen = []

    def passes(idx):
        seen.append(idx.copy())
        return idx <= limits

    out = largest_passing_each(passes, [-10] * 5, [10] * 5, test_ends=False)
    np.testing.assert_array_equal(out, [3, -10, 9, 7, -10])
    assert len(seen) == 5  # a range of 20 bisected: 5 steps, no test of either end
    assert all(np.all((s > -10) | (out == -10)) and np.all(s < 10) for s in seen)


def test_matrices_golden_bytes_layouts_and_round_trip():
    matrices = golden_matrices()
    assert [fit_matrix_model(m).layout for m in matrices] == [1, 2, 0, 0, 0]
    enc = IntegerEncoder()
    enc.encode_matrices(matrices)
    assert enc.to_bytes() == GOLDEN_MATRICES
    dec = IntegerDecoder(GOLDEN_MATRICES)
    for a, b in zip(dec.decode_matrices([m.shape for m in matrices]), matrices):
        np.testing.assert_array_equal(a, b)
    dec.finish()
    # one model per row pays where rows differ in scale: fewer bytes than one model, its parameters included
    rows = matrices[0]
    single = MatrixModel(0, (fit_model(rows),))
    assert fit_matrix_model(rows).cost(rows) < 0.9 * single.cost(rows)
    # any layout the caller chooses decodes, between other items of the stream; cost is what is written
    for model in (single, fit_matrix_model(rows), MatrixModel(2, tuple(Model(0, fit_model(c).decay) for c in rows.T))):
        enc = IntegerEncoder()
        enc.encode_raw([5], 3)
        enc.encode_matrices([rows], [model])
        enc.encode_raw([6], 3)
        data = enc.to_bytes()
        assert abs(8 * len(data) - model.cost(rows)) < 8 * 12
        dec = IntegerDecoder(data)
        assert dec.decode_raw(1, 3)[0] == 5
        np.testing.assert_array_equal(dec.decode_matrices([rows.shape])[0], rows)
        assert dec.decode_raw(1, 3)[0] == 6
        dec.finish()
    # a row of zeros costs next to nothing under its level-16 model
    zero_rows = np.zeros((40, 50), np.int64)
    zero_rows[0, :3] = [1, -2, 3]
    assert fit_matrix_model(zero_rows).cost(zero_rows) < 16 * 8


def test_matrix_models_are_validated_and_damage_is_refused():
    with pytest.raises(ParameterError):
        MatrixModel(3, (Model(0, 0),))
    with pytest.raises(ParameterError):
        MatrixModel(1, (Model(17, 3),))  # not at a level
    with pytest.raises(ParameterError):
        MatrixModel(1, (Model(255, 3),))  # a line of zeros has decay 0
    with pytest.raises(ParameterError):
        IntegerEncoder().encode_matrices([np.zeros((2, 2))])  # floats
    with pytest.raises(ParameterError):
        IntegerEncoder().encode_matrices([np.zeros((2, 2), np.int64)], [MatrixModel(1, (Model(0, 0),))])
    enc = IntegerEncoder()
    enc.encode_raw([3], 2)  # layout 3
    enc.encode_raw([0] * 8, 8)
    with pytest.raises(PayloadError, match="layout"):
        IntegerDecoder(enc.to_bytes()).decode_matrices([(2, 2)])
    enc = IntegerEncoder()
    enc.encode_raw([1], 2)
    enc.encode_raw([17, 0, 0, 0, 0, 0], 8)  # median level 17
    with pytest.raises(PayloadError, match="level"):
        IntegerDecoder(enc.to_bytes()).decode_matrices([(2, 2)])
    matrices = golden_matrices()
    with pytest.raises(PayloadError):
        dec = IntegerDecoder(GOLDEN_MATRICES[:-8])
        dec.decode_matrices([m.shape for m in matrices])
        dec.finish()


def test_bytes_identical_in_another_process():
    code = ("import numpy as np, sys; sys.path.insert(0, 'tests'); from test_coding import golden_groups; "
            "from test_coding import golden_matrices; from motionrep.plugin.coding import encode_integers, IntegerEncoder; "
            "enc = IntegerEncoder(); enc.encode_matrices(golden_matrices()); "
            "sys.stdout.write(encode_integers(golden_groups()).hex() + ' ' + enc.to_bytes().hex())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=str(__import__("pathlib").Path(__file__).resolve().parent.parent))
    groups, matrices = out.stdout.split()
    assert bytes.fromhex(groups) == GOLDEN and bytes.fromhex(matrices) == GOLDEN_MATRICES
