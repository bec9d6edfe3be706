"""The transform codec: conformance, the bound from 0.001 % to 20 %, fixed steps, damaged payloads, determinism,
old payloads, and the bound on the real clips (a quick one in the default run; all clips, marked slow)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import SHARED_DATA, real_params, requires_shared
from motionrep.codec import Payload, frame_times, interpolate_frames
from motionrep.compress import compress_file, compress_motion, decompress, decompress_file
from motionrep.container import pack, unpack
from motionrep.errors import BoundNotMetError, ContainerError, MotionrepError, ParameterError, PayloadError
from motionrep.evaluate import max_joint_error
from motionrep.io import read
from motionrep.plugins import get_codec, get_representation
from motionrep.testing import (chain_skeleton, check_codec, conformance_motions, humanoid_skeleton,
                               synthetic_motion)
from motionrep_transform._stream import unpack as unpack_stream
from motionrep_transform._wavelet import forward, inverse, level_sizes, num_levels

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def walk():
    return synthetic_motion(humanoid_skeleton(), frames=150, fps=60, seed=3)


# ---------------------------------------------------------------------------------------------------------------
# the pieces
# ---------------------------------------------------------------------------------------------------------------
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


def test_interpolate_frames_is_exact_on_frames_and_linear_between():
    rows = np.array([[0.0, 1.0], [2.0, 3.0], [4.0, -1.0]])
    np.testing.assert_array_equal(interpolate_frames(rows, frame_times(3)), rows)
    np.testing.assert_allclose(interpolate_frames(rows, [0.25, 0.75, 2.0, -1.0]),
                               [[1.0, 2.0], [3.0, 1.0], [4.0, -1.0], [0.0, 1.0]])
    np.testing.assert_array_equal(interpolate_frames(rows[:1], [0.0, 0.7]), rows[[0, 0]])


# ---------------------------------------------------------------------------------------------------------------
# the codec contract
# ---------------------------------------------------------------------------------------------------------------
def test_conformance():
    codec = get_codec("transform")
    check_codec(codec, params={"step": 0.5}, bound_params={})
    results = check_codec(codec, conformance_motions(), params={"step": 0.2}, bound_params={},
                          bound_fraction=0.01)
    assert all(r["bounded_error"] is not None for r in results)  # the bound is always met, never given up


@pytest.mark.parametrize("max_error", ["0.001%", "0.05%", "0.5%", "2%", "20%", "0.8"])
def test_bound_is_met_from_0_001_to_20_percent_and_in_file_units(walk, max_error):
    r = compress_motion(walk, "transform", max_error=max_error)
    assert r.report.max_error <= r.bound
    again = max_joint_error(walk, decompress(r.data))
    assert again.max_error <= r.bound
    assert r.container.arrays["data"].dtype == np.uint8


def test_smaller_bounds_take_more_bytes(walk):
    sizes = [compress_motion(walk, "transform", max_error=e).container.arrays["data"].size
             for e in ("10%", "2%", "0.5%", "0.05%")]
    assert sizes == sorted(sizes) and sizes[-1] > 3 * sizes[0]


def test_fixed_step_without_a_bound(walk):
    coarse = compress_motion(walk, "transform", max_error=None, params={"step": 2.0})
    fine = compress_motion(walk, "transform", max_error=None, params={"step": "0.05"})
    assert coarse.bound is None and fine.container.params["step"] == 0.05
    e_coarse = max_joint_error(walk, decompress(coarse.data)).max_error
    e_fine = max_joint_error(walk, decompress(fine.data)).max_error
    assert e_fine < e_coarse and fine.container.arrays["data"].size > coarse.container.arrays["data"].size
    # a fixed step with a bound: written only if the bound is met
    with pytest.raises(BoundNotMetError, match="step=2"):
        compress_motion(walk, "transform", max_error=e_coarse / 2, params={"step": 2.0})
    ok = compress_motion(walk, "transform", max_error=e_coarse * 1.01, params={"step": 2.0})
    assert ok.container.arrays["data"].tobytes() == coarse.container.arrays["data"].tobytes()


@pytest.mark.parametrize("params", [{"step": 0}, {"step": -1}, {"step": "nan"}, {"step": "inf"}, {"region": 3},
                                    {"region": 70000}, {"region": 2.5}, {"rounding": 0.6}, {"rounding": 0.0},
                                    {"window": 3}])
def test_parameters_are_validated_before_any_work(walk, params):
    with pytest.raises(ParameterError):
        get_codec("transform").parse_params(params)
    with pytest.raises(ParameterError):
        compress_motion(walk, "transform", params=params)


def test_no_bound_needs_a_step(walk):
    with pytest.raises(ParameterError, match="give step"):
        compress_motion(walk, "transform", max_error=None)


def test_decodes_at_any_time(walk):
    r = compress_motion(walk, "transform", max_error="1%")
    codec = get_codec("transform")
    payload = Payload(r.container.arrays)
    frames = codec.decode(payload, frame_times(walk.num_frames))
    between = codec.decode(payload, (np.arange(walk.num_frames - 1) + 0.5) / (walk.num_frames - 1))
    np.testing.assert_allclose(between, 0.5 * (frames[:-1] + frames[1:]), atol=1e-12)
    half = decompress(r.data, fps=walk.fps / 2)
    assert half.num_frames == (walk.num_frames - 1) // 2 + 1


def test_short_clips_and_one_frame():
    for frames in (1, 2, 3, 4, 5):
        m = synthetic_motion(chain_skeleton(3), frames=frames, seed=frames)
        r = compress_motion(m, "transform", max_error="0.5%")
        assert max_joint_error(m, decompress(r.data)).max_error <= r.bound


def test_features_that_move_nothing_are_still_coded(walk):
    """A joint without descendants moves no point: its step is floored, its values stay finite."""
    sk = chain_skeleton(4)
    sk = sk.replace(end_site_parents=np.zeros(0, np.int64), end_site_offsets=np.zeros((0, 3)))
    m = synthetic_motion(sk, frames=40, seed=2)
    r = compress_motion(m, "transform", max_error="1%")
    assert np.all(np.isfinite(decompress(r.data).rotations))


# ---------------------------------------------------------------------------------------------------------------
# damaged payloads, determinism, old files
# ---------------------------------------------------------------------------------------------------------------
def test_damaged_payloads_give_clean_errors(walk):
    """Every changed, cut or extended payload either raises a motionrep error or decodes to finite features of
    the right shape; in a container the checksum catches it first (ContainerError)."""
    r = compress_motion(walk, "transform", max_error="2%")
    data = r.container.arrays["data"]
    codec = get_codec("transform")
    times = frame_times(walk.num_frames)
    rng = np.random.default_rng(0)
    candidates = [data[:n] for n in (0, 3, 4, 8, data.size // 2, data.size - 4)]
    candidates += [np.concatenate([data, rng.integers(0, 256, n).astype(np.uint8)]) for n in (1, 4, 64)]
    for _ in range(150):
        bad = data.copy()
        at = rng.integers(0, data.size, rng.integers(1, 4))
        bad[at] = rng.integers(0, 256, at.size)
        candidates.append(bad)
    errors = 0
    for bad in candidates:
        try:
            out = codec.decode(Payload({"data": bad}), times)
        except MotionrepError:
            errors += 1
            continue
        assert out.ndim == 2 and out.shape[0] == times.size and np.all(np.isfinite(out))
    assert errors >= len(candidates) // 3
    with pytest.raises(PayloadError):
        codec.decode(Payload({"data": data.astype(np.int16)}), times)
    # through the container: any changed byte is refused before decoding
    blob = bytearray(r.data)
    blob[len(blob) // 2] ^= 0x40
    with pytest.raises(ContainerError):
        decompress(bytes(blob))


def test_a_header_cannot_ask_for_more_than_the_bytes_hold():
    from motionrep.coding import IntegerEncoder

    enc = IntegerEncoder()
    enc.encode_raw([2 ** 32 - 1], 32)  # 4 billion frames
    enc.encode_raw([99], 20)
    enc.encode_raw([15], 16)
    with pytest.raises(PayloadError, match="cannot be held"):
        unpack_stream(enc.to_bytes())


def test_same_input_gives_identical_bytes_across_processes_and_threads(walk):
    code = ("import sys; from motionrep.testing import humanoid_skeleton, synthetic_motion; "
            "from motionrep.compress import compress_motion; "
            "m = synthetic_motion(humanoid_skeleton(), frames=150, fps=60, seed=3); "
            "sys.stdout.buffer.write(compress_motion(m, 'transform', max_error='1%').data)")
    here = compress_motion(walk, "transform", max_error="1%").data
    runs = []
    for threads in ("1", "2"):
        env = dict(__import__("os").environ, OPENBLAS_NUM_THREADS=threads, OMP_NUM_THREADS=threads,
                   MKL_NUM_THREADS=threads)
        runs.append(subprocess.run([sys.executable, "-c", code], capture_output=True, check=True, env=env,
                                   cwd=str(REPO)).stdout)
    assert runs[0] == runs[1] == here


# The payload motionrep 0.1.0 (format 1) writes for golden_motion() at --max-error 2%: files in the wild hold such
# bytes, so they must keep decoding to a motion within that bound.
GOLDEN_HEX = (
    "0000170000e90b00c5f9ffe3d52fe507f33d620c519f89cb1b4783cb21cc361625939c859579b2a5b0f193e4871951f7d5a4403e"
    "62dd10bd126b216a7d700389ddb8f689554a35355cfdc71dff9916e1ef302233ab25f83e16f4387780d6d6ba1ef1d6fad0d7772f"
    "ba2bf26c4d7c57414b95495d929eb7b5620022d1016b3e66e3030a2d54a15c1abe90c325d690c8019f36c31f0694df20188cefea"
    "d2d31270fe32616fde9a41cd8a18025204c11f7cd1a3e6262130f59535de8fb90158fa4840bdfa7bfecd8c21cec1a0187e82fbb5"
    "2085d90394ede449f8cf397106af6013")


def golden_motion():
    return synthetic_motion(chain_skeleton(3), frames=24, fps=30, seed=9)


def test_format_1_payloads_still_decode():
    m = golden_motion()
    data = np.frombuffer(bytes.fromhex(GOLDEN_HEX), dtype=np.uint8)
    codec = get_codec("transform")
    features = codec.decode(Payload({"data": data}), frame_times(m.num_frames))
    decoded = get_representation("root-quat-axis-angle").from_features(features, m.skeleton, m.fps)
    assert max_joint_error(m, decoded).max_error_percent <= 2.0
    # and this version still writes the same bytes
    r = compress_motion(m, "transform", max_error="2%")
    assert r.container.arrays["data"].tobytes().hex() == GOLDEN_HEX


# ---------------------------------------------------------------------------------------------------------------
# real clips
# ---------------------------------------------------------------------------------------------------------------
def _verify_through_bvh(src: Path, tmp_path: Path, max_error: str) -> float:
    mrc, bvh = tmp_path / "t.mrc", tmp_path / "t.bvh"
    result = compress_file(src, mrc, "transform", max_error=max_error)
    decompress_file(mrc, bvh)
    report = max_joint_error(read(src), read(bvh))
    assert report.max_error <= result.bound
    return report.max_error_percent


#: A few real clips of different skeletons and rates, in the default run; every clip with MOTIONREP_ALL_CLIPS=1.
QUICK_CLIPS = ["cmu/bvh-matlab/walk.bvh", "other/bvh-toolbox/walk01.bvh",
               "other/bandai_namco/dataset-1_dash_normal_001.bvh", "edge/fairmotion_sinusoidal.bvh"]


@requires_shared
@pytest.mark.realdata
@pytest.mark.parametrize("max_error", ["2%", "0.5%"])
@pytest.mark.parametrize("rel", QUICK_CLIPS)
def test_bound_on_real_clips_through_bvh(rel, max_error, tmp_path):
    assert _verify_through_bvh(SHARED_DATA / rel, tmp_path, max_error) <= float(max_error.rstrip("%"))


@pytest.mark.slow
@pytest.mark.skipif(not os.environ.get("MOTIONREP_ALL_CLIPS"),
                    reason="every real clip at two bounds takes many minutes: set MOTIONREP_ALL_CLIPS=1 "
                           "(benchmarks/acl.py checks them all too)")
@pytest.mark.parametrize("max_error", ["2%", "0.5%"])
@pytest.mark.parametrize("src", real_params())
def test_bound_on_every_real_clip(src, max_error, tmp_path):
    if src is None:
        pytest.skip("no shared data")
    assert _verify_through_bvh(src, tmp_path, max_error) <= float(max_error.rstrip("%"))
