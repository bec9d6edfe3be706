"""``motionrep.pipeline.sources``: every clip-bearing file opened one way, and one rule that names the clips of many inputs
for every command (convert, compress, bench)."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from motionrep.io.archive import read_archive
from motionrep.errors import FormatError, ParameterError, ValidationError
from motionrep.io import list_clips, write, write_database
from motionrep.model.ops import resample, resample_times
from motionrep.batch.engine import pair_clips
from motionrep.pipeline.sources import collect_clips, open_source
from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, synthetic_motion
from helpers import run_cli


run = run_cli  # helpers.run_cli: the one CLI runner of the tests


@pytest.fixture
def tree(tmp_path) -> Path:
    """A directory of every kind of input: BVH and NPZ files in subdirectories, a database of two clips, a hidden
    file, a file of another type."""
    d = tmp_path / "clips"
    (d / "sub").mkdir(parents=True)
    (d / ".hidden").mkdir()
    write(synthetic_motion(chain_skeleton(3), frames=20, seed=1), d / "walk.bvh")
    write(synthetic_motion(chain_skeleton(4), frames=22, seed=2), d / "sub" / "arm.npz")
    write_database({"x": synthetic_motion(chain_skeleton(3), frames=24, seed=3),
                    "y": synthetic_motion(chain_skeleton(3), frames=26, seed=4)}, d / "sub" / "db.h5")
    write(synthetic_motion(chain_skeleton(3), frames=20, seed=5), d / ".hidden" / "skip.bvh")
    (d / "notes.txt").write_text("not a clip")
    return d


EXPECTED = ["sub__arm", "sub__db__x", "sub__db__y", "walk"]


def test_one_naming_rule(tree, tmp_path):
    refs = collect_clips([tree])
    assert [r.name for r in refs] == EXPECTED
    assert [r.clip for r in refs] == [None, "x", "y", None]
    assert refs[1].source == f"{tree / 'sub' / 'db.h5'}[x]" and refs[1].source_bytes is None
    assert refs[0].source_bytes == (tree / "sub" / "arm.npz").stat().st_size
    # a database alone keeps its clip names; a file given by name is named by its stem
    assert [r.name for r in collect_clips([tree / "sub" / "db.h5"])] == ["x", "y"]
    assert [r.name for r in collect_clips([tree / "walk.bvh", tree / "sub" / "db.h5"])] == ["walk", "db__x", "db__y"]
    assert [r.name for r in collect_clips([tree / "sub" / "db.h5"], clip="y")] == ["y"]


def test_collisions_keep_the_suffix_then_are_errors(tree, tmp_path):
    write(synthetic_motion(chain_skeleton(3), frames=20, seed=6), tree / "walk.npz")
    assert [r.name for r in collect_clips([tree / "walk.bvh", tree / "walk.npz"])] == ["walk.bvh", "walk.npz"]
    other = tmp_path / "other"
    other.mkdir()
    write(synthetic_motion(chain_skeleton(3), frames=20, seed=7), other / "walk.bvh")
    with pytest.raises(FormatError, match="two inputs would both be clip 'walk.bvh'"):
        collect_clips([tree / "walk.bvh", other / "walk.bvh", tree / "walk.npz"])
    with pytest.raises(ValidationError, match="given twice"):
        collect_clips([tree / "walk.bvh", tree / ".." / tree.name / "walk.bvh"])
    with pytest.raises(ValidationError, match="unknown file type '.txt'"):
        collect_clips([tree / "notes.txt"])
    with pytest.raises(FormatError, match="no such file"):
        collect_clips([tree / "missing.bvh"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(FormatError, match="no .bvh, .npz, .h5, .hdf5, .gltf, .glb, .fbx files"):
        collect_clips([tmp_path / "empty"])


def test_every_command_names_and_finds_the_same_clips(tree, tmp_path):
    """convert, compress and bench see the same clips under the same names (compress of a directory used to skip
    its .h5 databases, and bench named clips 'sub/arm' where the others said 'sub__arm')."""
    db = tmp_path / "all.h5"
    assert run("convert", tree, db).exit_code == 0
    assert list_clips(db) == EXPECTED
    archive = tmp_path / "all_mrc.h5"
    r = run("compress", tree, "-o", archive, "--codec", "svd")
    assert r.exit_code == 0, r.output
    assert sorted(read_archive(archive)) == EXPECTED
    out = tmp_path / "bench"
    r = run("bench", tree, "-c", "svd", "--decode-poses", "0", "-q", "--out", out)
    assert r.exit_code == 0, r.output
    rows = json.loads((out / "bench.json").read_text())["rows"]
    assert [row["clip"] for row in rows] == EXPECTED


def test_open_source_kinds(tree, tmp_path):
    mrc, archive = tmp_path / "walk.mrc", tmp_path / "a.h5"
    assert run("compress", tree / "walk.bvh", "-o", mrc, "--codec", "svd").exit_code == 0
    assert run("compress", tree / "sub" / "db.h5", "-o", archive, "--codec", "svd").exit_code == 0
    expect = {tree / "walk.bvh": ("motion", ["walk"]), tree / "sub" / "arm.npz": ("motion", ["arm"]),
              tree / "sub" / "db.h5": ("database", ["x", "y"]), mrc: ("compressed", ["walk"]),
              archive: ("archive", ["x", "y"])}
    for path, (kind, names) in expect.items():
        with open_source(path) as src:
            assert (src.kind, src.names) == (kind, names)
            motion = src.read(names[-1])
            assert motion.num_frames > 0
    with open_source(archive) as src:
        assert src.container("y").num_frames == 26 and src.size("y") > 0
        with pytest.raises(FormatError, match="holds 2 clips; choose one with clip=NAME: x, y"):
            src.read()
        with pytest.raises(FormatError, match="no clip named 'z'"):
            src.read("z")
    with open_source(tree / "walk.bvh") as src, pytest.raises(FormatError, match="holds motions"):
        src.container()
    with pytest.raises(FormatError, match="unknown file type"):
        open_source(tree / "notes.txt")


def test_evaluate_of_two_databases_opens_each_file_once(tree, tmp_path, monkeypatch):
    db, archive = tmp_path / "db.h5", tmp_path / "archive.h5"
    assert run("convert", tree, db).exit_code == 0
    assert run("compress", db, "-o", archive, "--codec", "svd").exit_code == 0
    opened: list[str] = []
    from motionrep.io._h5read import H5Reader

    original = H5Reader.__init__

    def counting(self, path, *args, **kwargs):  # every HDF5 file is opened through an H5Reader
        opened.append(Path(path).name)
        original(self, path, *args, **kwargs)

    monkeypatch.setattr(H5Reader, "__init__", counting)
    for a, b in ((db, archive), (db, db)):
        opened.clear()
        r = run("evaluate", a, b, "--json")
        assert r.exit_code == 0, r.output
        assert [c["clip"] for c in json.loads(r.output)["clips"]] == EXPECTED
        assert Counter(opened) == Counter([a.name, b.name])


def test_pair_clips(tree, tmp_path):
    with open_source(tree / "sub" / "db.h5") as db, open_source(tree / "walk.bvh") as one:
        assert pair_clips(db, db) == [("x", "x", "x"), ("y", "y", "y")]
        assert pair_clips(db, one, "y") == [("y", "y", "walk")]
        with pytest.raises(ParameterError, match="holds 2 clips"):
            pair_clips(db, one)


def test_one_resampler(tmp_path):
    """ops.resample serves decompress --fps, render's alignment and the conformance suite's upsampling."""
    from motionrep.model.synthetic import odd_skeleton
    from motionrep.testing import upsample_motion

    m = synthetic_motion(odd_skeleton(), frames=31, fps=30.0, seed=2)
    up = upsample_motion(m, 4)
    assert up.num_frames == 121 and up.fps == 120.0
    assert np.allclose(up.rotations[::4], m.rotations, atol=1e-12)
    assert np.allclose(up.root_translation[::4], m.root_translation)
    down = resample(up, 30.0)
    assert down.num_frames == 31 and np.allclose(down.rotations, m.rotations, atol=1e-12)
    # 1- and 2-axis joints stay expressible with their own axes between frames
    x_only = m.skeleton.index("x_only")
    assert np.allclose(up.rotations[:, x_only, 1:3], 0.0, atol=1e-12)
    assert resample(m, 60.0).num_frames == len(resample_times(31, 30.0, 60.0)) == 61
    h = synthetic_motion(humanoid_skeleton(), frames=10, fps=30.0)
    assert resample(h, 7.0).num_frames == len(resample_times(10, 30.0, 7.0)) == 3


def test_options_are_resolved_once_and_passed_down(tree, tmp_path, monkeypatch):
    """compress and bench resolve a setting (codec, representation, parameters, bound) once, not per clip."""
    from motionrep.pipeline.compress import Pipeline

    built = []
    original = Pipeline.build.__func__

    def counting(cls, *args, **kwargs):
        built.append(args[:1] or kwargs.get("codec"))
        return original(cls, *args, **kwargs)

    monkeypatch.setattr(Pipeline, "build", classmethod(counting))
    r = run("compress", tree, "-o", tmp_path / "all.h5", "--codec", "svd")
    assert r.exit_code == 0, r.output
    assert len(built) == 1  # four clips, one pipeline
    built.clear()
    r = run("bench", tree, "-c", "svd", "--max-error", "1%", "--max-error", "3%", "--decode-poses", "0", "-q")
    assert r.exit_code == 0, r.output
    assert len(built) == 2  # four clips x two bounds, one pipeline per bound
