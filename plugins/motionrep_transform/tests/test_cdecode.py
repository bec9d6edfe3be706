"""The C decoder of ``transform`` payloads (``_c/mrtransform.c``) against what it replaced: constriction's range
decoder and models (``motionrep.plugin.coding``) for the integer coding, and the Python decoder
(``transform_reference_v1``) for whole payloads, valid and damaged: the same values, bit for bit, and the same
one-line errors.  And the library alone: plain C99, no Python, built and run by the machine's C compiler.

Compared bit for bit on purpose: both sides are IEEE double arithmetic in a fixed order (numpy element-wise
operations and C compiled without fused multiply-add or fast-math), no BLAS.
"""

from __future__ import annotations

import random
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import transform_reference_v1 as reference
from helpers import SHARED_DATA, requires_shared
from motionrep.errors import PayloadError
from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, synthetic_motion
from motionrep.pipeline.compress import compress_motion
from motionrep.plugin.coding import MAX_MAGNITUDE, IntegerDecoder, IntegerEncoder, Model
from motionrep_transform import _cdecode
from motionrep_transform._decoder import STREAMS
from motionrep_transform._stream import unpack

HERE = Path(__file__).resolve().parent
C_DIR = HERE.parent / "_c"
sys.path.insert(0, str(HERE.parents[2] / "tests"))
from fuzz.mutate import mutate_bytes  # noqa: E402


def _values(rng: np.random.Generator, n: int) -> np.ndarray:
    kind = rng.integers(0, 4)
    if kind == 0:
        return rng.integers(-3, 4, n)
    if kind == 1:
        return (rng.geometric(rng.uniform(0.01, 0.9), n) - 1) * rng.choice([-1, 1], n)
    if kind == 2:  # every bit length up to 2 ** 62 - 1
        e = rng.integers(0, 62, n)
        return (np.left_shift(np.int64(1), e) + rng.integers(0, 2 ** 62, n) % np.left_shift(np.int64(1), e)
                ) * rng.choice([-1, 1], n)
    v = np.zeros(n, np.int64)
    v[rng.random(n) < 0.05] = rng.integers(-100000, 100000)
    return v


def _constriction(data: bytes, segments) -> tuple[np.ndarray, bool]:
    dec = IntegerDecoder(data)
    out = [dec.decode_raw(n, -a) if a < 0 else dec.decode(n, Model(a, b)) for a, b, n in segments]
    return (np.concatenate(out) if out else np.zeros(0, np.int64)), dec._decoder.maybe_exhausted()


def _outcome(fn, *args):
    try:
        return ("ok",) + tuple(fn(*args))
    except PayloadError as exc:
        return ("error", str(exc))


def _same(a, b) -> bool:
    if a[0] != b[0]:
        return False
    if a[0] == "error":
        return a[1] == b[1]
    return all(np.array_equal(x, y) if isinstance(x, np.ndarray) else x == y for x, y in zip(a[1:], b[1:]))


def test_integer_coding_is_constrictions_on_random_models_and_streams():
    """Random models (every zero and decay index), values of every size and raw fields of 1-62 bits: what
    constriction encoded decodes to the same values, and damaged or random words give the same values, the same
    error, and the same end-of-data state."""
    rng = np.random.default_rng(24)
    checked = errors = 0
    for trial in range(120):
        segments, enc = [], IntegerEncoder()
        for _ in range(rng.integers(1, 6)):
            n = int(rng.integers(0, 200))
            if rng.random() < 0.3:
                bits = int(rng.integers(1, 63))
                enc.encode_raw(rng.integers(0, 2 ** min(bits, 62), n), bits)
                segments.append((-bits, 0, n))
            else:
                z, d = int(rng.integers(0, 256)), int(rng.integers(0, 256))
                enc.encode(np.clip(_values(rng, n), -MAX_MAGNITUDE, MAX_MAGNITUDE), Model(z, d))
                segments.append((z, d, n))
        data = enc.to_bytes()
        streams = [data]
        for _ in range(6):
            bad = bytearray(data if rng.random() < 0.7 else rng.integers(0, 256, 4 * rng.integers(0, 40),
                                                                          dtype=np.uint8).tobytes())
            for _ in range(rng.integers(0, 4)):
                if bad:
                    bad[rng.integers(0, len(bad))] = rng.integers(0, 256)
            streams.append(bytes(bad))
        for k, stream in enumerate(streams):
            expected = _outcome(_constriction, stream, segments)
            got = _outcome(lambda d, s: (np.frombuffer(_cdecode.integers(d, s)[0], np.int64),
                                         _cdecode.integers(d, s)[1]), stream, segments)
            assert _same(expected, got), (trial, k, expected[:2], got[:2])
            assert k or expected[0] == "ok"
            errors += expected[0] == "error"
            checked += 1
    assert checked == 840 and errors > 10


def _payloads(version: int = 1) -> list[bytes]:
    """Payloads of synthetic clips in format ``version``: the encoder's integers (it writes version 3), packed as
    that version."""
    from motionrep_transform import _stream, _stream2

    cases = [(humanoid_skeleton(), 120, "2%", "root-quat-axis-angle"), (chain_skeleton(5), 37, "0.5%", "euler"),
             (humanoid_skeleton(), 3, "2%", "ortho6d"), (humanoid_skeleton(), 1, "2%", "root-quat-axis-angle"),
             (chain_skeleton(3), 300, "0.1%", "dual-quaternion"), (chain_skeleton(4), 4, "2%", "euler"),
             (chain_skeleton(4), 5, "2%", "euler")]
    written = [compress_motion(synthetic_motion(s, frames=f, seed=i), "transform", representation=r,
                               max_error=b).container.arrays["data"].tobytes() for i, (s, f, b, r) in enumerate(cases)]
    qs = [_stream2.unpack(data, 3) for data in written]
    return [_stream.pack(q) if version == 1 else _stream2.pack(q, version) for q in qs]


@pytest.fixture(scope="module")
def payloads():
    return _payloads()


@pytest.fixture(scope="module")
def payloads_v2():
    return _payloads(2)


@pytest.fixture(scope="module")
def payloads_v3():
    return _payloads(3)


def _reference_v2(data: bytes, version: int = 2) -> np.ndarray:
    """Version 2 (or 3) as main decoded it: mrcoder's integers (``_stream2.unpack``), then the numpy
    reconstruction."""
    from motionrep_transform import _stream2

    return reference.reconstruct(_stream2.unpack(data, version))


def _c_frames(data: bytes) -> tuple[np.ndarray]:
    return (np.asarray(_cdecode.decode(data, 1)).T,)


def _c_quantised(data: bytes):
    q = unpack(data)
    return (q.feature_exponents, q.region_exponents, *q.coefficients)


def _reference_quantised(data: bytes):
    q = reference.unpack(data)
    return (q.feature_exponents, q.region_exponents, *q.coefficients)


def test_valid_payloads_decode_to_the_python_decoders_bits(payloads):
    for data in payloads:
        expected = reference.decode_frames(data)
        got = np.asarray(_cdecode.decode(data, 1)).T
        assert got.shape == expected.shape and got.tobytes() == expected.tobytes()
        assert _same(_outcome(_reference_quantised, data), _outcome(_c_quantised, data))


@pytest.mark.parametrize("version", [2, 3])
def test_version_2_and_3_payloads_decode_to_the_numpy_reconstructions_bits(payloads_v2, payloads_v3, version):
    """Version 2's and 3's integers are mrcoder.c's in both decoders; dequantisation and the inverse wavelet are
    the C library's here, numpy's in the decoder it replaced: the same bits, valid or damaged (the same messages)."""
    rng = random.Random(2)
    payloads = payloads_v2 if version == 2 else payloads_v3
    for data in payloads:
        assert np.asarray(_cdecode.decode(data, version)).T.tobytes() == _reference_v2(data, version).tobytes()
    for i in range(400):
        bad = mutate_bytes(payloads[i % len(payloads)], rng)
        assert _same(_outcome(lambda d: (_reference_v2(d, version),), bad),
                     _outcome(lambda d: (np.asarray(_cdecode.decode(d, version)).T,), bad)), i


def test_damaged_payloads_give_the_python_decoders_values_or_errors(payloads):
    """Mutants (bytes overwritten, inserted, removed, truncated; half with the head's declared counts changed, as
    tests/fuzz/payloads.py makes them): every one decodes to the same frames or fails with the same message; the
    row-major unpack too.  (tests/fuzz/payloads.py runs many more through the whole decode.)"""
    rng = random.Random(24)
    outcomes = set()
    for i in range(1500):
        bad = mutate_bytes(payloads[i % len(payloads)], rng)
        if rng.random() < 0.5:
            head = bytearray(bad[:16])
            for _ in range(rng.randrange(1, 4)):
                if head:
                    head[rng.randrange(len(head))] = rng.randrange(256)
            bad = bytes(head) + bad[16:]
        if rng.random() < 0.5:  # whole words: the range decoder meets the damage
            bad = bad[:len(bad) // 4 * 4]
        expected = _outcome(lambda d: (reference.decode_frames(d),), bad)
        assert _same(expected, _outcome(_c_frames, bad)), (i, expected[:2])
        if i % 5 == 0:
            assert _same(_outcome(_reference_quantised, bad), _outcome(_c_quantised, bad)), i
        outcomes.add(expected[1].split(" (")[0] if expected[0] == "error" else "ok")
    assert len(outcomes) >= 8, outcomes  # every kind of damage was met


def test_a_header_is_refused_exactly_where_the_bytes_cannot_hold_it():
    """``F D + D + R`` against ``max_values`` of the byte count (motionrep.plugin.coding): the C bound is the
    Python one at the boundary, for many payload sizes."""
    from motionrep.plugin.coding import max_values

    for words in (4, 5, 7, 50, 333):
        size = 4 * words
        limit = max_values(size, 208)
        for F in (limit // 2 - 1, limit // 2, limit // 2 + 1):  # D = 1, region = 1: F + 1 + F values
            enc = IntegerEncoder()
            enc.encode_raw([F - 1], 32)
            enc.encode_raw([0], 20)
            enc.encode_raw([0], 16)
            data = (enc.to_bytes() + bytes(size))[:size]
            expected = _outcome(lambda d: (reference.decode_frames(d),), data)
            assert _same(expected, _outcome(_c_frames, data))
            assert ("cannot be held" in expected[1]) == (2 * F + 1 > limit)


def test_reconstruct_and_inverse_are_the_decoders(payloads):
    """The encoder measures candidates with :func:`~motionrep_transform._decoder.reconstruct` (the C decoder's
    dequantisation and inverse wavelet), whose values are the numpy decoder's."""
    from motionrep_transform._decoder import reconstruct
    from motionrep_transform._wavelet import forward, inverse, num_levels

    for data in payloads:
        q = unpack(data)
        assert reconstruct(q).tobytes() == reference.reconstruct(q).tobytes()
    x = np.random.default_rng(0).normal(size=(77, 5))
    coefficients = forward(x, num_levels(77))
    assert inverse(coefficients).tobytes() == reference.inverse(coefficients).tobytes()


_EMBED = r"""
#include <stdio.h>
#include <stdlib.h>
#include "mrtransform.h"
int main(int argc, char **argv) {
    if (argc < 3)
        return 2;
    FILE *f = fopen(argv[1], "rb");
    static unsigned char data[1 << 20];
    size_t size = fread(data, 1, sizeof data, f);
    fclose(f);
    mrt_frames frames;
    mrt_status st;
    if (mrt_decode(data, size, atoi(argv[2]), &frames, &st) != MRT_OK) {
        printf("error: %s\n", st.message);
        return 1;
    }
    double times[3] = {0.0, 0.37, 1.0}, out[3 * 4096];
    mrt_sample(&frames, times, 3, out, 3);
    fwrite(out, sizeof(double), 3 * frames.features, stdout);
    mrt_frames_free(&frames);
    return 0;
}
"""


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_reconstruct_is_the_numpy_reconstruction_on_sparse_dense_and_extreme_coefficients():
    """The C synthesis (eight features at once, the rest one by one; a zero detail not computed when every step is
    finite; all-zero features) gives the numpy reconstruction's bits, or its error, on random quantised clips:
    sparse and dense coefficients, all-zero features, steps that underflow to 0 or overflow to infinity.  Scalar
    IEEE operations in the same order on both sides, compiled without FMA contraction: compared bit for bit."""
    from motionrep_transform._decoder import reconstruct
    from motionrep_transform._stream import Quantised
    from motionrep_transform._wavelet import level_sizes, num_levels

    rng = np.random.default_rng(24)
    outcomes = {"ok": 0, "error": 0}
    for trial in range(300):
        F, D, region = int(rng.integers(1, 200)), int(rng.integers(1, 30)), int(rng.integers(1, 40))
        R = -(-F // region)
        mode = trial % 4  # normal steps, overflowing, underflowing, widely spread
        low, high = [(-150, 50), (31000, 32000), (-32000, -31000), (-10000, 10000)][mode]
        fexp = rng.integers(low, high, D).astype(np.int64)
        rexp = rng.integers(-40, 40, R).astype(np.int64)
        density = [0.02, 0.3, 1.0, 0.002][trial // 4 % 4]
        coef = np.where(rng.random((F, D)) < density, rng.integers(-1000, 1001, (F, D)), 0).astype(np.int64)
        coef[:, rng.random(D) < 0.2] = 0
        sizes = level_sizes(F, num_levels(F))
        q = Quantised(F, D, region, fexp, rexp, np.split(coef, np.cumsum(sizes)[:-1]))
        expected = _outcome(lambda q: (reference.reconstruct(q),), q)
        got = _outcome(lambda q: (reconstruct(q),), q)
        assert expected[0] == got[0] and (expected[1] == got[1] if got[0] == "error"
                                          else expected[1].tobytes() == got[1].tobytes()), (trial, expected, got)
        outcomes[expected[0]] += 1
    assert min(outcomes.values()) > 30, outcomes


def test_the_library_builds_and_decodes_alone_without_python(payloads, payloads_v2, payloads_v3, tmp_path):
    """mrtransform.c (with mrcoder.c and mrprior3.h for versions 2 and 3) is plain C99 with the standard library
    and libm: an engine builds it with its own compiler (no Python headers, no motionrep headers) and gets the same
    values as motionrep, and the same one-line errors."""
    main = tmp_path / "embed.c"
    main.write_text(_EMBED)
    exe = tmp_path / "embed"
    subprocess.run(["cc", "-std=c99", "-O2", "-ffp-contract=off", "-Wall", "-Wextra", "-pedantic", "-Werror",
                    f"-I{C_DIR}", str(main), str(C_DIR / "mrtransform.c"), str(C_DIR / "mrcoder.c"), "-o", str(exe),
                    "-lm"], check=True)
    payload = tmp_path / "payload.bin"
    for version, data in ((1, payloads[0]), (2, payloads_v2[0]), (3, payloads_v3[0])):
        payload.write_bytes(data)
        done = subprocess.run([str(exe), str(payload), str(version)], capture_output=True, check=True)
        decoder = _cdecode.decode(data, version)
        out = np.empty((decoder.features, 3))
        _cdecode.sample(np.array([0.0, 0.37, 1.0]), out, decoder)
        assert done.stdout == out.tobytes()
        half = data[:len(data) // 2]  # (a few bytes less need not be noticed by version 2's coder: see mrcoder.c)
        payload.write_bytes(half)
        failed = subprocess.run([str(exe), str(payload), str(version)], capture_output=True, text=True)
        assert failed.returncode == 1 and failed.stdout.startswith("error: ")
        with pytest.raises(PayloadError) as info:
            _cdecode.decode(half, version)
        assert failed.stdout.strip() == f"error: {info.value}"


REAL_CLIPS = ["cmu/bvh11/131_01.bvh", "cmu/bvh-matlab/walk.bvh", "other/bandai_namco/dataset-1_dash_normal_001.bvh",
              "edge/fairmotion_sinusoidal.bvh"]


@requires_shared
@pytest.mark.realdata
@pytest.mark.parametrize("rel", REAL_CLIPS)
def test_real_clips_decode_to_the_python_decoders_bits_within_their_bound(rel):
    """Real clips coded at 2 %: the C decoder gives the frames of the decoders it replaced bit for bit (version 3,
    and the same integers as versions 2 and 1), and the file decodes within the bound it stores.  (Every real clip, transform and svd, decodes to main's numba decoders' bits:
    benchmarks/results/c_decode.md.)"""
    from motionrep.io import read
    from motionrep.io.container import unpack as unpack_container
    from motionrep.pipeline.decode import decompress
    from motionrep.pipeline.evaluate import max_joint_error

    from motionrep_transform import _stream

    motion = read(SHARED_DATA / rel)
    result = compress_motion(motion, "transform", max_error="2%")
    data = result.container.arrays["data"].tobytes()  # version 3
    assert np.asarray(_cdecode.decode(data, 3)).T.tobytes() == _reference_v2(data, 3).tobytes()
    v2 = STREAMS[2].pack(unpack(data, 3))  # the same integers as version 2: the same frames
    assert np.asarray(_cdecode.decode(v2, 2)).T.tobytes() == np.asarray(_cdecode.decode(data, 3)).T.tobytes()
    v1 = _stream.pack(unpack(data, 3))  # the same integers as version 1
    assert np.asarray(_cdecode.decode(v1, 1)).T.tobytes() == reference.decode_frames(v1).tobytes()
    decoded = decompress(unpack_container(result.data))
    assert max_joint_error(motion, decoded).max_error_percent <= 2.0
