"""The shared evaluation: FK-based L-infinity over joints and end sites, and the four compression figures."""

from __future__ import annotations

import math

import numpy as np
import pytest

from motionrep import Motion
from motionrep.errors import ValidationError
from motionrep.pipeline.evaluate import Evaluator, max_joint_error
from motionrep.pipeline.figures import compression_figures
from motionrep.model.kinematics import character_height
from motionrep.model.rotations import euler_to_quat
from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, synthetic_motion


def _still(skeleton, frames=10, fps=30.0):
    rot = np.zeros((frames, skeleton.num_joints, 4))
    rot[..., 3] = 1.0
    root = np.broadcast_to(skeleton.offsets[0], (frames, 3)).copy()
    return Motion(skeleton, fps, root, rot)


def test_identical_motions_have_zero_error():
    m = synthetic_motion(frames=20)
    r = max_joint_error(m, m)
    assert r.max_error == 0.0 and r.mean_error == 0.0 and r.max_error_percent == 0.0
    assert r.num_frames == 20 and r.num_points == m.skeleton.num_joints + m.skeleton.num_end_sites


def test_root_shift_in_one_frame_is_found_with_exact_value_mean_and_location():
    sk = chain_skeleton(4, bone=10.0)
    ref = _still(sk)
    root = ref.root_translation.copy()
    root[6] += (3.0, 4.0, 0.0)  # every point of frame 6 moves by 5
    r = max_joint_error(ref, ref.replace(root_translation=root))
    assert r.max_error == pytest.approx(5.0)
    assert r.frame == 6
    assert r.mean_error == pytest.approx(5.0 / 10)  # one frame of ten moved, every point by 5
    assert r.height == pytest.approx(character_height(sk)) and r.height == pytest.approx(40.0)
    assert r.max_error_percent == pytest.approx(100 * 5.0 / 40.0)


def test_end_sites_count_and_are_named():
    """Rotating the last joint by 90 degrees moves only its end site: by 10 * sqrt(2)."""
    sk = chain_skeleton(4, orders=("XYZ",) * 4, bone=10.0)
    ref = _still(sk, frames=3)
    rot = ref.rotations.copy()
    rot[2, 3] = euler_to_quat(np.array([0.0, 0.0, 90.0]), "XYZ", degrees=True)
    r = max_joint_error(ref, ref.replace(rotations=rot))
    assert r.max_error == pytest.approx(10.0 * math.sqrt(2.0))
    assert (r.frame, r.joint) == (2, "j3/End Site")


def test_evaluator_reuses_reference_and_checks_positions_shape():
    m = synthetic_motion(humanoid_skeleton(), frames=12, seed=3)
    ev = Evaluator(m)
    other = synthetic_motion(humanoid_skeleton(), frames=12, seed=4)
    assert ev(other) == max_joint_error(m, other)
    with pytest.raises(ValidationError):
        ev.positions_error(np.zeros((3, 2, 3)))


@pytest.mark.parametrize("change", ["frames", "fps", "skeleton"])
def test_incomparable_motions_raise(change):
    m = synthetic_motion(chain_skeleton(4), frames=10)
    if change == "frames":
        other = m.frames(slice(0, 9))
    elif change == "fps":
        other = m.replace(fps=m.fps * 2)
    else:
        other = synthetic_motion(chain_skeleton(5), frames=10)
    with pytest.raises(ValidationError):
        max_joint_error(m, other)


def test_compression_figures_follow_their_definitions():
    f = compression_figures(num_frames=900, feature_width=97, num_parameters=5205, num_channels=96, num_joints=31,
                            compressed_bytes=21932, source_bytes=700000)
    assert f.paper_ratio == pytest.approx(900 * 97 / 5205)
    assert f.float32_ratio == pytest.approx(900 * 96 * 4 / 21932)
    assert f.bits_per_joint_frame == pytest.approx(21932 * 8 / (900 * 31))
    assert f.file_ratio == pytest.approx(700000 / 21932)
    assert compression_figures(num_frames=1, feature_width=1, num_parameters=1, num_channels=1, num_joints=1,
                               compressed_bytes=1).file_ratio is None
    with pytest.raises(ValidationError):
        compression_figures(num_frames=0, feature_width=1, num_parameters=1, num_channels=1, num_joints=1,
                            compressed_bytes=1)


def test_frame_count_mismatch_says_the_rates():
    sk = chain_skeleton(3)
    ref = synthetic_motion(sk, frames=20, fps=30)
    with pytest.raises(ValidationError, match=r"20 vs 40 at 30 vs 60 fps .*fps=30"):
        max_joint_error(ref, synthetic_motion(sk, frames=40, fps=60))
    with pytest.raises(ValidationError, match=r"different frame counts: 20 vs 21 \(resample=True samples"):
        max_joint_error(ref, synthetic_motion(sk, frames=21, fps=30))


def test_positions_error_of_some_frames_reports_clip_frames():
    sk = humanoid_skeleton()
    ref = synthetic_motion(sk, frames=30, fps=30, seed=1)
    cand = synthetic_motion(sk, frames=30, fps=30, seed=2)
    ev = Evaluator(ref)
    from motionrep.model.kinematics import global_positions

    pos = global_positions(cand)
    whole = ev.positions_error(pos)
    dist = np.linalg.norm(pos - ev.reference_positions, axis=-1)
    part = ev.positions_error(pos[10:20], first=10)
    assert part.max_error == dist[10:20].max() and part.num_frames == 10
    assert 10 <= part.frame < 20 and dist[part.frame].max() == part.max_error
    assert part.max_error <= whole.max_error
    with pytest.raises(ValidationError, match="not frames of the reference"):
        ev.positions_error(pos[:5], first=27)


def test_context_frame_errors_match_the_report():
    from motionrep.pipeline.evaluate import MotionContext
    from motionrep.plugin.registry import get_codec, get_representation

    m = synthetic_motion(humanoid_skeleton(), frames=40, seed=2)
    rep = get_representation("root-quat-axis-angle")
    ctx = MotionContext(m, rep, get_codec("svd"), None)
    f = rep.to_features(m) + np.random.default_rng(0).normal(scale=1e-2, size=(40, rep.width(m.skeleton)))
    per_frame = ctx.frame_errors(f)
    report = ctx.evaluate(f)
    assert per_frame.shape == (40,) and per_frame.max() == report.max_error
    assert int(per_frame.argmax()) == report.frame
    part = ctx.frame_errors(f[10:20], 10)
    np.testing.assert_array_equal(part, per_frame[10:20])
    assert part.max() == ctx.evaluate_frames(f[10:20], 10).max_error
    with pytest.raises(ValidationError):
        ctx.frame_errors(f[:5], 38)


def test_context_feature_sensitivity():
    """Position units per feature unit: 1 for the root translation, the lever arm for a rotation, 0 for a
    feature that moves nothing."""
    from motionrep.pipeline.evaluate import MotionContext
    from motionrep.plugin.registry import get_codec, get_representation

    sk = chain_skeleton(3, orders=("ZXY", "ZXY", "ZXY"), bone=10.0)  # j0 -> j1 -> j2 -> end site, along +Y
    m = synthetic_motion(sk, frames=100, seed=1, amplitude_deg=0.0)  # rest pose: the chain straight up
    rep = get_representation("root-quat-axis-angle")
    names = rep.feature_names(sk)
    ctx = MotionContext(m, rep, get_codec("svd"), None)
    s = ctx.feature_sensitivity(rep.to_features(m))
    assert s.shape == (min(64, 4096 // len(names)), len(names))
    col = {n: s[:, i] for i, n in enumerate(names)}
    for axis in ("tx", "ty", "tz"):
        np.testing.assert_allclose(col[f"j0/{axis}"], 1.0, rtol=1e-5)
    # j2 rotates only its end site, 10 units up the Y axis: a swing about X or Z moves it 10 per radian, a
    # twist about Y not at all
    np.testing.assert_allclose(col["j2/aa_x"], 10.0, rtol=1e-4)
    np.testing.assert_allclose(col["j2/aa_z"], 10.0, rtol=1e-4)
    assert np.all(col["j2/aa_y"] < 1e-4)
    np.testing.assert_allclose(col["j1/aa_x"], 20.0, rtol=1e-4)


@pytest.mark.parametrize("name", ["root-quat-axis-angle", "euler", "ortho6d", "dual-quaternion"])
def test_the_context_decodes_through_the_plan_with_the_motions_bits(name):
    """``frame_errors`` and ``feature_sensitivity`` decode through the representation's pose plan into pose arrays
    (fixed translation axes set by the plan) and FK them, without building a Motion: the same bits as the Motion
    path (``from_features``, ``fixed_axes_restored``, ``global_positions``, numpy's distances), which a context
    without a plan takes.  Scalar IEEE float64 in both, no fused multiply-add: compared bitwise."""
    from motionrep import Skeleton
    from motionrep.pipeline.evaluate import MotionContext
    from motionrep.plugin.registry import get_codec, get_representation

    sk = humanoid_skeleton()
    chans = list(sk.channels)
    chans[0] = ("Xposition", "Zposition") + tuple(c for c in chans[0] if c.endswith("rotation"))  # Y fixed
    chans[5] = ("Yposition",) + tuple(c for c in chans[5] if c.endswith("rotation"))  # a joint moving on Y only
    sk = Skeleton(sk.names, sk.parents, sk.offsets, tuple(chans), sk.end_site_parents, sk.end_site_offsets)
    m = synthetic_motion(sk, frames=50, seed=4)
    rep = get_representation(name)
    fast = MotionContext(m, rep, get_codec("svd"), None)
    slow = MotionContext(m, rep, get_codec("svd"), None)
    assert fast._plan is not None
    slow._plan = None  # the Motion path
    f = rep.to_features(m) + np.random.default_rng(1).normal(scale=1e-2, size=(50, rep.width(sk)))
    for a, b in ((fast.frame_errors(f), slow.frame_errors(f)), (fast.frame_errors(f[7:19], 7),
                                                                slow.frame_errors(f[7:19], 7)),
                 (fast.feature_sensitivity(f), slow.feature_sensitivity(f))):
        assert a.dtype == b.dtype == np.float64 and np.array_equal(a.view(np.uint64), b.view(np.uint64))
    assert fast.evaluations == slow.evaluations == 4
    # the per-frame errors are the report's distances: the report's maximum, bit for bit
    assert fast.frame_errors(f).max() == fast.evaluate(f).max_error
    bad = f.copy()
    bad[3, 5] = np.nan
    for ctx in (fast, slow):
        with pytest.raises(ValidationError):
            ctx.frame_errors(bad)
