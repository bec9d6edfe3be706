"""The version-2 and version-3 payload stream of ``transform`` (:mod:`motionrep_transform._stream2`, the compiled
coder in ``_c/mrcoder.c``): lossless round trips of any integers the format holds, the same bytes every time and from
every thread, and hostile bytes refused with one ``PayloadError`` (never a crash, never a huge allocation)."""

from __future__ import annotations

import random
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from motionrep.errors import PayloadError
from motionrep_transform import _ccoder, _stream2
from motionrep_transform._stream import Quantised
from motionrep_transform._wavelet import level_sizes, num_levels

LIMIT = (1 << 62) - 1


def quantised(frames: int, features: int, region: int = 16, seed: int = 0, scale: float = 3.0,
              constant: tuple[int, ...] = ()) -> Quantised:
    """Random coefficients shaped like a clip's: Laplacian, larger at coarse levels; ``constant`` features zero."""
    rng = np.random.default_rng(seed)
    sizes = level_sizes(frames, num_levels(frames))
    coeffs = []
    for k, n in enumerate(sizes):
        width = scale * 2.0 ** (len(sizes) - k) if k else 1000.0
        c = np.rint(rng.laplace(0.0, width, size=(n, features)) * (rng.random((n, features)) < 0.6))
        c[:, list(constant)] = 0
        coeffs.append(c.astype(np.int64))
    regions = -(-frames // region)
    return Quantised(frames, features, region, rng.integers(-60, 60, features), rng.integers(-200, 30, regions),
                     coeffs)


def assert_same(a: Quantised, b: Quantised) -> None:
    assert (a.num_frames, a.num_features, a.region_frames) == (b.num_frames, b.num_features, b.region_frames)
    np.testing.assert_array_equal(a.region_exponents, b.region_exponents)
    active = np.any(np.concatenate(a.coefficients) != 0, axis=0)
    np.testing.assert_array_equal(np.asarray(a.feature_exponents)[active], b.feature_exponents[active])
    assert np.all(b.feature_exponents[~active] == 0)  # not stored: all-zero features decode at any step
    assert len(a.coefficients) == len(b.coefficients)
    for x, y in zip(a.coefficients, b.coefficients):
        np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("frames,features,region", [(1, 1, 4), (3, 2, 4), (4, 1, 16), (5, 7, 4), (24, 3, 16),
                                                     (100, 13, 16), (257, 40, 7), (1000, 5, 65536)])
@pytest.mark.parametrize("version", [2, 3])
def test_round_trip(frames, features, region, version):
    q = quantised(frames, features, region, seed=frames, constant=(0,) if features > 2 else ())
    data = _stream2.pack(q, version)
    assert _stream2.declared(data, version) == (frames, features, region)
    assert_same(q, _stream2.unpack(data, version))


def test_version_3_is_the_default_and_other_versions_are_refused():
    q = quantised(257, 40, 7, seed=3)
    assert _stream2.pack(q) == _stream2.pack(q, 3) != _stream2.pack(q, 2)
    for version in (1, 4):
        with pytest.raises(ValueError, match="version"):
            _stream2.pack(q, version)
        with pytest.raises(ValueError, match="version"):
            _stream2.unpack(_stream2.pack(q), version)


def test_extreme_values_round_trip():
    q = quantised(40, 4)
    q.coefficients[0][0] = [LIMIT, -LIMIT, 0, 1]  # the approximation's differences then reach 2 ** 63 - 2
    q.coefficients[0][-1] = [-LIMIT, LIMIT, 1, -1]
    q.coefficients[-1][3] = [LIMIT, -LIMIT, -1, 5]
    q = Quantised(q.num_frames, 4, 16, np.array([32767, -32767, 0, 5]), np.array([-32767, 32767, 0]),
                  q.coefficients)
    assert_same(q, _stream2.unpack(_stream2.pack(q)))


def test_values_the_format_cannot_hold_are_refused_by_the_encoder():
    q = quantised(40, 4)
    q.coefficients[1][0, 0] = LIMIT + 1
    with pytest.raises(ValueError):
        _stream2.pack(q)
    q = quantised(40, 4)
    with pytest.raises(ValueError):
        _stream2.pack(Quantised(40, 4, 16, np.array([40000, 0, 0, 0]), q.region_exponents, q.coefficients))


def test_the_same_bytes_every_time_and_from_every_thread():
    qs = [quantised(300, 20, seed=s) for s in range(6)]
    first = [_stream2.pack(q) for q in qs]
    with ThreadPoolExecutor(4) as pool:  # the coder releases the GIL: these run at once
        assert list(pool.map(_stream2.pack, qs * 3)) == first * 3
        decoded = list(pool.map(_stream2.unpack, first * 3))
    for q, d in zip(qs * 3, decoded):
        assert_same(q, d)


def test_a_nearly_constant_clip_is_padded_to_the_values_per_byte_limit():
    frames, features = 20000, 60
    q = quantised(frames, features, seed=1, constant=tuple(range(1, features)))
    for c in q.coefficients[1:]:
        c[:] = 0  # one feature, approximation only, one step: a few bytes of coded data
    q = Quantised(frames, features, 16, q.feature_exponents, np.zeros_like(q.region_exponents), q.coefficients)
    data = _stream2.pack(q)
    assert len(data) * _stream2.VALUES_PER_BYTE >= frames * features + features + -(-frames // 16)
    assert data.endswith(b"\0\0\0")
    assert_same(q, _stream2.unpack(data))


def _head(*values: int) -> bytes:
    out = bytearray()
    for v in values:
        while True:
            out.append((v & 0x7F) | (0x80 if v >> 7 else 0))
            v >>= 7
            if not v:
                break
    return bytes(out)


@pytest.mark.parametrize("data,words", [
    (b"", "head"),
    (_head(99), "head"),
    (bytes([0x80, 0x80, 0x80, 0x80, 0x80, 0x01]), "head"),  # a count of six bytes
    (bytes([0x81, 0x00]) + _head(0, 0), "head"),  # not the shortest form
    (_head(2 ** 32, 0, 0) + bytes(10), "head"),  # 2 ** 32 + 1 frames
    (_head(0, 2 ** 20, 0), "head"),  # 2 ** 20 + 1 features
    (_head(0, 0, 65536), "head"),  # a region of 65537 frames
    (_head(10 ** 6, 50, 15) + bytes(100), "cannot be held"),
])
def test_malformed_heads_are_refused(data, words):
    with pytest.raises(PayloadError, match=words):
        _stream2.unpack(data)


def test_truncated_and_trailing_bytes_are_refused():
    data = _stream2.pack(quantised(200, 10, seed=4))
    with pytest.raises(PayloadError, match="ends early"):
        _stream2.unpack(data[:len(data) // 2])
    with pytest.raises(PayloadError, match="after the coded data"):  # (a byte within the ending is harmless)
        _stream2.unpack(data + bytes(8) + b"\x07")
    assert_same(_stream2.unpack(data), _stream2.unpack(data + bytes(5)))  # zero padding is allowed


def test_mutants_are_refused_or_decode_to_their_declared_shapes():
    """Random damage (bytes overwritten, inserted, removed, the head edited) gives a PayloadError or integers of
    the declared shapes, never another exception (``tests/fuzz/payloads.py`` runs many more through the core)."""
    originals = [_stream2.pack(quantised(f, d, seed=f)) for f, d in ((60, 9), (333, 30), (7, 2))]
    rng = random.Random(0)
    outcomes = {"refused": 0, "decoded": 0}
    for n in range(600):
        b = bytearray(originals[n % 3])
        for _ in range(rng.randrange(1, 5)):
            what, at = rng.random(), rng.randrange(len(b))
            if what < 0.5:
                b[at] = rng.randrange(256)
            elif what < 0.7:
                b.insert(at, rng.randrange(256))
            elif what < 0.9:
                del b[at]
            else:
                del b[at:]
            if not b:
                b.append(rng.randrange(256))
        if n % 2:
            b[rng.randrange(min(5, len(b)))] = rng.randrange(256)
        try:
            q = _stream2.unpack(bytes(b))
        except PayloadError as exc:
            assert "\n" not in str(exc)
            outcomes["refused"] += 1
            continue
        assert sum(len(c) for c in q.coefficients) == q.num_frames
        assert all(c.shape == (len(c), q.num_features) for c in q.coefficients)
        assert np.abs(np.concatenate(q.coefficients)).max(initial=0) <= LIMIT
        assert np.abs(q.region_exponents).max() <= 32767 and np.abs(q.feature_exponents).max() <= 32767
        outcomes["decoded"] += 1
    assert outcomes["refused"] > 300, outcomes  # most damage is caught


def _both_loops(data: bytes, version: int, feature_major: bool) -> list:
    """``(error, fexp, rexp, coef)`` of the decoder's own loop over the details and of the generic one
    (``mrc_decode_reference``), each into arrays filled with 7 first."""
    F, D, region = _ccoder.declared(data)
    out = []
    for reference in (False, True):
        arrays = [np.full(n, 7, np.int64) for n in (D, -(-F // region), F * D)]
        try:
            _ccoder.decode(data, *arrays, version, feature_major, reference)
            error = None
        except ValueError as exc:
            error = str(exc)
        out.append((error, *arrays))
    return out


def _clip_shaped(frames: int, features: int, seed: int, keep: float) -> Quantised:
    """Coefficients with what the decoder's loop treats apart: runs of zeros, rows whose neighbourhood is all zero
    (fewer the larger ``keep``, the fraction of detail coefficients kept), non-zero neighbours in a row (the next
    feature's context), all-zero features between active ones, magnitudes up to the format's limit."""
    q = quantised(frames, features, seed=seed, constant=tuple(range(1, features, 3)))
    rng = np.random.default_rng(seed)
    for c in q.coefficients[1:]:
        c[rng.random(c.shape) > keep] = 0
        big = rng.random(c.shape) < 0.002
        c[big] = rng.integers(-LIMIT, LIMIT, int(big.sum()))
    return q


@pytest.mark.parametrize("frames,features,keep", [(3, 2, 0.2), (40, 5, 0.2), (333, 30, 0.2), (333, 30, 0.003),
                                                  (1200, 7, 0.01), (90, 1100, 0.2)])
@pytest.mark.parametrize("version", [2, 3])
def test_the_decoders_loop_decodes_what_the_generic_loop_does(frames, features, keep, version):
    """mrc_decode_version's own loop over the details (the zero flags straight-line, quiet rows apart, contexts per
    row first) against
    the encoder's generic loop run in the decoding direction: the same integers from payloads (1100 features: the
    per-feature contexts wrap at 1024) and from damaged ones (random decisions: every path of the loop), in both
    layouts, and the same error."""
    rng = random.Random(frames)
    data = _stream2.pack(_clip_shaped(frames, features, frames, keep), version)
    head = len(_head(frames - 1, features - 1, 15))  # (region 16) the body's damage only
    mutants = [data]
    for _ in range(40):
        b = bytearray(data)
        for _ in range(rng.randrange(1, 4)):
            b[rng.randrange(head, len(b))] = rng.randrange(256)
        mutants.append(bytes(b))
    mutants.append(data[:head] + bytes(rng.randrange(256) for _ in range(len(data) - head)))  # noise as the body
    decoded = 0
    for b in mutants:
        for feature_major in (False, True):
            (e1, *a1), (e2, *a2) = _both_loops(b, version, feature_major)
            assert e1 == e2
            for x, y in zip(a1, a2):
                np.testing.assert_array_equal(x, y)
            decoded += e1 is None
    assert decoded >= 2  # the payload itself, in both layouts
    (error, *arrays), _ = _both_loops(data, version, False)
    assert error is None and np.array_equal(arrays[2].reshape(frames, features),
                                            np.concatenate(_clip_shaped(frames, features, frames, keep).coefficients))
