"""The ``convert`` and ``info`` commands, in process (CliRunner) and as a real subprocess."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from motionrep import Motion, Skeleton

from motionrep.plugin import registry as plugins
from motionrep.errors import ValidationError
from motionrep.plugin.hookspecs import hookimpl
from motionrep.io import list_clips, read, read_bvh, read_features, read_stored, write, write_database
from motionrep.io._bvh import channel_values, format_bvh
from motionrep.model.kinematics import character_height
from motionrep.plugin.representation import Representation
from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, synthetic_motion

from helpers import HAVE_SHARED, SHARED_DATA, requires_shared, run_cli_caught

REPO = Path(__file__).resolve().parent.parent


def run(*args: str):
    result = run_cli_caught(*args)
    assert "Traceback" not in result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result


def error_line(result) -> str:
    """The single error line on stderr (asserting there is exactly one, after any usage lines)."""
    lines = [ln for ln in result.stderr.splitlines() if ln.startswith("Error: ")]
    assert len(lines) == 1, result.stderr
    return lines[0]


def files_in(directory: Path) -> list[str]:
    return sorted(str(p.relative_to(directory)) for p in directory.rglob("*"))


@pytest.fixture
def walk(tmp_path) -> Path:
    path = tmp_path / "walk.bvh"
    write(synthetic_motion(humanoid_skeleton(), frames=30, fps=30, seed=7), path)
    return path


def bvh_text(path: Path) -> str:
    """What motionrep writes for the motion in ``path`` (the reference for exact round trips)."""
    return format_bvh(read_bvh(path))


# ---------------------------------------------------------------------------------------------------------------
# convert: single files
# ---------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("middle", ["walk.npz", "walk.h5", "walk.hdf5"])
def test_convert_bvh_through_npz_or_hdf5_and_back_is_exact(tmp_path, walk, middle):
    r1 = run("convert", walk, tmp_path / middle)
    assert r1.exit_code == 0 and r1.output.startswith(f"wrote {tmp_path / middle}: ")
    r2 = run("convert", tmp_path / middle, tmp_path / "back.bvh")
    assert r2.exit_code == 0, r2.output
    assert (tmp_path / "back.bvh").read_text() == bvh_text(walk)
    assert np.array_equal(channel_values(read(tmp_path / "back.bvh")), channel_values(read_bvh(walk)))
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["walk.bvh", middle, "back.bvh"])


def test_bvh_to_hdf5_names_the_clip_after_the_input(tmp_path, walk):
    assert run("convert", walk, tmp_path / "db.h5").exit_code == 0
    assert list_clips(tmp_path / "db.h5") == ["walk"]


@requires_shared
@pytest.mark.realdata
def test_convert_real_file_round_trip(tmp_path):
    src = SHARED_DATA / "edge" / "pybvh_rotation_first_root.bvh"
    assert run("convert", src, tmp_path / "a.h5").exit_code == 0
    assert run("convert", tmp_path / "a.h5", tmp_path / "b.npz").exit_code == 0
    assert run("convert", tmp_path / "b.npz", tmp_path / "c.bvh").exit_code == 0
    assert np.array_equal(channel_values(read_bvh(tmp_path / "c.bvh")), channel_values(read_bvh(src)))


def test_decimals(tmp_path, walk):
    assert run("convert", walk, tmp_path / "w2.bvh", "--decimals", "2").exit_code == 0
    frame_lines = (tmp_path / "w2.bvh").read_text().split("Frame Time:")[1].splitlines()[1:]
    assert len(frame_lines) == 30
    assert all(len(tok.split(".")[1]) == 2 for line in frame_lines for tok in line.split())
    ref = channel_values(read_bvh(walk))
    assert np.max(np.abs(channel_values(read_bvh(tmp_path / "w2.bvh")) - ref)) <= 0.005 + 1e-9


# ---------------------------------------------------------------------------------------------------------------
# convert: directories and databases
# ---------------------------------------------------------------------------------------------------------------
@pytest.fixture
def clip_dir(tmp_path) -> Path:
    d = tmp_path / "clips"
    (d / "sub").mkdir(parents=True)
    write(synthetic_motion(humanoid_skeleton(), frames=20, seed=1), d / "a.bvh")
    write(synthetic_motion(chain_skeleton(5), frames=7, fps=24, seed=2), d / "sub" / "b.bvh")
    write(synthetic_motion(humanoid_skeleton("YXZ"), frames=11, seed=3), d / "sub" / "c.npz")
    write(synthetic_motion(chain_skeleton(2), frames=2), d / ".hidden.bvh")  # skipped: hidden
    (d / "notes.txt").write_text("not a motion")  # skipped: unknown suffix inside a directory
    return d


def test_directory_to_database_to_directory(tmp_path, clip_dir):
    db = tmp_path / "db.h5"
    r = run("convert", clip_dir, db)
    assert r.exit_code == 0, r.output
    # progress on stderr (not a terminal: the first and last clip, and a line every 10 s), on stdout only what was
    # written
    assert r.stderr.startswith("[1/3] converted a;") and "[3/3] converted sub__c" in r.stderr, r.stderr
    assert r.stdout == f"wrote {db}: 3 clips\n"
    assert list_clips(db) == ["a", "sub__b", "sub__c"]
    originals = {"a": read(clip_dir / "a.bvh"), "sub__b": read(clip_dir / "sub" / "b.bvh"),
                 "sub__c": read(clip_dir / "sub" / "c.npz")}

    out = tmp_path / "out"
    assert run("convert", db, out).exit_code == 0  # directory created, BVH by default
    assert files_in(out) == ["a.bvh", "sub__b.bvh", "sub__c.bvh"]
    for name, motion in originals.items():  # exactly what writing the source motion as BVH gives
        assert (out / f"{name}.bvh").read_text() == format_bvh(motion), name

    out_npz = tmp_path / "out_npz"
    assert run("convert", db, str(out_npz) + "/", "--format", "npz").exit_code == 0
    assert files_in(out_npz) == ["a.npz", "sub__b.npz", "sub__c.npz"]
    for name, motion in originals.items():
        back = read(out_npz / f"{name}.npz")
        for field in ("root_translation", "rotations", "joint_translations"):
            assert np.array_equal(getattr(back, field), getattr(motion, field)), (name, field)

    out_h5 = tmp_path / "out_h5"
    assert run("convert", db, out_h5, "--format", "h5").exit_code == 0
    assert files_in(out_h5) == ["a.h5", "sub__b.h5", "sub__c.h5"]
    assert list_clips(out_h5 / "sub__b.h5") == ["sub__b"]


def test_clip_option_takes_one_clip_out(tmp_path, clip_dir):
    db = tmp_path / "db.h5"
    run("convert", clip_dir, db)
    r = run("convert", db, tmp_path / "b.bvh", "--clip", "sub__b")
    assert r.exit_code == 0
    assert (tmp_path / "b.bvh").read_text() == bvh_text(clip_dir / "sub" / "b.bvh")
    r = run("convert", db, tmp_path / "one.h5", "--clip", "a")
    assert r.exit_code == 0 and list_clips(tmp_path / "one.h5") == ["a"]


def test_several_inputs_and_name_collisions(tmp_path, walk):
    other = tmp_path / "walk.npz"
    write(synthetic_motion(chain_skeleton(3), frames=4), other)
    db = tmp_path / "two.h5"
    write_database({"x": synthetic_motion(chain_skeleton(2), frames=2),
                    "y": synthetic_motion(chain_skeleton(2), frames=3)}, db)
    r = run("convert", walk, other, db, tmp_path / "all.h5")
    assert r.exit_code == 0, r.output
    assert list_clips(tmp_path / "all.h5") == ["walk.bvh", "walk.npz", "two__x", "two__y"]


def test_database_to_one_file_needs_a_clip(tmp_path, clip_dir):
    db = tmp_path / "db.h5"
    run("convert", clip_dir, db)
    r = run("convert", db, tmp_path / "x.bvh")
    assert r.exit_code == 2
    assert "3 (a, sub__b, sub__c)" in r.stderr and "--clip" in r.stderr
    assert not (tmp_path / "x.bvh").exists()


# ---------------------------------------------------------------------------------------------------------------
# convert: errors
# ---------------------------------------------------------------------------------------------------------------
def test_missing_input(tmp_path):
    r = run("convert", tmp_path / "nope.bvh", tmp_path / "out.npz")
    assert r.exit_code == 1
    assert error_line(r) == f"Error: {tmp_path / 'nope.bvh'}: no such file or directory"
    assert list(tmp_path.iterdir()) == []


BAD_BVH = """HIERARCHY
ROOT Hips
{
\tOFFSET 0 0 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
\tEnd Site
\t{
\t\tOFFSET 0 1 0
\t}
}
MOTION
Frames: 2
Frame Time: 0.033333
0 0 0 0 0 0
0 0 zero 0 0 0
"""


@pytest.mark.parametrize("out_name", ["out.npz", "out.h5", "out.bvh", "outdir"])
def test_malformed_bvh_written_in_test(tmp_path, out_name):
    bad = tmp_path / "bad.bvh"
    bad.write_text(BAD_BVH)
    r = run("convert", bad, tmp_path / out_name)
    assert r.exit_code == 1
    line = error_line(r)
    assert line.startswith(f"Error: {bad}:15: ") and "zero" in line
    assert [p.name for p in tmp_path.iterdir()] == ["bad.bvh"]  # nothing written, not even the directory


MALFORMED = sorted((SHARED_DATA / "edge" / "malformed").glob("*.bvh")) if HAVE_SHARED else []


@requires_shared
@pytest.mark.realdata
@pytest.mark.parametrize("bad", MALFORMED or [None], ids=lambda p: getattr(p, "name", "none"))
def test_malformed_real_bvh(tmp_path, bad):
    for out in (tmp_path / "x.npz", tmp_path / "x.h5"):
        r = run("convert", bad, out)
        assert r.exit_code == 1
        line = error_line(r)
        assert line.startswith(f"Error: {bad}:")
        assert int(line[len(f"Error: {bad}:"):].split(":")[0]) >= 1  # the line number
    r = run("info", bad)
    assert r.exit_code == 1 and error_line(r).startswith(f"Error: {bad}:")
    assert list(tmp_path.iterdir()) == []


def test_batch_failure_into_database_leaves_no_file_and_keeps_the_old_one(tmp_path, clip_dir):
    (clip_dir / "sub" / "broken.bvh").write_text(BAD_BVH)
    db = tmp_path / "db.h5"
    db.write_bytes(b"previous database")
    r = run("convert", clip_dir, db, "--force")
    assert r.exit_code == 1
    assert error_line(r).startswith(f"Error: {clip_dir / 'sub' / 'broken.bvh'}:15: ")
    assert db.read_bytes() == b"previous database"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["clips", "db.h5"]


def test_batch_failure_into_directory_says_what_was_written(tmp_path, clip_dir):
    (clip_dir / "sub" / "broken.bvh").write_text(BAD_BVH)  # sorted after a.bvh, before sub/c.npz
    out = tmp_path / "out"
    r = run("convert", clip_dir, out, "--format", "npz")
    assert r.exit_code == 1
    line = error_line(r)
    assert line.startswith(f"Error: {clip_dir / 'sub' / 'broken.bvh'}:15: ")
    assert line.endswith(f"2 of 4 files were written to {out} before this error: a.npz, sub__b.npz")
    assert files_in(out) == ["a.npz", "sub__b.npz"]


@pytest.mark.parametrize("content, message", [
    (b"garbage that is not a zip", "not an NPZ archive"),
    (b"PK\x03\x04 truncated", "not an NPZ archive"),
])
def test_corrupted_npz(tmp_path, content, message):
    bad = tmp_path / "bad.npz"
    bad.write_bytes(content)
    for args in (("convert", bad, tmp_path / "x.bvh"), ("info", bad)):
        r = run(*args)
        assert r.exit_code == 1
        assert error_line(r).startswith(f"Error: {bad}: {message}")
    assert [p.name for p in tmp_path.iterdir()] == ["bad.npz"]


def test_corrupted_hdf5(tmp_path, walk):
    good = tmp_path / "good.h5"
    run("convert", walk, good)
    data = bytearray(good.read_bytes())
    truncated = tmp_path / "trunc.h5"
    truncated.write_bytes(bytes(data[: len(data) // 3]))
    text = tmp_path / "text.h5"
    text.write_bytes(b"hello")
    for bad in (truncated, text):
        for args in (("convert", bad, tmp_path / "x.bvh"), ("info", bad), ("convert", bad, tmp_path / "d")):
            r = run(*args)
            assert r.exit_code == 1, args
            assert error_line(r).startswith(f"Error: {bad}: ")
    assert not (tmp_path / "x.bvh").exists() and not (tmp_path / "d").exists()


def test_unknown_clip(tmp_path, clip_dir):
    db = tmp_path / "db.h5"
    run("convert", clip_dir, db)
    for args in (("convert", db, tmp_path / "x.bvh", "--clip", "nope"), ("info", db, "--clip", "nope")):
        r = run(*args)
        assert r.exit_code == 1
        assert error_line(r) == f"Error: {db}: no clip named 'nope'; clips in this file: a, sub__b, sub__c"
    assert not (tmp_path / "x.bvh").exists()


@pytest.mark.parametrize("args, message", [
    (("{walk}", "{tmp}/x.fbx"), "motionrep reads FBX but does not write it"),
    (("{tmp}/x.xyz", "{tmp}/x.bvh"), "unknown file type '.xyz'"),
    (("{walk}", "{walk}"), "input and output are the same"),
    (("{walk}",), "at least one input and an output"),
    (("{walk}", "{tmp}/x.npz", "--decimals", "3"), "--decimals applies only to BVH"),
    (("{walk}", "{tmp}/x.npz", "--format", "bvh"), "--format applies only when OUT is a directory"),
    (("{walk}", "{tmp}/x.bvh", "--representation", "test-flat"), "--representation needs .npz or .h5"),
    (("{walk}", "{tmp}/x.npz", "--clip", "a"), "--clip takes one clip out of a single HDF5"),
    (("{walk}", "{tmp}/../{tmp.name}/walk.bvh", "{tmp}/x.npz"), "is given twice"),
    (("{walk}", "{tmp}", "{tmp}/x.bvh"), "is given twice"),
])
def test_usage_errors_exit_2(tmp_path, walk, args, message):
    r = run("convert", *[a.format(walk=walk, tmp=tmp_path) for a in args])
    assert r.exit_code == 2
    assert message in r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["walk.bvh"]


def test_several_clips_into_one_file(tmp_path, walk):
    write(synthetic_motion(chain_skeleton(3), frames=4), tmp_path / "other.bvh")
    r = run("convert", walk, tmp_path / "other.bvh", tmp_path / "x.npz")
    assert r.exit_code == 2 and "x.npz holds one clip but the inputs hold 2 (walk, other)" in r.stderr
    assert not (tmp_path / "x.npz").exists()


def test_info_usage_errors(tmp_path, walk):
    assert run("info", tmp_path / "x.txt").exit_code == 2
    r = run("info", walk, "--clip", "a")
    assert r.exit_code == 2 and "HDF5" in r.stderr
    r = run("info", tmp_path / "none.npz")
    assert r.exit_code == 1 and error_line(r).startswith(f"Error: {tmp_path / 'none.npz'}: ")


def test_empty_directory(tmp_path):
    (tmp_path / "empty").mkdir()
    r = run("convert", tmp_path / "empty", tmp_path / "db.h5")
    assert r.exit_code == 1 and "no .bvh, .npz, .h5, .hdf5, .gltf, .glb, .fbx files" in error_line(r)
    assert not (tmp_path / "db.h5").exists()


def test_output_inside_the_input_directory_is_not_read_back(tmp_path, clip_dir):
    assert run("convert", clip_dir, clip_dir / "all.h5").exit_code == 0
    assert run("convert", clip_dir, clip_dir / "all.h5", "--force").exit_code == 0  # the old all.h5 is skipped
    assert list_clips(clip_dir / "all.h5") == ["a", "sub__b", "sub__c"]


# ---------------------------------------------------------------------------------------------------------------
# info
# ---------------------------------------------------------------------------------------------------------------
def test_info_text(walk):
    r = run("info", walk)
    assert r.exit_code == 0 and r.stderr == ""
    lines = r.stdout.splitlines()
    motion = read_bvh(walk)
    height = character_height(motion.skeleton)
    assert "joints:     15" in lines and f"end sites:  {motion.skeleton.num_end_sites}" in lines and "frames:     30" in lines
    assert "fps:        30 (frame time 0.03333333 s)" in lines and "duration:   1 s" in lines and "channels:   48" in lines
    assert f"height:     {height:.6g} file units (unknown)" in lines
    assert any(ln.split() == ["Hips", "Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation",
                              "[ZXY]"] for ln in lines)
    assert any(ln.split() == ["LeftArm", "Zrotation", "Xrotation", "Yrotation", "[ZXY]"] for ln in lines)


def test_info_json_motion(tmp_path):
    m = synthetic_motion(humanoid_skeleton(), frames=12, fps=24)
    path = tmp_path / "m.npz"
    write(m, path)  # humanoid_skeleton has units "cm"
    r = run("info", path, "--json")
    assert r.exit_code == 0
    d = json.loads(r.stdout)
    assert d["info_version"] == 1 and d["format"] == "npz" and d["kind"] == "motion" and d["clip"] == "m"
    assert d["file"] == str(path)
    assert (d["frames"], d["fps"], d["duration"], d["joints"], d["end_sites"], d["channels"]) == (
        12, 24.0, 0.5, 15, m.skeleton.num_end_sites, m.skeleton.num_channels)
    assert d["height"] == character_height(m.skeleton) and d["units"] == "cm"
    assert isinstance(d["frames"], int) and isinstance(d["fps"], float)
    assert [j["name"] for j in d["layout"]] == list(m.skeleton.names)
    root = d["layout"][0]
    assert root == {"name": "Hips", "parent": None, "channels": list(m.skeleton.channels[0]),
                    "rotation_order": "ZXY", "position_axes": "XYZ", "end_sites": 0}
    assert sum(j["end_sites"] for j in d["layout"]) == m.skeleton.num_end_sites == 5
    assert [j["parent"] for j in d["layout"][1:]] == [m.skeleton.names[p] for p in m.skeleton.parents[1:]]


def test_info_database_text_and_json(tmp_path, clip_dir):
    db = tmp_path / "db.h5"
    run("convert", clip_dir, db)
    r = run("info", db, "--json")
    d = json.loads(r.stdout)
    assert d["kind"] == "database" and d["format"] == "hdf5"
    assert [(c["name"], c["kind"], c["frames"], c["joints"]) for c in d["clips"]] == [
        ("a", "motion", 20, 15), ("sub__b", "motion", 7, 5), ("sub__c", "motion", 11, 15)]
    # BVH stores the frame time with a few digits; sub__c came from an NPZ file, which keeps fps exactly
    assert [c["fps"] for c in d["clips"]] == [pytest.approx(60, rel=1e-5), pytest.approx(24, rel=1e-5), 60.0]
    assert all(c["duration"] == pytest.approx(c["frames"] / c["fps"]) for c in d["clips"])
    text = run("info", db).stdout
    assert "hdf5 database, 3 clips" in text
    assert any(ln.split()[:4] == ["sub__b", "motion", "7", "24"] for ln in text.splitlines())
    one = json.loads(run("info", db, "--clip", "sub__b", "--json").stdout)
    assert one["kind"] == "motion" and one["clip"] == "sub__b" and one["frames"] == 7 and one["joints"] == 5


# ---------------------------------------------------------------------------------------------------------------
# features through the command line
# ---------------------------------------------------------------------------------------------------------------
class FlatRep(Representation):
    """A lossless toy representation: root translation, raw xyzw quaternions, joint translations."""

    name = "test-flat"
    version = 1

    def width(self, skeleton: Skeleton) -> int:
        return 3 + 4 * skeleton.num_joints + 3 * len(skeleton.translated_joints)

    def feature_names(self, skeleton: Skeleton) -> list[str]:
        return [f"f{i}" for i in range(self.width(skeleton))]

    def to_features(self, motion: Motion) -> np.ndarray:
        F = motion.num_frames
        return np.concatenate([motion.root_translation, motion.rotations.reshape(F, -1),
                               motion.joint_translations.reshape(F, -1)], axis=1)

    def from_features(self, features, skeleton: Skeleton, fps: float) -> Motion:
        f = np.asarray(features, dtype=np.float64)
        J, P = skeleton.num_joints, len(skeleton.translated_joints)
        if f.shape[1] != self.width(skeleton):
            raise ValidationError(f"bad features shape {f.shape}")
        return Motion(skeleton, fps, f[:, :3], f[:, 3:3 + 4 * J].reshape(-1, J, 4),
                      f[:, 3 + 4 * J:].reshape(f.shape[0], P, 3))

    def weights(self, motion: Motion) -> np.ndarray:
        return np.ones(self.width(motion.skeleton))


@pytest.fixture
def flat_rep(monkeypatch):
    monkeypatch.setattr(plugins, "DEFAULT_PLUGINS", ())

    class Plugin:
        @staticmethod
        @hookimpl
        def register_representations(register):
            register(FlatRep())

    plugins.pm.register(Plugin(), name="test-flat-plugin")


@pytest.mark.parametrize("suffix", [".npz", ".h5"])
def test_representation_features_and_back(tmp_path, walk, flat_rep, suffix):
    feats = tmp_path / f"walk_feats{suffix}"
    r = run("convert", walk, feats, "--representation", "test-flat")
    assert r.exit_code == 0, r.output
    clip = read_features(feats)
    assert clip.representation == "test-flat" and clip.features.shape == (30, 3 + 4 * 15)
    info = json.loads(run("info", feats, "--json").stdout)
    assert info["kind"] == "features"
    assert info["representation"] == {"name": "test-flat", "version": 1, "width": 63}
    assert "features:   test-flat version 1, width 63" in run("info", feats).stdout
    # features in, motion out: decoded through the representation
    assert run("convert", feats, tmp_path / "back.bvh").exit_code == 0
    ref = read_bvh(walk)
    np.testing.assert_allclose(channel_values(read_bvh(tmp_path / "back.bvh")), channel_values(ref),
                               rtol=0, atol=1e-9)
    # features in, same representation out: copied bit for bit
    assert run("convert", feats, tmp_path / "copy.npz", "--representation", "test-flat").exit_code == 0
    assert np.array_equal(read_features(tmp_path / "copy.npz").features, clip.features)


def test_representation_for_a_directory(tmp_path, clip_dir, flat_rep):
    r = run("convert", clip_dir, tmp_path / "feats.h5", "-r", "test-flat")
    assert r.exit_code == 0, r.output
    d = json.loads(run("info", tmp_path / "feats.h5", "--json").stdout)
    assert [(c["name"], c["kind"], c["representation"]) for c in d["clips"]] == [
        ("a", "features", "test-flat"), ("sub__b", "features", "test-flat"), ("sub__c", "features", "test-flat")]
    assert run("convert", tmp_path / "feats.h5", tmp_path / "motions").exit_code == 0
    assert files_in(tmp_path / "motions") == ["a.bvh", "sub__b.bvh", "sub__c.bvh"]
    name, motion = read_stored(tmp_path / "motions" / "sub__b.bvh")
    assert name == "sub__b" and motion.num_frames == 7


def test_unknown_representation(tmp_path, walk, flat_rep):
    r = run("convert", walk, tmp_path / "x.npz", "--representation", "nope")
    assert r.exit_code == 1
    assert "unknown representation 'nope'; available: test-flat" in error_line(r)
    assert not (tmp_path / "x.npz").exists()


# ---------------------------------------------------------------------------------------------------------------
# a real process
# ---------------------------------------------------------------------------------------------------------------
def _subprocess(*args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, MOTIONREP_LOAD_PLUGINS="")
    return subprocess.run([sys.executable, "-m", "motionrep", *map(str, args)], capture_output=True, text=True,
                          cwd=REPO, env=env, timeout=120)


def test_subprocess_convert_info_and_error(tmp_path, walk):
    p = _subprocess("convert", walk, tmp_path / "walk.h5")
    assert p.returncode == 0 and p.stdout == f"wrote {tmp_path / 'walk.h5'}: 1 clip\n" and p.stderr == "", p.stderr
    p = _subprocess("info", tmp_path / "walk.h5", "--json")
    assert p.returncode == 0
    d = json.loads(p.stdout)
    assert (d["format"], d["clip"], d["frames"], d["joints"]) == ("hdf5", "walk", 30, 15)
    bad = tmp_path / "bad.bvh"
    bad.write_text(BAD_BVH)
    p = _subprocess("convert", bad, tmp_path / "bad.npz")
    assert p.returncode == 1
    assert p.stderr.splitlines() == [f"Error: {bad}:15: expected a number, found 'zero'"]
    assert not (tmp_path / "bad.npz").exists()
