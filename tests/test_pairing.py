"""Comparison across exports (motionrep.pipeline.pairing, evaluate/view/render --match, --resample, --common): small
skeletons written by the tests; the Blender round trips are tests/test_blender.py."""

from __future__ import annotations

import json

import numpy as np
import pytest

from helpers import HAVE_SHARED, SHARED_DATA, run_cli_caught
from motionrep import Motion, Skeleton
from motionrep.errors import ValidationError
from motionrep.pipeline.evaluate import compare, max_joint_error
from motionrep.io import read, write
from motionrep.model.kinematics import global_positions
from motionrep.model.ops import resample
from motionrep.pipeline.pairing import RESAMPLE_METHOD, MatchOptions, compared_bones, pair_points
from motionrep.model.rotations import euler_to_quat

NAMES = ("Hips", "Spine", "Head", "LeftLeg", "LeftFoot", "RightLeg", "RightFoot")
PARENTS = [-1, 0, 1, 0, 3, 0, 5]
OFFSETS = [[0, 90, 0], [0, 30, 0], [0, 40, 0], [10, -5, 0], [0, -40, 0], [-10, -5, 0], [0, -40, 0]]


def _clip(frames: int = 40, fps: float = 30.0, prefix: str = "", order=None, sites=True) -> Motion:
    """A walking 7-joint character; ``order`` lists the joints in another (parents-first) order."""
    order = list(range(7)) if order is None else list(order)
    where = {j: k for k, j in enumerate(order)}
    names = tuple(prefix + NAMES[j] for j in order)
    parents = np.array([-1 if PARENTS[j] < 0 else where[PARENTS[j]] for j in order])
    offsets = np.array([OFFSETS[j] for j in order], float)
    kw = {}
    if sites:
        kw = dict(end_site_parents=np.array([where[2], where[4], where[6]]),
                  end_site_offsets=np.array([[0, 10, 0], [0, -5, 12], [0, -5, 12]], float))
    sk = Skeleton(names, parents, offsets, **kw)
    t = np.arange(frames) / fps
    angles = np.zeros((frames, 7, 3))
    angles[:, :, 0] = 0.5 * np.sin(2 * np.pi * t)[:, None] * np.linspace(0.3, 1.0, 7)
    angles[:, :, 2] = 0.2 * np.cos(2 * np.pi * t)[:, None]
    root = np.stack([30 * t, 90 + 2 * np.sin(4 * np.pi * t), np.zeros(frames)], axis=1)
    return Motion(sk, fps, root, euler_to_quat(angles[:, order], "XYZ"), np.zeros((frames, 0, 3)))


def _tails(motion: Motion) -> Motion:
    """``motion`` with its end sites as leaf joints ``<joint>_end`` (what Blender brings back)."""
    sk = motion.skeleton
    names = sk.names + tuple(f"{sk.names[p]}_end" for p in sk.end_site_parents)
    parents = np.concatenate([sk.parents, sk.end_site_parents])
    offsets = np.concatenate([sk.offsets, sk.end_site_offsets])
    E, F = sk.num_end_sites, motion.num_frames
    rot = np.concatenate([motion.rotations, np.tile([0, 0, 0, 1.0], (F, E, 1))], axis=1)
    return Motion(Skeleton(names, parents, offsets), motion.fps, motion.root_translation, rot,
                  np.zeros((F, 0, 3)))


def test_joints_in_another_order_with_a_prefix_compare_exactly_by_name():
    ref = _clip()
    cand = _clip(prefix="mixamorig:", order=[0, 5, 6, 3, 4, 1, 2])
    with pytest.raises(ValidationError, match=r"match='names'"):
        max_joint_error(ref, cand)
    with pytest.raises(ValidationError, match=r"no joint name in common .*strip_prefix removes"):
        max_joint_error(ref, cand, MatchOptions(match="names"))
    report = max_joint_error(ref, cand, MatchOptions(match="names", strip_prefix=("mixamorig:",)))
    assert report.max_error < 1e-9 * report.height  # the same FK in another order: float rounding only
    assert report.num_points == 10 and report.comparison.complete
    assert set(report.comparison.joints) == set(NAMES) and len(report.comparison.end_sites) == 3


def test_end_sites_as_bone_tails_are_paired_by_position_and_missing_ones_listed():
    ref = _clip()
    report = max_joint_error(ref, _tails(ref), MatchOptions(match="names"))
    assert report.max_error < 1e-9 and report.num_points == 10
    assert report.comparison.tails == (("Head/End Site", "Head_end"), ("LeftFoot/End Site", "LeftFoot_end"),
                                       ("RightFoot/End Site", "RightFoot_end"))
    # the other way round: the reference has the tails, the candidate end sites
    back = max_joint_error(_tails(ref), ref, MatchOptions(match="names"))
    assert back.max_error < 1e-9 and back.num_points == 10 and back.comparison.complete
    # no end sites at all on one side: the points both have, the end sites listed as left out
    bare = max_joint_error(ref, _clip(sites=False), MatchOptions(match="names"))
    assert bare.num_points == 7 and bare.max_error < 1e-9
    assert bare.comparison.left_out["reference_end_sites"] == ["Head/End Site", "LeftFoot/End Site",
                                                               "RightFoot/End Site"]
    assert any("end sites only the reference has (3)" in line for line in bare.comparison.lines())


def test_a_tail_far_from_the_end_site_is_not_paired_and_extra_joints_need_ignore_extra():
    ref = _clip()
    moved = _tails(ref)
    sk = moved.skeleton
    offsets = sk.offsets.copy()
    offsets[sk.index("Head_end")] = [0, 30, 0]  # 20 units (more than 1 % of the height) from the end site
    moved = moved.replace(skeleton=Skeleton(sk.names, sk.parents, offsets))
    with pytest.raises(ValidationError, match=r"1 joint only in the candidate: 'Head_end' \(ignore_extra=True"):
        max_joint_error(ref, moved, MatchOptions(match="names"))
    report = max_joint_error(ref, moved, MatchOptions(match="names", ignore_extra=True))
    assert report.comparison.left_out["candidate_joints"] == ["Head_end"]
    assert report.comparison.left_out["reference_end_sites"] == ["Head/End Site"]
    assert report.num_points == 9 and report.max_error < 1e-9


def test_an_error_is_found_where_it_is_and_named_by_the_reference():
    ref = _clip()
    cand = _clip(prefix="x:", order=[0, 3, 4, 5, 6, 1, 2])
    rot = cand.rotations.copy()
    rot[17, cand.skeleton.index("x:Spine")] = euler_to_quat(np.array([0.1, 0, 0]), "XYZ")
    report = max_joint_error(ref, cand.replace(rotations=rot), MatchOptions(match="names", strip_prefix="x:"))
    assert report.frame == 17 and report.joint in ("Head/End Site", "Head")
    assert report.max_error > 1.0


def test_resample_samples_the_candidate_at_the_reference_times_and_lists_frames_outside():
    ref = _clip(frames=61, fps=60.0)
    cand = resample(ref, 30.0)  # 31 frames: every other reference frame, the others interpolated
    with pytest.raises(ValidationError, match=r"61 vs 31 at 60 vs 30 fps.*fps=60.*\(resample=True"):
        max_joint_error(ref, cand)
    report = max_joint_error(ref, cand, MatchOptions(resample=True))
    assert report.comparison.method == RESAMPLE_METHOD and report.num_frames == 61
    even = global_positions(ref)[::2] - global_positions(cand)
    assert np.abs(even).max() < 1e-9  # the frames both have agree; the error is between them
    assert 0 < report.max_error < 0.05 * report.height and report.frame % 2 == 1
    # a shorter candidate: the reference frames after its end are listed, not dropped silently
    short = compare(ref, cand.frames(slice(0, 21)), MatchOptions(resample=True))
    assert short.comparison.frames == (0, 40) and short.num_frames == 41
    assert short.comparison.left_out["reference_frames"] == [[41, 60]]
    longer = compare(ref.frames(slice(0, 21)), cand, MatchOptions(resample=True))
    assert longer.comparison.left_out["candidate_frames"] == [[11, 30]]


def test_options_check_themselves():
    with pytest.raises(ValidationError, match="needs match='names'"):
        MatchOptions(strip_prefix=("a:",))
    with pytest.raises(ValidationError, match="needs match='names'"):
        MatchOptions(ignore_extra=True)
    with pytest.raises(ValidationError, match="match must be"):
        MatchOptions(match="fuzzy")


def test_compared_bones_join_points_to_their_nearest_compared_ancestor():
    ref = _clip()
    points = pair_points(ref.skeleton, _clip(sites=False).skeleton, MatchOptions(match="names"))
    left_out = [p for p in points.reference if p != 1]  # Spine not compared: Head hangs from Hips
    bones = compared_bones(ref.skeleton, left_out)
    assert (0, left_out.index(2)) in {tuple(b) for b in bones.tolist()}


def _write(tmp_path, name, motion):
    path = tmp_path / name
    write(motion, path)
    return str(path)


def test_cli_evaluate_match_names_reports_what_it_compared(tmp_path):
    ref = _write(tmp_path, "ref.bvh", _clip())
    cand = _write(tmp_path, "cand.bvh", _clip(prefix="mixamorig:", order=[0, 5, 6, 3, 4, 1, 2], sites=False))
    strict = run_cli_caught("evaluate", ref, cand)
    assert strict.exit_code == 1 and "--match names" in strict.output
    run = run_cli_caught("evaluate", ref, cand, "--match", "names", "--strip-prefix", "mixamorig:")
    assert run.exit_code == 0, run.output
    assert "compared: 7 joints by name (prefix 'mixamorig:' removed), 0 end sites, frames 0-39 (40)" in run.output
    assert "left out: end sites only the reference has (3): Head/End Site" in run.output
    data = json.loads(run_cli_caught("evaluate", ref, cand, "--match", "names", "--strip-prefix",
                                           "mixamorig:", "--json").output)
    assert data["comparison"]["left_out"]["reference_end_sites"] == ["Head/End Site", "LeftFoot/End Site",
                                                                      "RightFoot/End Site"]
    assert data["comparison"]["frames"] == [0, 39] and data["num_points"] == 7
    plain = json.loads(run_cli_caught("evaluate", ref, ref, "--json").output)
    assert plain["comparison"]["match"] == "order" and len(plain["comparison"]["end_sites"]) == 3
    usage = run_cli_caught("evaluate", ref, cand, "--ignore-extra")
    assert usage.exit_code == 2 and "needs --match names" in usage.output


def test_cli_evaluate_common_compares_the_clips_both_have(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    for name in ("walk", "run"):
        _write(a, f"{name}.bvh", _clip())
    for name in ("walk", "jump"):
        _write(b, f"{name}.bvh", _clip())
    _write(a, "sit.bvh", _clip())
    refused = run_cli_caught("evaluate", str(a), str(b))
    assert refused.exit_code == 1 and "--common" in refused.output
    # one clip in common: one report, and the others listed
    run = run_cli_caught("evaluate", str(a), str(b), "--common", "--json")
    assert run.exit_code == 0, run.output
    _write(b, "sit.bvh", _clip())
    data = json.loads(run_cli_caught("evaluate", str(a), str(b), "--common", "--json").output)
    assert [c["clip"] for c in data["clips"]] == ["sit", "walk"]
    assert data["only_in_reference"] == ["run"] and data["only_in_candidate"] == ["jump"]
    text = run_cli_caught("evaluate", str(a), str(b), "--common").output
    assert "only in the reference, not compared (1): run" in text
    assert "only in the candidate, not compared (1): jump" in text


def test_cli_render_and_view_take_the_comparison_options(tmp_path):
    ref = _write(tmp_path, "ref.bvh", _clip(frames=20))
    cand = _write(tmp_path, "cand.bvh", resample(_clip(frames=20, prefix="m:", sites=False), 15.0))
    args = ["--match", "names", "--strip-prefix", "m:", "--resample"]
    run = run_cli_caught("render", ref, cand, "-o", str(tmp_path / "r.png"), "--count", "2", *args)
    assert run.exit_code == 0, run.output
    assert "left out: end sites only the reference has (3)" in run.output
    page = run_cli_caught("view", ref, cand, "-o", str(tmp_path / "v.html"), *args)
    assert page.exit_code == 0, page.output
    assert "compared: 7 joints by name" in page.output
    strict = run_cli_caught("view", ref, cand, "-o", str(tmp_path / "w.html"))
    assert strict.exit_code == 1 and "--match names" in strict.output


@pytest.mark.realdata
@pytest.mark.skipif(not HAVE_SHARED, reason=f"real clips not found at {SHARED_DATA}")
def test_a_real_mixamo_clip_without_its_namespace_end_sites_and_half_its_rate(tmp_path):
    """Mixamo's ``mixamorig:`` names against the same clip renamed, without end sites and at half the rate:
    every joint paired, the end sites listed, the frames both have exact."""
    ref = read(SHARED_DATA / "other/ganimator/Gangnam-Style.bvh")
    sk = ref.skeleton
    assert all(n.startswith("mixamorig:") for n in sk.names)
    bare = Skeleton(tuple(n[len("mixamorig:"):] for n in sk.names), sk.parents, sk.offsets, sk.channels)
    cand = ref.replace(skeleton=bare, euler_branch=None, euler_angles=None).frames(slice(0, None, 2))
    cand = cand.replace(fps=ref.fps / 2)
    options = MatchOptions(match="names", strip_prefix=("mixamorig:",), resample=True)
    report = max_joint_error(ref, cand, options)
    assert len(report.comparison.joints) == sk.num_joints and report.comparison.end_sites == ()
    assert len(report.comparison.left_out["reference_end_sites"]) == sk.num_end_sites
    assert report.comparison.method == RESAMPLE_METHOD
    even = compare(ref.frames(slice(0, None, 2)).replace(fps=ref.fps / 2), cand,
                   MatchOptions(match="names", strip_prefix=("mixamorig:",)))
    assert even.max_error <= 1e-9 * even.height  # the same numbers: FK rounding only


def test_cli_evaluate_common_between_two_databases(tmp_path):
    from motionrep.io import write_database

    write_database([("walk", _clip()), ("run", _clip(frames=30))], tmp_path / "a.h5")
    write_database([("walk", _clip()), ("jump", _clip(frames=20)), ("run", _clip(frames=30))], tmp_path / "b.h5")
    refused = run_cli_caught("evaluate", str(tmp_path / "a.h5"), str(tmp_path / "b.h5"))
    assert refused.exit_code == 1 and "only in" in refused.output and "--common" in refused.output
    run = run_cli_caught("evaluate", str(tmp_path / "a.h5"), str(tmp_path / "b.h5"), "--common", "--json")
    assert run.exit_code == 0, run.output
    data = json.loads(run.output)
    assert sorted(c["clip"] for c in data["clips"]) == ["run", "walk"]
    assert data["only_in_reference"] == [] and data["only_in_candidate"] == ["jump"]
    assert all(c["max_error"] == 0 for c in data["clips"])
