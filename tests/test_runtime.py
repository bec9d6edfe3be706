"""The runtime decoder (motionrep.open): the values the core measured, one pose alike alone or in a batch, times in
seconds clamped to the clip, FK positions, clean errors; and the compiled decoding kernels it is built on."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import motionrep
from motionrep import Motion, Skeleton
from motionrep.pipeline.compress import compress_motion, decompress
from motionrep.io.container import unpack
from motionrep.errors import ContainerError, ValidationError
from motionrep.model.kinematics import global_positions
from motionrep.plugin.representation import empty_poses
from motionrep.pipeline.runtime import BLOCK, Clip
from motionrep.model.synthetic import chain_skeleton, odd_skeleton, synthetic_motion


def _partial_axes_skeleton() -> Skeleton:
    """A root with only X and Z position channels and a joint with only a Y position channel: the other axes
    keep their OFFSET, which decoding must restore."""
    channels = (("Xposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"),
                ("Yposition", "Zrotation", "Xrotation", "Yrotation"), ("Zrotation", "Xrotation", "Yrotation"))
    return Skeleton(names=("hips", "spine", "head"), parents=np.array([-1, 0, 1]),
                    offsets=np.array([[1.0, 90.0, 2.0], [0.0, 10.0, 0.0], [0.0, 20.0, 0.0]]), channels=channels,
                    end_site_parents=np.array([2]), end_site_offsets=np.array([[0.0, 8.0, 0.0]]))


@pytest.fixture(scope="module")
def svd_clip():
    motion = synthetic_motion(odd_skeleton(), frames=61, fps=30, seed=2)
    return motion, compress_motion(motion, "svd", max_error=None, params={"rank": 5}).data


@pytest.fixture(scope="module")
def transform_clip():
    motion = synthetic_motion(chain_skeleton(5), frames=61, fps=30, seed=4)
    return motion, compress_motion(motion, "transform", max_error="5%").data


@pytest.fixture(scope="module")
def fourier_clip():
    motion = synthetic_motion(chain_skeleton(4), frames=40, fps=24, seed=3)
    return motion, compress_motion(motion, "naive-fourier", max_error=None, params={"k": 2, "iters": 25}).data


@pytest.mark.parametrize("representation", ["root-quat-axis-angle", "euler", "ortho6d", "dual-quaternion"])
@pytest.mark.parametrize("skeleton", [odd_skeleton, _partial_axes_skeleton], ids=["odd", "partial-axes"])
def test_frames_decode_to_what_decompress_gives(representation, skeleton):
    motion = synthetic_motion(skeleton(), frames=33, fps=30, seed=4)
    data = compress_motion(motion, "svd", representation=representation, max_error=None, params={"rank": 3}).data
    clip = motionrep.open(data)
    expected = decompress(data)
    # the frames' normalised times exactly as the core decodes them
    got = empty_poses(clip.skeleton, motion.num_frames)
    clip._decode_block(np.arange(motion.num_frames) / (motion.num_frames - 1), got)
    assert np.array_equal(got.rotations, expected.rotations)
    assert np.array_equal(got.root_translation, expected.root_translation)
    assert np.array_equal(got.joint_translations, expected.joint_translations)
    # the same through the public API, in seconds (times rounded, so equal to float32 rounding of the features)
    p = clip.poses(np.arange(motion.num_frames) / clip.fps)
    assert np.allclose(p.rotations, expected.rotations, atol=1e-6)
    assert clip.motion().rotations.tobytes() == expected.rotations.tobytes()


def test_open_path_bytes_and_container(svd_clip, tmp_path):
    motion, data = svd_clip
    path = tmp_path / "a.mrc"
    path.write_bytes(data)
    clips = [motionrep.open(path), motionrep.open(str(path)), motionrep.open(data), motionrep.open(unpack(data))]
    for clip in clips:
        assert isinstance(clip, Clip)
        assert clip.num_frames == 61 and clip.fps == 30.0 and clip.duration == pytest.approx(2.0)
        assert clip.codec == "svd" and clip.representation == "root-quat-axis-angle"
        assert clip.skeleton == motion.skeleton
    t = np.linspace(0, 2, 17)
    first = clips[0].poses(t)
    for clip in clips[1:]:
        assert np.array_equal(clip.poses(t).rotations, first.rotations)
    assert "svd" in repr(clips[0])


@pytest.mark.parametrize("which", ["svd_clip", "fourier_clip"])
def test_one_pose_is_the_batch_row_bit_for_bit(which, request):
    _, data = request.getfixturevalue(which)
    clip = motionrep.open(data)
    times = np.random.default_rng(0).uniform(0, clip.duration, 2 * BLOCK + 9)  # several blocks
    batch = clip.poses(times)
    assert batch.rotations.shape == (times.size, clip.skeleton.num_joints, 4)
    assert batch.rotations.dtype == np.float64
    for i in (0, 1, BLOCK - 1, BLOCK, 2 * BLOCK + 8):
        one = clip.pose(times[i])
        assert np.array_equal(one.rotations, batch.rotations[i])
        assert np.array_equal(one.root_translation, batch.root_translation[i])
        assert np.array_equal(one.joint_translations, batch.joint_translations[i])
    # a sub-batch at another position gives the same rows
    assert np.array_equal(clip.poses(times[5:40]).rotations, batch.rotations[5:40])
    norms = np.linalg.norm(batch.rotations, axis=-1)
    assert np.allclose(norms, 1.0, atol=1e-12)


@pytest.mark.parametrize("tail", [1, 2, 3, 40])
@pytest.mark.parametrize("which", ["svd_clip", "transform_clip"])
def test_a_batch_streamed_past_the_cache_is_its_poses_bit_for_bit(which, tail, request):
    """A batch of 8192 poses or more has its float64 rotations gathered sub-block by sub-block in a stage and
    streamed from there to memory (motionrep/_c/plan/plan.c); its last block of 1 or 2 poses takes the one-pose
    path (joints side by side), which once wrote past the stage (whose stale rows then overwrote those poses, on
    main until this test). Every row must be
    the pose of that time decoded alone, and in a small batch, bit for bit: the decoders are scalar IEEE float64
    C compiled without FMA contraction and without fast-math, so a time gives the same bits in any vector lane,
    at any position of any batch."""
    _, data = request.getfixturevalue(which)
    clip = motionrep.open(data)
    times = np.random.default_rng(tail).uniform(0, clip.duration, 8192 + 2 * BLOCK + tail)
    batch = clip.poses(times)
    for i in (0, 1, BLOCK, 8191, 8192, times.size - 3, times.size - 2, times.size - 1):
        assert clip.pose(times[i]).rotations.tobytes() == batch.rotations[i].tobytes()
    small = clip.poses(times[-tail - 5:])  # the last poses in a batch too small to stream
    assert small.rotations.tobytes() == batch.rotations[-tail - 5:].tobytes()
    assert small.root_translation.tobytes() == batch.root_translation[-tail - 5:].tobytes()
    whole = np.concatenate([clip.poses(times[a:a + 4000]).rotations for a in range(0, times.size, 4000)])
    assert whole.tobytes() == batch.rotations.tobytes()


def test_float32_rotations_are_the_float64_ones_rounded(svd_clip):
    clip = motionrep.open(svd_clip[1])
    t = np.linspace(0, clip.duration, 50)
    p64, p32 = clip.poses(t), clip.poses(t, dtype=np.float32)
    assert p32.rotations.dtype == np.float32 and p32.root_translation.dtype == np.float64
    assert np.array_equal(p32.rotations, p64.rotations.astype(np.float32))
    assert np.array_equal(clip.pose(0.7, dtype=np.float32).rotations, p32.rotations.dtype.type(
        clip.pose(0.7).rotations))
    with pytest.raises(ValidationError, match="float64 or float32"):
        clip.pose(0.1, dtype=np.int32)


def test_out_arrays_are_written_in_place(svd_clip):
    clip = motionrep.open(svd_clip[1])
    t = np.linspace(0, clip.duration, 700)
    out = empty_poses(clip.skeleton, t.size, np.float32)
    assert clip.poses(t, out=out) is out
    assert np.array_equal(out.rotations, clip.poses(t, dtype=np.float32).rotations)
    with pytest.raises(ValidationError, match="out must hold"):
        clip.poses(t[:3], out=out)


def test_times_are_seconds_clamped_to_the_clip(svd_clip):
    clip = motionrep.open(svd_clip[1])
    inside = clip.poses([0.0, clip.duration])
    outside = clip.poses([-5.0, clip.duration + 100.0])
    assert np.array_equal(outside.rotations, inside.rotations)
    assert np.array_equal(outside.root_translation, inside.root_translation)
    assert len(clip.poses([])) == 0
    for bad in (np.nan, np.inf):
        with pytest.raises(ValidationError, match="finite"):
            clip.pose(bad)
        with pytest.raises(ValidationError, match="finite"):
            clip.poses([0.0, bad])
    with pytest.raises(ValidationError, match="number"):
        clip.pose("soon")


@pytest.mark.parametrize("which", ["svd_clip", "transform_clip", "fourier_clip"])
def test_seconds_are_normalised_in_c_as_numpy_clip_does(which, request):
    """Clip.poses hands its seconds to the C loop, which normalises them block by block: the poses are those of
    the normalised times numpy.clip(t * per_second, 0, 1) gives, bit for bit (-0.0, tiny negatives, the ends)."""
    from motionrep.plugin.representation import empty_poses

    clip = motionrep.open(request.getfixturevalue(which)[1])
    rng = np.random.default_rng(5)
    t = np.concatenate([[-0.0, 0.0, -1e-300, 5e-324, -3.0, clip.duration, np.nextafter(clip.duration, 0.0),
                         clip.duration * 7.0], rng.random(300) * clip.duration])
    got = clip.poses(t)
    want = empty_poses(clip.skeleton, t.size, np.float64)
    u = np.clip(t * clip._per_second, 0.0, 1.0)
    assert clip._runtime.poses(u, want.rotations, want.root_translation, want.joint_translations) == 0
    for a, b in ((got.rotations, want.rotations), (got.root_translation, want.root_translation),
                 (got.joint_translations, want.joint_translations)):
        assert a.tobytes() == b.tobytes()


@pytest.mark.parametrize("codec, representation, least", [
    ("transform", "root-quat-axis-angle", 3), ("transform", "euler", 3), ("transform", "ortho6d", 3),
    ("transform", "dual-quaternion", 3), ("svd", "root-quat-axis-angle", 2), ("svd", "euler", 2),
    ("svd", "ortho6d", 2)])
def test_joints_constant_over_the_clip_are_converted_once_to_the_same_bits(codec, representation, least):
    """transform's and svd's decoders report the features constant over the clip (constant_features: for svd,
    those whose basis column is all zeros, which its sampler then writes as their means); the C loop then converts
    the joints whose features all are once (motionrep/_c/plan/module.c): the poses are bit for bit those of
    converting them at every pose (the same Runtime without the constants).  Bitwise: the decoders are scalar
    IEEE float64 C without FMA contraction or fast-math, the same bits in any vector lane."""
    from motionrep._cplan import SUB_BLOCK, Runtime
    from motionrep.pipeline.runtime import Pose

    motion = synthetic_motion(chain_skeleton(6), frames=80, fps=30, seed=7)
    rotations = motion.rotations.copy()
    rotations[:, 2] = [0.0, 0.0, 0.0, 1.0]  # a joint that never moves
    rotations[:, 4] = rotations[0, 4]  # one held at a pose of its own
    data = compress_motion(motion.replace(rotations=rotations), codec, representation=representation,
                           max_error="5%").data
    clip = motionrep.open(data)
    constant = clip._decoder.constant_features
    assert np.isfinite(constant).sum() >= least
    t = np.concatenate([[0.0, clip.duration], np.random.default_rng(8).random(500) * clip.duration])
    got = clip.poses(t)
    plain = Runtime(clip._plan, clip._decoder.sampler, constant.size, SUB_BLOCK, Pose)
    want = empty_poses(clip.skeleton, t.size, np.float64)
    assert plain.poses(t, want.rotations, want.root_translation, want.joint_translations, clip._per_second) == 0
    assert got.rotations.tobytes() == want.rotations.tobytes()
    assert got.root_translation.tobytes() == want.root_translation.tobytes()
    for one in t[:5]:
        assert clip.pose(one).rotations.tobytes() == want.rotations[np.flatnonzero(t == one)[0]].tobytes()


def test_positions_are_fk_of_the_poses(svd_clip):
    motion, data = svd_clip
    clip = motionrep.open(data)
    expected = global_positions(decompress(data))
    got = clip.positions(np.arange(motion.num_frames) / clip.fps)
    assert got.shape == expected.shape
    assert np.allclose(got, expected, atol=1e-9 * 100)


def test_axes_without_position_channels_keep_their_offset():
    sk = _partial_axes_skeleton()
    motion = synthetic_motion(sk, frames=20, fps=30, seed=5)
    clip = motionrep.open(compress_motion(motion, "svd", max_error=None, params={"rank": 1}).data)
    p = clip.poses(np.linspace(0, clip.duration, 13))
    assert np.all(p.root_translation[:, 1] == sk.offsets[0, 1])
    assert np.all(p.joint_translations[:, 0, [0, 2]] == sk.offsets[1, [0, 2]])


def test_one_frame_clip():
    motion = synthetic_motion(chain_skeleton(3), frames=1, fps=30, seed=6)
    clip = motionrep.open(compress_motion(motion, "svd", max_error=None, params={"rank": 0}).data)
    assert clip.duration == 0.0
    assert np.array_equal(clip.pose(3.0).rotations, clip.pose(0.0).rotations)


def test_a_payload_that_does_not_fit_its_codec_is_a_container_error(svd_clip):
    import dataclasses

    container = unpack(svd_clip[1])
    arrays = dict(container.arrays, basis=np.zeros((2, 2), np.float32))
    with pytest.raises(ContainerError, match="cannot decode this payload"):
        motionrep.open(dataclasses.replace(container, arrays=arrays))


def test_decoding_imports_no_torch(fourier_clip, tmp_path):
    path = tmp_path / "f.mrc"
    path.write_bytes(fourier_clip[1])
    code = ("import sys, motionrep; c = motionrep.open(sys.argv[1]); p = c.poses([0.0, 0.5]); c.pose(0.2); "
            "c.positions([0.1]); assert 'torch' not in sys.modules, 'torch imported'; print(len(p))")
    out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "2"


def test_fourier_windows_decode_like_decompress():
    motion = synthetic_motion(chain_skeleton(3), frames=60, fps=30, seed=7)
    data = compress_motion(motion, "naive-fourier", max_error=None, params={"k": 1, "iters": 25, "window": 20}).data
    clip = motionrep.open(data)
    expected = decompress(data)
    got = empty_poses(clip.skeleton, motion.num_frames)
    clip._decode_block(np.arange(60) / 59, got)
    assert np.array_equal(got.rotations, expected.rotations)
    times = np.random.default_rng(1).uniform(0, clip.duration, 300)
    batch = clip.poses(times)
    assert np.array_equal(clip.pose(times[17]).rotations, batch.rotations[17])


def test_motion_of_a_clip_is_decompress(svd_clip):
    motion, data = svd_clip
    got, expected = motionrep.open(data).motion(fps=45.0), decompress(data, fps=45.0)
    assert isinstance(got, Motion) and got.num_frames == expected.num_frames
    assert np.array_equal(got.rotations, expected.rotations)


# ---- a third party's decoder: without a C sampler, the runtime calls it from Python before the C pose plan ----
def _numba_sample(times, out, rows_t):
    """The transform decoder's sampling as a third party's numba kernel (``motionrep.jit``): the same arithmetic."""
    D, F = rows_t.shape
    for i in range(times.shape[0]):
        t = min(max(times[i], 0.0), 1.0)
        j, a = 0, 0.0
        if F > 1:
            pos = t * (F - 1)
            j = min(int(np.floor(pos)), F - 1)
            a = pos - j
        k = min(j + 1, F - 1)
        for d in range(D):
            v = rows_t[d, j]
            out[d, i] = v if a == 0.0 else v + (rows_t[d, k] - v) * a


class _NoSampler:
    """A shipped decoder seen through its Python face only: a C ``kernel``, a numba one, or neither."""

    def __init__(self, decoder, kernel: str):
        from motionrep.jit import jit

        self._decoder, self.width = decoder, decoder.width
        if kernel == "c":
            self.kernel, self.kernel_args = decoder.kernel, decoder.kernel_args
        elif kernel == "numba":
            self.kernel, self.kernel_args = jit(_numba_sample), (np.ascontiguousarray(decoder.frames.T),)

    def __call__(self, times, out=None):
        return self._decoder(times, out)


class _ThirdPartyCodec:
    """The transform codec as a third party would offer it: its decoder without ``sampler``."""

    def __init__(self, kernel: str):
        from motionrep.plugin.registry import get_codec

        self._codec, self._kernel = get_codec("transform"), kernel
        self.name = "transform"

    def check_payload(self, payload, num_frames):
        self._codec.check_payload(payload, num_frames)

    def decoder(self, payload):
        return _NoSampler(self._codec.decoder(payload), self._kernel)


@pytest.mark.parametrize("kernel", ["c", "numba", None], ids=["c-kernel", "numba-kernel", "decoder-only"])
def test_a_decoder_without_a_c_sampler_decodes_the_same_poses(kernel):
    if kernel == "numba":
        pytest.importorskip("numba", reason="numba (the jit extra) is not installed")
    motion = synthetic_motion(chain_skeleton(5), frames=70, fps=30, seed=5)
    data = compress_motion(motion, "transform").data
    times = np.random.default_rng(0).random(1500) * motion.duration
    reference = motionrep.open(data)
    assert reference._runtime is not None  # the C loop
    other = Clip(unpack(data), codec=_ThirdPartyCodec(kernel))
    assert other._runtime is None
    a, b = reference.poses(times), other.poses(times)
    for name in ("rotations", "root_translation", "joint_translations"):
        assert np.array_equal(getattr(a, name), getattr(b, name))
    for t in times[:20]:
        assert np.array_equal(reference.pose(t).rotations, other.pose(t).rotations)
