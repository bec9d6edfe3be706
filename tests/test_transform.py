"""The transform codec through the core: conformance, the bound from 0.001 % to 20 %, fixed steps, damaged
payloads, determinism, and the bound on real clips through BVH (a few in the default run; every clip with
MOTIONREP_ALL_CLIPS=1).  Its machinery (wavelet, stream, old payloads) is tested in
``plugins/motionrep_transform/tests``."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from helpers import SHARED_DATA, real_params, requires_shared, run_cli_caught
from motionrep.plugin.codec import Payload, frame_times
from motionrep.pipeline.compress import compress_file, compress_motion, decompress, decompress_file
from motionrep.errors import BoundNotMetError, ContainerError, MotionrepError, ParameterError, PayloadError
from motionrep.pipeline.evaluate import max_joint_error
from motionrep.io import read
from motionrep.plugin.registry import get_codec
from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, synthetic_motion
from motionrep.testing import check_codec, conformance_motions

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def walk():
    return synthetic_motion(humanoid_skeleton(), frames=150, fps=60, seed=3)


# ---------------------------------------------------------------------------------------------------------------
# the codec contract
# ---------------------------------------------------------------------------------------------------------------
def test_interpolation_is_exact_on_frames_and_linear_between():
    from motionrep_transform import interpolate_rows

    rows = np.array([[0.0, 1.0], [2.0, 3.0], [4.0, -1.0]])
    np.testing.assert_array_equal(interpolate_rows(rows, frame_times(3)), rows)
    np.testing.assert_allclose(interpolate_rows(rows, [0.25, 0.75, 2.0, -1.0]),
                               [[1.0, 2.0], [3.0, 1.0], [4.0, -1.0], [0.0, 1.0]])
    np.testing.assert_array_equal(interpolate_rows(rows[:1], [0.0, 0.7]), rows[[0, 0]])
    out = np.full((2, 2), np.nan)
    assert interpolate_rows(rows, [1.0, 0.5], out) is out and np.array_equal(out, rows[[2, 1]])


def test_prepared_decoder_equals_decode(walk):
    r = compress_motion(walk, "transform", max_error="1%")
    codec = get_codec("transform")
    payload = Payload(r.container.arrays)
    decoder = codec.decoder(payload)
    times = np.random.default_rng(1).random(50)
    np.testing.assert_array_equal(decoder(times), codec.decode(payload, times))
    out = np.empty((50, decoder.width))
    assert decoder(times, out) is out


def test_conformance():
    codec = get_codec("transform")
    check_codec(codec, params={"step": 0.5}, bound_params={})
    motions = conformance_motions()
    results = check_codec(codec, motions, params={"step": 0.2}, bound_params={}, bound_fraction=0.01)
    for m, r in zip(motions, results):
        # the bound is met wherever it can be: not where the reference's root moves without position channels
        reachable = any(c.endswith("position") for c in m.skeleton.channels[0]) or np.allclose(
            m.root_translation, m.skeleton.offsets[0])
        assert r["bounded_error"] is not None or not reachable


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


def test_same_input_gives_identical_bytes_across_processes_and_threads(walk):
    """The whole search (region exponents, then the slack spent: here it moves coefficients) gives the same bytes
    in fresh processes with one and two BLAS threads as in this one."""
    code = ("import sys; from motionrep.testing import humanoid_skeleton, synthetic_motion; "
            "from motionrep.pipeline.compress import compress_motion; "
            "m = synthetic_motion(humanoid_skeleton(), frames=150, fps=60, seed=3); "
            "sys.stdout.buffer.write(compress_motion(m, 'transform', max_error='1%').data)")
    events = []
    here = compress_motion(walk, "transform", max_error="1%",
                           progress=lambda stage, fields: events.append((stage, dict(fields)))).data
    assert [f["moved"] for stage, f in events if stage == "slack"][0] > 0
    runs = []
    for threads in ("1", "2"):
        env = dict(__import__("os").environ, OPENBLAS_NUM_THREADS=threads, OMP_NUM_THREADS=threads,
                   MKL_NUM_THREADS=threads)
        runs.append(subprocess.run([sys.executable, "-c", code], capture_output=True, check=True, env=env,
                                   cwd=str(REPO)).stdout)
    assert runs[0] == runs[1] == here


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


@requires_shared
@pytest.mark.realdata
@pytest.mark.parametrize("max_error", ["2%", "0.0588%"])
def test_the_slack_saves_bytes_on_a_real_clip_within_the_bound_through_bvh(max_error, tmp_path):
    """Spending the slack (the default) writes fewer bytes than keeping the rounded integers (slack=0), and the
    file still meets the bound after a round trip through BVH text."""
    src = SHARED_DATA / "cmu/pybvh/cmu_12_01_walk.bvh"
    kept = compress_file(src, None, "transform", max_error=max_error, params={"slack": 0})
    spent = compress_file(src, tmp_path / "s.mrc", "transform", max_error=max_error)
    assert spent.container.payload_bytes < kept.container.payload_bytes
    decompress_file(tmp_path / "s.mrc", tmp_path / "s.bvh")
    assert max_joint_error(read(src), read(tmp_path / "s.bvh")).max_error <= spent.bound


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


def test_payload_bytes_and_bits_per_bone_frame_in_info_and_figures(walk, tmp_path):
    import json



    r = compress_motion(walk, "transform", max_error="2%")
    payload = r.container.arrays["data"].nbytes
    bones = walk.skeleton.num_joints + walk.skeleton.num_end_sites
    assert r.container.payload_bytes == payload < len(r.data)
    assert r.figures.payload_bytes == payload and r.figures.num_end_sites == walk.skeleton.num_end_sites
    assert r.figures.bits_per_bone_frame == pytest.approx(8 * payload / (walk.num_frames * bones))
    assert "bits/bone/frame" in r.figures.summary()
    path = tmp_path / "w.mrc"
    path.write_bytes(r.data)
    out = run_cli_caught("info", str(path), "--json")
    d = json.loads(out.output)
    assert d["payload_bytes"] == payload and d["bits_per_bone_frame"] == pytest.approx(r.figures.bits_per_bone_frame)
    assert d["figures"]["bits_per_bone_frame"] == pytest.approx(d["bits_per_bone_frame"])
    # one vocabulary: the payload's and the file's figures under their own names, in info and in the figures
    assert d["payload_bits_per_bone_frame"] == pytest.approx(d["figures"]["payload_bits_per_bone_frame"])
    assert d["file_bits_per_bone_frame"] == pytest.approx(8 * len(r.data) / (walk.num_frames * bones))
    assert d["figures"]["file_bits_per_bone_frame"] == pytest.approx(d["file_bits_per_bone_frame"])
    text = run_cli_caught("info", str(path), "--verbose").output
    assert f"payload:    {payload} bytes" in text and "payload bits/bone/frame" in text
