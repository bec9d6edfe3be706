"""The transform plugin's machinery: the wavelet, the payload streams' limits, payloads of format 1 written by
motionrep 0.1.0 and of format 2.  The codec's behaviour through the core is tested in ``tests/test_transform.py``;
the version-2 coder's own properties (round trips, hostile bytes) in ``test_stream2.py``."""

from __future__ import annotations

import numpy as np
import pytest

from motionrep.plugin.codec import Payload, frame_times
from motionrep.pipeline.compress import compress_motion
from motionrep.errors import PayloadError
from motionrep.pipeline.evaluate import max_joint_error
from motionrep.plugin.registry import get_codec, get_representation
from motionrep.model.synthetic import chain_skeleton, synthetic_motion
from motionrep_transform import _stream2
from motionrep_transform._stream import pack as pack_stream, unpack as unpack_stream
from motionrep_transform._wavelet import forward, inverse, level_sizes, num_levels

from transform_reference_v1 import forward as numpy_forward


@pytest.mark.parametrize("frames", [4, 5, 7, 8, 33, 100, 257])
def test_wavelet_is_critically_sampled_and_invertible(frames):
    x = np.random.default_rng(frames).normal(size=(frames, 3))
    levels = num_levels(frames)
    coeffs = forward(x, levels)
    assert [c.shape[0] for c in coeffs] == level_sizes(frames, levels) and sum(map(len, coeffs)) == frames
    np.testing.assert_allclose(inverse(coeffs), x, atol=1e-12)
    # a constant is all approximation; a straight line too, away from the mirrored ends (vanishing moments)
    assert max(np.abs(d).max() for d in forward(np.full((frames, 2), 3.0), levels)[1:]) < 1e-9
    line = np.outer(np.arange(frames), [0.5, -2.0]) + 3.0
    assert max((np.abs(d[3:-3]).max() if len(d) > 6 else 0.0) for d in forward(line, levels)[1:]) < 1e-9


@pytest.mark.parametrize("frames", [1, 3, 4, 5, 8, 33, 100, 257, 1250])
def test_the_c_forward_wavelet_is_the_numpy_lifting_bit_for_bit(frames):
    """Bit for bit against the numpy lifting it replaced (transform_reference_v1.forward): the C forward (mrt_forward) is scalar IEEE without FMA contraction (setup.py), each operation
    in the numpy code's order, so the same values on every CPU."""
    x = np.random.default_rng(frames).normal(size=(frames, 5)) * 50
    levels = num_levels(frames)
    got, want = forward(x, levels), numpy_forward(x, levels)
    assert len(got) == len(want) == levels + 1
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g.view(np.int64), w.view(np.int64))
    with pytest.raises(ValueError):
        forward(x, levels + 1)


def test_a_header_cannot_ask_for_more_than_the_bytes_hold():
    from motionrep.plugin.coding import IntegerEncoder

    enc = IntegerEncoder()
    enc.encode_raw([2 ** 32 - 1], 32)  # 4 billion frames
    enc.encode_raw([99], 20)
    enc.encode_raw([15], 16)
    with pytest.raises(PayloadError, match="cannot be held"):
        unpack_stream(enc.to_bytes())


# The payload motionrep 0.1.0 (format 1) writes for golden_motion() at --max-error 2%: files in the wild hold such
# bytes, so they must keep decoding to a motion within that bound.
GOLDEN_HEX = (
    "0000170000e90b00d5f7ffe36258ab0f83e676628ed93183002f58a6f36087a922fc2f5b420aacfb116e517b8b533bb4bd78a648"
    "bfb35744b630c082329b6b90e3560540c835e270960806b908c5f4b4ed0f9f1f0e5086b206af4c1f7790b600bc585f2fa49b766e"
    "6a0882033c9e578e4b0a556cd50ce348ee4e88014ee407bd6cd99e1e83f183fc2cb1baaabcd127ce253017e2b75475467d95e1ae"
    "961089c9c81832847fd0388ae8ad59d0bd4d44bc0b168ac29e4872c82d6556fa1fb5fc6768fd2db1bf1da3ed1f6a93810f8950f2"
    "3a6e3168f1a42668")


def golden_motion():
    return synthetic_motion(chain_skeleton(3), frames=24, fps=30, seed=9)


def _decoded_error_percent(hexdata: str, version: int | None) -> float:
    m = golden_motion()
    data = np.frombuffer(bytes.fromhex(hexdata), dtype=np.uint8)
    features = get_codec("transform").decode(Payload({"data": data}, version=version), frame_times(m.num_frames))
    decoded = get_representation("root-quat-axis-angle").from_features(features, m.skeleton, m.fps)
    return max_joint_error(m, decoded).max_error_percent


def test_format_1_payloads_still_decode():
    assert _decoded_error_percent(GOLDEN_HEX, version=1) <= 2.0
    # the version-1 writer still writes the same bytes for the same integers
    assert pack_stream(unpack_stream(bytes.fromhex(GOLDEN_HEX))).hex() == GOLDEN_HEX


# The payload of format 2 written for golden_motion() at --max-error 2% (the bytes the encoder's search chose when
# version 2 was introduced; a later search may choose other integers, but these bytes must keep decoding).
GOLDEN_2_HEX = (
    "170c0f806f8d1020ef23bc0ae4a4f5a112e0803ca89cfc7448d97b28c06f19332928be180acb0b4de1fe5f71b13ff10395aac68564a9"
    "75f207585cc8564d63b3b32279de5a1067316a7db14f8e3cf47452952f7da098b3057a961e37ca2b8b65cea58f0aee0464e717e3b32a"
    "2bcafe5a60d99cab23d0daba73e37f01ee0122ec2bb19e82f03ab3222812937f4959effb10a49690e13ac2d53b59179c4c4dc42d8d1b"
    "b4e5bf0ea20c8b6c455a95d7fbce")


# The payload of format 3 of the same integers (the bytes version 3 writes for them: version 2's coder started from
# the trained states of _c/mrprior3.h).
GOLDEN_3_HEX = (
    "170c0fdf9cb4ee8618ed1ccf516f35245ad148fad7d1ff62361931d0528a1f20d929bb628641353507fd3dd60c7da18e8e77912bdc12"
    "60406dd62cf2f4c60935a36ceda606ef33653d330d5df82cf930784c87a185817422655ae7460c4ca3481dd92af852f7841e9a55d792"
    "ca5569b048c0b957d51485e97407aa9e31303e3b864d0634d7693552b7dcf3231e3ebdcbb9cba15dbb1fa7dada375ba97a62e1a037e8"
    "b6fca7")


def test_format_2_payloads_decode_and_code_the_same_integers_to_the_same_bytes():
    assert _decoded_error_percent(GOLDEN_2_HEX, version=2) <= 2.0
    q = _stream2.unpack(bytes.fromhex(GOLDEN_2_HEX), 2)
    assert _stream2.pack(q, 2).hex() == GOLDEN_2_HEX
    # the same integers as version 1 would store, in fewer bytes
    assert len(pack_stream(q)) > len(GOLDEN_2_HEX) // 2


def test_format_3_is_written_and_codes_version_2s_integers_in_fewer_bytes():
    assert _decoded_error_percent(GOLDEN_3_HEX, version=3) <= 2.0
    assert _decoded_error_percent(GOLDEN_3_HEX, version=None) <= 2.0  # a payload without a version is current
    q2 = _stream2.unpack(bytes.fromhex(GOLDEN_2_HEX), 2)
    q3 = _stream2.unpack(bytes.fromhex(GOLDEN_3_HEX), 3)
    for a, b in zip([q2.feature_exponents, q2.region_exponents, *q2.coefficients],
                    [q3.feature_exponents, q3.region_exponents, *q3.coefficients]):
        np.testing.assert_array_equal(a, b)
    assert _stream2.pack(q2).hex() == GOLDEN_3_HEX and len(GOLDEN_3_HEX) < len(GOLDEN_2_HEX)
    # the same frames from either version of the same integers, bit for bit
    codec = get_codec("transform")
    frames = [codec.decoder(Payload({"data": np.frombuffer(bytes.fromhex(h), np.uint8)}, version=v)).frames
              for h, v in ((GOLDEN_2_HEX, 2), (GOLDEN_3_HEX, 3))]
    assert frames[0].tobytes() == frames[1].tobytes()
    r = compress_motion(golden_motion(), "transform", max_error="2%")
    assert r.container.codec_version == 3
    # the open-loop search without spending the slack (slack=0) at the rounding of version 2's time (0.4) still
    # chooses these integers; by default it quantises closed loop and spends the room under the bound (and rounds
    # at 0.45), which changes the integers (fewer bytes), not the format
    kept = compress_motion(golden_motion(), "transform", max_error="2%",
                           params={"slack": 0, "rounding": 0.4, "closed_loop": False})
    assert kept.container.arrays["data"].tobytes().hex() == GOLDEN_3_HEX
    assert r.container.payload_bytes <= kept.container.payload_bytes


def test_both_versions_of_the_same_integers_decode_to_the_same_frames_bit_for_bit():
    m = synthetic_motion(chain_skeleton(5), frames=300, fps=60, seed=2)
    v3 = compress_motion(m, "transform", max_error="0.5%").container.arrays["data"]
    v1 = np.frombuffer(pack_stream(_stream2.unpack(v3.tobytes())), np.uint8)
    codec = get_codec("transform")
    frames_1 = codec.decoder(Payload({"data": v1}, version=1)).frames
    assert np.array_equal(frames_1, codec.decoder(Payload({"data": v3}, version=3)).frames)
    assert v3.size < v1.size


def test_the_runtime_sampler_is_interpolate_rows_bit_for_bit():
    """``motionrep.open`` samples with the C sampler (feature-major), ``decode`` with the C rows, and
    :func:`interpolate_rows` (numpy) defines the values: all three give the same."""
    from motionrep_transform._decoder import interpolate_rows

    data = np.frombuffer(bytes.fromhex(GOLDEN_3_HEX), dtype=np.uint8)
    decoder = get_codec("transform").decoder(Payload({"data": data}))
    F = decoder.frames.shape[0]
    rng = np.random.default_rng(1)
    times = np.concatenate([rng.random(300), np.arange(F) / (F - 1), [0.0, 1.0, -0.5, 1.5, np.nextafter(1.0, 0)]])
    out = np.full((decoder.width, times.size + 3), np.nan)
    decoder.kernel(times, out, *decoder.kernel_args)
    assert np.array_equal(out[:, :times.size].T, interpolate_rows(decoder.frames, times))
    assert np.array_equal(out[:, :times.size].T, decoder(times))
    one = compress_motion(synthetic_motion(chain_skeleton(3), frames=1, seed=2), "transform").container
    decoder = get_codec("transform").decoder(Payload(one.arrays))
    single = np.empty((decoder.width, 2))
    decoder.kernel(np.array([0.0, 0.7]), single, *decoder.kernel_args)
    assert decoder.frames.shape[0] == 1
    assert np.array_equal(single.T, np.repeat(decoder.frames[:1], 2, axis=0))  # a one-frame clip


def test_window_minimum_is_scipys_minimum_filter_with_nearest_ends():
    from scipy.ndimage import minimum_filter1d

    from motionrep_transform._codec import window_minimum

    rng = np.random.default_rng(0)
    for n in (1, 2, 3, 7, 50, 200):
        for span in (1, 2, 3, 5, 8, 31, 49, 60, 1000):
            v = rng.integers(-20, 20, n)
            got = window_minimum(v, span)
            assert got.dtype == v.dtype and np.array_equal(got, minimum_filter1d(v, 2 * span + 1, mode="nearest"))
        assert window_minimum(v, 0) is v


@pytest.mark.parametrize("frames, region", [(4, 16), (37, 4), (300, 16), (1001, 16), (1250, 8)])
def test_quantise_is_every_coefficient_over_its_own_step(frames, region):
    """``_Plan.quantise`` (one table of steps per distinct region exponent, rows picked through the windows'
    minima) gives ``sign(c) floor(|c| / step + rounding)`` with each coefficient's own step
    (:func:`steps_of` of :meth:`_Plan.exponents`), bit for bit: exact steps (``step_scale``) and one division
    of the same numbers, on any machine; for region exponents of a narrow and a wide range, repeated ones and
    one region."""
    from motionrep_transform._codec import _Plan, steps_of

    rng = np.random.default_rng(frames)
    features = np.cumsum(rng.normal(size=(frames, 6)), axis=0) * rng.uniform(0.01, 100, size=6)
    plan = _Plan(features, rng.integers(-20, 20, size=6), region)
    for low, high in ((-3, -1), (-40, 40), (-300, 200), (5, 6)):
        k = rng.integers(low, high, size=plan.regions)
        for rounding in (0.5, 0.3):
            got = plan.quantise(k, rounding)
            for q, c, step in zip(got, plan.coefficients, steps_of(plan.exponents(k))):
                want = (np.sign(c) * np.floor(np.abs(c) / step + rounding)).astype(np.int64)
                assert q.dtype == np.int64 and np.array_equal(q, want), (low, high, rounding)
