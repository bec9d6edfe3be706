"""The svd codec's compiled decoder (``_csvd``) from Python: an object that was never initialised refuses to sample
(a ValueError, never a call through an empty sampler); the values it decodes, bit for bit, against the arithmetic
written out in numpy."""

from __future__ import annotations

import numpy as np
import pytest

from motionrep_svd import _csvd


def test_an_uninitialised_decoder_refuses_to_sample():
    empty = _csvd.Decoder.__new__(_csvd.Decoder)
    with pytest.raises(ValueError, match="not initialised"):
        empty.sampler
    with pytest.raises(ValueError, match="not initialised"):
        _csvd.sample(np.zeros(2), np.zeros((3, 2)), empty)


def _places(F, times, dtype):
    """Each time's place among ``F`` frames as the decoder finds it: the clamped time ``t``, its position
    ``t (F - 1)``, frame ``j`` and the next ``k1``, the fraction between them in ``dtype`` and one minus it."""
    t = np.clip(times, 0.0, 1.0)
    pos = t * float(F - 1)
    j = np.minimum(np.floor(pos), max(F - 2, 0)).astype(np.int64)
    frac = (pos - j).astype(dtype)
    return t, pos, j, np.minimum(j + 1, F - 1), frac, dtype.type(1.0) - frac


def _direct(coeff, mean, basis, times):
    """The arithmetic a decoder decodes each frame with, written out in numpy, one IEEE operation at a time in the
    C code's order (numpy's elementwise + and * are single IEEE operations, never fused): coefficient rows
    interpolated at each time, then the mean plus each component in order."""
    _, _, j, k1, frac, rest = _places(coeff.shape[0], times, coeff.dtype)
    with np.errstate(invalid="ignore", over="ignore"):  # inf * 0.0 is NaN, as in C
        c = coeff[j] * rest[:, None] + coeff[k1] * frac[:, None]
        y = np.broadcast_to(mean, (times.size, mean.size)).copy()
        for k in range(coeff.shape[1]):
            y = y + c[:, k:k + 1] * basis[k]
    return y


def _reference(coeff, mean, basis, times):
    """The decoder's values written out in numpy: every frame decoded at its time ``i / (F - 1)`` (:func:`_direct`),
    then each time's two frames blended in the arrays' dtype, ``R_j (1 - a) + R_(j+1) a`` (``a`` rounded to it); a
    time that is a frame's time, or whose fraction rounds to 0 or 1, gives that frame (``R 1 + R 0``: its values);
    a feature of zero weights (its mean finite and not -0.0) its mean when every coefficient is far from
    overflowing."""
    T = coeff.dtype.type
    F = coeff.shape[0]
    frames = _direct(coeff, mean, basis, np.arange(F) / (F - 1) if F > 1 else np.zeros(1))
    t, pos, j, k1, frac, rest = _places(F, times, coeff.dtype)
    k = np.minimum(np.floor(pos + 0.5), F - 1).astype(np.int64) if F > 1 else np.zeros(t.size, np.int64)
    on = np.ones(t.size, bool) if F < 2 else k / (F - 1) == t
    alone = np.where(on, k, np.where(frac == 0, j, np.where(rest == 0, k1, -1)))
    first, second = np.where(alone >= 0, alone, j), np.where(alone >= 0, alone, k1)
    re, fr = np.where(alone >= 0, T(1.0), rest).astype(coeff.dtype), np.where(alone >= 0, T(0.0), frac).astype(coeff.dtype)
    with np.errstate(invalid="ignore", over="ignore"):
        y = frames[first] * re[:, None] + frames[second] * fr[:, None]
    limit = 1e37 if coeff.dtype == np.float32 else 1e306
    zero = np.all(basis == 0, axis=0) & np.isfinite(mean) & ~((mean == 0) & np.signbit(mean))
    if np.all(np.abs(coeff) < limit):
        y[:, zero] = mean[zero]
    return y.astype(np.float64)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_features_constant_over_the_clip_are_found_exactly_and_written_as_their_means(dtype):
    """A feature whose basis column is all zeros (+0.0 or -0.0) and whose mean is finite and not -0.0 is the same
    bits at every time where the interpolated coefficients are finite (mean + c * 0 + ...: a sum of zeros of
    either sign added to the mean, +0.0 + -0.0 being +0.0): the decoder reports it (constant_features, for the
    runtime decoder) when every coefficient is far from overflowing, and then writes the mean at every time (else
    it blends the frames it decoded: NaN where a frame's sum was).  Compared bit for bit with the arithmetic
    written out in numpy: scalar IEEE operations in a fixed order, no FMA contraction, no fast-math, so the same
    bits in any vector lane."""
    from motionrep_svd._codec import SVDDecoder

    rng = np.random.default_rng(3)
    F, r, D = 40, 5, 12
    coeff = rng.normal(size=(F, r)).astype(dtype) * 3  # negative coefficients: c * 0.0 is -0.0
    basis = rng.normal(size=(r, D)).astype(dtype)
    mean = rng.normal(size=D).astype(dtype)
    basis[:, [1, 4, 5, 7, 9]] = 0.0
    basis[2, 4] = -0.0
    mean[[4, 5]] = [0.0, -0.0]  # +0.0 stays +0.0 whatever the zeros' signs; -0.0 may not
    mean[9] = np.inf
    decoder = SVDDecoder({"coefficients": coeff, "mean": mean, "basis": basis}, dtype)
    constant = decoder.constant_features
    assert np.flatnonzero(np.isfinite(constant)).tolist() == [1, 4, 7]
    assert constant[[1, 4, 7]].tobytes() == mean[[1, 4, 7]].astype(np.float64).tobytes()
    times = np.concatenate([[0.0, 1.0, 0.5, -1.0, 2.0], rng.random(300)])
    want = _reference(coeff, mean, basis, times)
    got = np.asarray(decoder(times), dtype=np.float64)
    assert got.tobytes() == want.tobytes()
    for i in (0, 3, 7):  # the one-time path (every feature summed) gives the same bits
        assert np.asarray(decoder(times[i:i + 1]), dtype=np.float64).tobytes() == want[i:i + 1].tobytes()
    bad = coeff.copy()
    bad[3, 2] = np.inf  # inf * 0.0 is NaN: nothing is constant then, and blocks near frame 3 sum every feature
    decoder = SVDDecoder({"coefficients": bad, "mean": mean, "basis": basis}, dtype)
    assert not np.isfinite(decoder.constant_features).any()
    got, want = np.asarray(decoder(times), dtype=np.float64), _reference(bad, mean, basis, times)
    assert np.isnan(got[:, 1]).any() and np.array_equal(np.isnan(got), np.isnan(want))
    assert np.nan_to_num(got).tobytes() == np.nan_to_num(want).tobytes()
    huge = coeff.copy()
    huge[0, 0] = np.finfo(dtype).max  # finite, but its interpolation could overflow: not reported constant
    assert not np.isfinite(SVDDecoder({"coefficients": huge, "mean": mean, "basis": basis}, dtype)
                           .constant_features).any()


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("r", [1, 7, 8, 13, 39])
def test_the_block_path_interpolates_to_the_arithmetic_written_out(dtype, r):
    """Blocks of times interpolate their coefficients eight times by eight coefficients at a time, turned with
    shuffles (the last tile of a row overlapping the one before it when r is no multiple of eight, fewer than
    eight times or coefficients one at a time): every value is still the one product-and-sum of the arithmetic
    written out in numpy, bit for bit (scalar IEEE operations, no FMA contraction, no fast-math: the same bits in
    any vector lane, on any CPU), for blocks of every length."""
    from motionrep_svd._codec import SVDDecoder

    rng = np.random.default_rng(r)
    F, D = 50, 21
    coeff = (rng.normal(size=(F, r)) * 10.0 ** rng.integers(-3, 4, (F, r))).astype(dtype)
    basis = rng.normal(size=(r, D)).astype(dtype)
    mean = rng.normal(size=D).astype(dtype)
    decoder = SVDDecoder({"coefficients": coeff, "mean": mean, "basis": basis}, dtype)
    times = np.concatenate([[0.0, 1.0, 0.5, -1.0, 2.0, 1.0 - 1e-17, 49.5 / 49], rng.random(1000)])
    for n in (times.size, 64, 63, 9, 8, 7, 2):
        got = np.asarray(decoder(times[:n]), dtype=np.float64)
        assert got.tobytes() == _reference(coeff, mean, basis, times[:n]).tobytes(), n


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("F", [1, 2, 3, 49, 50, 130])
def test_every_frame_time_decodes_to_the_frame_as_before(dtype, F):
    """At the frames' own times ``i / (F - 1)`` (those the encoder measures the bound at, and a decompressed clip
    has) the decoder gives what the direct arithmetic gives there, bit for bit, alone or in a block: the files
    written and measured before it decode as they did (49 frames: ``(i / 48) * 48`` is not always ``i`` in floating
    point, so some of those times fall a hair before their frame)."""
    from motionrep_svd._codec import SVDDecoder

    rng = np.random.default_rng(F)
    r, D = 6, 11
    coeff = rng.normal(size=(F, r)).astype(dtype)
    basis = rng.normal(size=(r, D)).astype(dtype)
    mean = rng.normal(size=D).astype(dtype)
    decoder = SVDDecoder({"coefficients": coeff, "mean": mean, "basis": basis}, dtype)
    times = np.arange(F) / (F - 1) if F > 1 else np.zeros(1)
    want = _direct(coeff, mean, basis, times).astype(np.float64)
    assert np.asarray(decoder(times), dtype=np.float64).tobytes() == want.tobytes()
    for i in range(0, F, max(1, F // 7)):
        assert np.asarray(decoder(times[i:i + 1]), dtype=np.float64).tobytes() == want[i:i + 1].tobytes()


@pytest.mark.parametrize("D", [1, 3, 8, 64, 65, 130])
def test_blocks_of_any_width_blend_the_frames(D):
    """The frames are blended in chunks of 64 features, eight by eight (fewer one at a time): every width gives the
    values written out in numpy, bit for bit, for blocks of every length."""
    from motionrep_svd._codec import SVDDecoder

    rng = np.random.default_rng(D)
    F, r = 33, 5
    coeff = rng.normal(size=(F, r)).astype(np.float32)
    basis = rng.normal(size=(r, D)).astype(np.float32)
    mean = rng.normal(size=D).astype(np.float32)
    decoder = SVDDecoder({"coefficients": coeff, "mean": mean, "basis": basis}, np.float32)
    times = np.concatenate([[0.0, 1.0, 0.5, 1.0 - 1e-17, 16.5 / 32], rng.random(200)])
    for n in (times.size, 64, 63, 9, 8, 7, 1):
        got = np.asarray(decoder(times[:n]), dtype=np.float64)
        assert got.tobytes() == _reference(coeff, mean, basis, times[:n]).tobytes(), n


def test_the_frames_a_decoder_prepares_count_as_decode_work():
    """Preparing a decoder decodes and holds every frame, so a payload declares ``F (r + 1) D`` units of work: one of
    rank 0 (no coefficients, a few bytes) over a million frames of 1100 features is refused, where counting only
    ``F r D`` let it through (its prepared frames would be 4.6 GB)."""
    from motionrep.errors import PayloadError
    from motionrep.plugin.codec import Payload
    from motionrep_svd._codec import SVDCodec

    F, D = 1_000_000, 1100
    arrays = {"mean": np.zeros(D, np.float32), "coefficients": np.zeros((F, 0), np.float32),
              "basis": np.zeros((0, D), np.float32)}
    with pytest.raises(PayloadError, match="decode work"):
        SVDCodec().check_payload(Payload(arrays, {"rank": 0}), F)
    small = {"mean": np.zeros(D, np.float32), "coefficients": np.zeros((900, 0), np.float32),
             "basis": np.zeros((0, D), np.float32)}
    SVDCodec().check_payload(Payload(small, {"rank": 0}), 900)
