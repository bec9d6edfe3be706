"""``motionrep compress / decompress / evaluate / example`` from the command line."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from motionrep.io._demo import demo_path, demo_walk
from motionrep.io.archive import is_archive, read_archive
from motionrep.io import read, write, write_database
from motionrep.model.synthetic import chain_skeleton, synthetic_motion
from helpers import one_line_error, run_cli


run = run_cli  # helpers.run_cli: the one CLI runner of the tests


@pytest.fixture
def clip(tmp_path) -> Path:
    path = tmp_path / "clip.bvh"
    write(synthetic_motion(chain_skeleton(4), frames=40, fps=30, seed=3), path)
    return path


_one_line_error = one_line_error


def test_shipped_demo_clip_is_what_the_generator_makes(tmp_path):
    out = tmp_path / "walk.bvh"
    assert run("example", out).exit_code == 0
    assert out.read_bytes() == demo_path().read_bytes()
    regenerated = tmp_path / "regen.bvh"
    write(demo_walk(), regenerated, decimals=6)
    assert regenerated.read_bytes() == out.read_bytes()
    m = read(out)
    assert (m.num_frames, m.num_joints) == (450, 15) and m.fps == pytest.approx(30.0)


def test_compress_decompress_evaluate_round_trip(clip, tmp_path):
    mrc, back = tmp_path / "clip.mrc", tmp_path / "back.bvh"
    r = run("compress", clip, "-o", mrc, "--codec", "svd")
    assert r.exit_code == 0, r.output
    for needle in ("40 frames", "4 joints", "root-quat-axis-angle", "rank=", "L-inf error", "payload bits/bone/frame",
                   "file bits/bone/frame", "x smaller than source", "bytes in"):
        assert needle in r.output
    assert "paper ratio" not in r.output  # the other figures are behind --verbose
    r = run("compress", clip, "-o", mrc, "--codec", "svd", "--verbose", "--force")
    for needle in ("paper ratio", "vs float32 channels", "bits/joint/frame"):
        assert needle in r.output
    assert run("decompress", mrc, "-o", back).exit_code == 0
    r = run("evaluate", clip, back, "--json")
    report = json.loads(r.output)
    assert report["max_error_percent"] <= 2.0 and report["num_frames"] == 40
    r = run("evaluate", clip, mrc)  # a .mrc is decoded first
    assert r.exit_code == 0 and "L-inf error" in r.output


def test_compress_json_and_bound_in_file_units(clip, tmp_path):
    mrc = tmp_path / "c.mrc"
    r = run("compress", clip, "-o", mrc, "--codec", "svd", "--max-error", "0.5", "--json")
    data = json.loads(r.output)
    assert data["bound"] == 0.5 and data["evaluation"]["max_error"] <= 0.5
    assert set(data["figures"]) >= {"paper_ratio", "float32_ratio", "bits_per_joint_frame", "file_ratio",
                                    "payload_bits_per_bone_frame", "file_bits_per_bone_frame", "ratio_vs_source"}
    assert data["bytes"] == mrc.stat().st_size


def test_same_seed_same_bytes_from_the_cli(clip, tmp_path):
    a, b = tmp_path / "a.mrc", tmp_path / "b.mrc"
    args = ("--codec", "naive-fourier", "-p", "k=1", "-p", "iters=50", "--max-error", "none", "--seed", "3")
    assert run("compress", clip, "-o", a, *args).exit_code == 0
    assert run("compress", clip, "-o", b, *args).exit_code == 0
    assert a.read_bytes() == b.read_bytes()


def test_decompress_resamples(clip, tmp_path):
    mrc, out = tmp_path / "c.mrc", tmp_path / "c60.npz"
    run("compress", clip, "-o", mrc, "--codec", "svd")
    r = run("decompress", mrc, "-o", out, "--fps", "60")
    assert r.exit_code == 0, r.output
    m = read(out)
    assert m.fps == 60.0 and m.num_frames == 79  # 39 frame intervals at 30 fps = 1.3 s = 78 intervals at 60 fps


@pytest.mark.parametrize("args, needles", [
    (("--codec", "haar"), ("unknown codec 'haar'", "svd")),
    (("--codec", "svd", "--representation", "bones"), ("unknown representation 'bones'",)),
    (("--codec", "svd", "-p", "rank=-2"), ("rank must be",)),
    (("--codec", "svd", "-p", "colour=red"), ("unknown parameter 'colour'",)),
    (("--codec", "svd", "-p", "rank=1"), ("did not meet", "above the bound") ),
    (("--codec", "svd", "--max-error", "-3%"), ("--max-error",)),
    (("--codec", "adaptive-fourier", "-p", "max_k=0", "--max-error", "0.01%"), ("max_k=0", "best L-inf")),
])
def test_errors_are_one_line_exit_1_and_leave_no_file(clip, tmp_path, args, needles):
    out = tmp_path / "x.mrc"
    r = run("compress", clip, "-o", out, *args)
    if "rank=1" in args:
        needles = ("svd: rank 1 reaches",)
    _one_line_error(r, *needles)
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["clip.bvh"]


def test_altered_file_gives_a_clear_error(clip, tmp_path):
    mrc, out = tmp_path / "c.mrc", tmp_path / "d.bvh"
    run("compress", clip, "-o", mrc, "--codec", "svd")
    data = bytearray(mrc.read_bytes())
    data[len(data) // 2] ^= 0x10
    mrc.write_bytes(bytes(data))
    _one_line_error(run("decompress", mrc, "-o", out), "c.mrc", "checksum")
    mrc.write_bytes(bytes(data[:100]))
    _one_line_error(run("decompress", mrc, "-o", out), "truncated")
    assert not out.exists()


def test_evaluate_refuses_different_skeletons(clip, tmp_path):
    other = tmp_path / "other.bvh"
    write(synthetic_motion(chain_skeleton(5), frames=40, fps=30), other)
    _one_line_error(run("evaluate", clip, other), "different skeletons")


@pytest.mark.slow  # two spawned worker processes import motionrep and torch
def test_directory_to_archive_with_two_jobs(tmp_path):
    src = tmp_path / "clips"
    (src / "sub").mkdir(parents=True)
    write(synthetic_motion(chain_skeleton(3), frames=20, seed=1), src / "a.bvh")
    write(synthetic_motion(chain_skeleton(4), frames=25, seed=2), src / "sub" / "b.bvh")
    archive = tmp_path / "out.h5"
    r = run("compress", src, "-o", archive, "--codec", "svd", "--jobs", "2")
    assert r.exit_code == 0, r.output
    assert is_archive(archive)
    containers = read_archive(archive)
    assert sorted(containers) == ["a", "sub__b"] and containers["sub__b"].num_frames == 25
    db = tmp_path / "db.h5"
    r = run("decompress", archive, "-o", db)
    assert r.exit_code == 0, r.output
    one = tmp_path / "b.bvh"
    assert run("decompress", archive, "--clip", "sub__b", "-o", one).exit_code == 0
    assert read(one).num_frames == 25


def test_database_to_directory_of_mrc_files(tmp_path):
    db = tmp_path / "db.h5"
    write_database({"x": synthetic_motion(chain_skeleton(3), frames=20, seed=1),
                    "y": synthetic_motion(chain_skeleton(3), frames=22, seed=2)}, db)
    out = tmp_path / "mrc"
    r = run("compress", db, "-o", out, "--codec", "svd", "--json")
    assert r.exit_code == 0, r.output
    summary = json.loads(r.output)
    assert sorted(summary["clips"]) == ["x", "y"]
    assert sorted(p.name for p in out.iterdir()) == ["x.mrc", "y.mrc"]
    back = tmp_path / "y.bvh"
    assert run("decompress", out / "y.mrc", "-o", back).exit_code == 0
    assert read(back).num_frames == 22


def test_batch_reports_failed_clips_and_exits_1(tmp_path):
    src = tmp_path / "clips"
    src.mkdir()
    write(synthetic_motion(chain_skeleton(3), frames=20, seed=1), src / "a.bvh")
    out = tmp_path / "out"
    r = run("compress", src, "-o", out, "--codec", "svd", "-p", "rank=0")
    assert r.exit_code == 1
    assert "a: FAILED" in r.output and "1 of 1 clips failed" in r.output
    assert not out.exists()  # created with its first clip


def test_readme_quick_start(tmp_path):
    """The README's main job: compress the shipped clip with adaptive-fourier within 2 %."""
    walk, mrc, back = tmp_path / "walk.bvh", tmp_path / "walk.mrc", tmp_path / "walk2.bvh"
    assert run("example", walk).exit_code == 0
    r = run("compress", walk, "-o", mrc, "--codec", "adaptive-fourier")
    assert r.exit_code == 0, r.output
    assert "K=" in r.output or "K per window" in r.output  # one network, or windows where they are smaller
    assert run("decompress", mrc, "-o", back).exit_code == 0
    report = json.loads(run("evaluate", walk, back, "--json").output)
    assert report["max_error_percent"] <= 2.0


def test_info_on_a_compressed_file(clip, tmp_path):
    mrc = tmp_path / "clip.mrc"
    r = run("compress", clip, "-o", mrc, "--codec", "naive-fourier", "-p", "k=2", "--max-error", "none")
    assert r.exit_code == 0, r.output
    r = run("info", mrc)
    assert r.exit_code == 0, r.output
    for needle in ("format:     mrc (compressed)", "codec:      naive-fourier (payload version 4), parameters",
                   "outcome:    K=2, omega=[1, 2] cycles/clip, hidden 10", "features:   root-quat-axis-angle version 1",
                   f"size:       {mrc.stat().st_size} bytes", "payload bits/bone/frame", "L-inf:", "bound none",
                   "frames:     40", "channel layout"):
        assert needle in r.output, r.output
    assert "ratios:" not in r.output and "ratios:     paper" in run("info", mrc, "--verbose").output
    d = json.loads(run("info", mrc, "--json").output)
    assert (d["kind"], d["format"], d["frames"], d["joints"], d["bytes"]) == (
        "compressed", "mrc", 40, 4, mrc.stat().st_size)
    assert d["codec"]["name"] == "naive-fourier" and d["codec"]["outcome"]["K"] == 2
    assert d["codec"]["params"]["k"] == 2
    assert d["parameters"] == sum(int(np.prod(a["shape"])) for a in d["arrays"])
    assert d["figures"]["compressed_bytes"] == d["bytes"]
    assert d["figures"]["paper_ratio"] == pytest.approx(40 * d["representation"]["width"] / d["parameters"])
    # the stored evaluation is what evaluate measures on the decoded file
    measured = json.loads(run("evaluate", clip, mrc, "--json").output)
    assert d["evaluation"]["max_error"] == pytest.approx(measured["max_error"], rel=1e-12)
    r = run("info", mrc, "--clip", "x")  # a usage error, as for a BVH file
    assert r.exit_code == 2 and "--clip applies to HDF5 databases and archives" in r.output


def test_info_on_an_archive(tmp_path):
    src = tmp_path / "clips"
    src.mkdir()
    for i in range(2):
        write(synthetic_motion(chain_skeleton(3 + i), frames=30, fps=30, seed=i), src / f"c{i}.bvh")
    archive = tmp_path / "out.h5"
    assert run("compress", src, "-o", archive, "--codec", "svd").exit_code == 0
    r = run("info", archive)
    assert r.exit_code == 0, r.output
    assert "archive of compressed clips (.mrc), 2 clips" in r.output and "rank=" in r.output
    d = json.loads(run("info", archive, "--json").output)
    assert d["kind"] == "archive" and [c["name"] for c in d["clips"]] == ["c0", "c1"]
    assert [c["joints"] for c in d["clips"]] == [3, 4]
    stored = read_archive(archive)
    for row in d["clips"]:
        assert row["max_error"] == stored[row["name"]].evaluation["max_error"]
        assert row["bytes"] > 0
    one = json.loads(run("info", archive, "--clip", "c1", "--json").output)
    assert (one["kind"], one["clip"], one["joints"]) == ("compressed", "c1", 4)
    assert one["bytes"] == d["clips"][1]["bytes"]
    _one_line_error(run("info", archive, "--clip", "nope"), "nope", "c0, c1")


def test_info_on_a_corrupt_compressed_file(clip, tmp_path):
    mrc = tmp_path / "clip.mrc"
    assert run("compress", clip, "-o", mrc, "--codec", "svd").exit_code == 0
    data = bytearray(mrc.read_bytes())
    data[len(data) // 2] ^= 0xFF
    mrc.write_bytes(bytes(data))
    _one_line_error(run("info", mrc), "clip.mrc")


def test_evaluate_databases_and_archives_clip_by_clip(tmp_path):
    src = tmp_path / "clips"
    src.mkdir()
    for i in range(3):
        write(synthetic_motion(chain_skeleton(3 + i), frames=30, fps=30, seed=i), src / f"c{i}.bvh")
    db, archive, one = tmp_path / "db.h5", tmp_path / "out.h5", tmp_path / "c1.mrc"
    assert run("convert", src, db).exit_code == 0
    assert run("compress", db, "-o", archive, "--codec", "svd").exit_code == 0
    r = run("evaluate", db, archive)
    assert r.exit_code == 0, r.output
    assert "3 clips" in r.output and all(f"c{i} " in r.output for i in range(3)) and "worst: c" in r.output
    d = json.loads(run("evaluate", db, archive, "--json").output)
    assert [c["clip"] for c in d["clips"]] == ["c0", "c1", "c2"]
    stored = read_archive(archive)
    for c in d["clips"]:  # the same number compress measured and stored
        assert c["max_error"] == pytest.approx(stored[c["clip"]].evaluation["max_error"], rel=1e-12)
    assert d["worst"]["max_error_percent"] == max(c["max_error_percent"] for c in d["clips"])
    # one clip: --clip on the database side, a .mrc on the other
    assert run("compress", src / "c1.bvh", "-o", one, "--codec", "svd").exit_code == 0
    r = run("evaluate", db, one, "--clip", "c1", "--json")
    assert json.loads(r.output)["max_error"] == pytest.approx(stored["c1"].evaluation["max_error"], rel=1e-12)
    r = run("evaluate", db, one)
    assert r.exit_code == 2 and "holds 3 clips" in r.output and "--clip" in r.output
    _one_line_error(run("evaluate", db, archive, "--clip", "c9"), "no clip named 'c9'", "c0, c1, c2")
    assert run("evaluate", src / "c1.bvh", one, "--clip", "c1").exit_code == 2  # no database involved
    # different clips on the two sides: one line naming them, nothing compared
    partial = tmp_path / "partial.h5"
    write_database([(n, read(src / f"{n}.bvh")) for n in ("c0", "c2")], partial)
    _one_line_error(run("evaluate", db, partial), "only in", "c1")


def test_convert_decodes_an_mrc_and_points_to_compress_for_one(clip, tmp_path):
    mrc = tmp_path / "clip.mrc"
    assert run("compress", clip, "-o", mrc, "--codec", "svd").exit_code == 0
    r = run("convert", mrc, tmp_path / "x.bvh")  # decoded, as an archive of .mrc clips is (one rule)
    assert r.exit_code == 0 and (tmp_path / "x.bvh").exists(), r.output
    r = run("convert", clip, tmp_path / "y.mrc")
    assert r.exit_code == 2 and "motionrep compress" in r.output and not (tmp_path / "y.mrc").exists()


def test_a_codec_outcome_reads_the_same_in_every_command(tmp_path):
    """The codec describes its own outcome (Codec.describe): the short form in every table (bench, compress of
    many clips, info of an archive), the detailed form where one clip is shown (compress, info)."""
    src = tmp_path / "clips"
    src.mkdir()
    for i in range(2):
        write(synthetic_motion(chain_skeleton(3), frames=30, fps=30, seed=i), src / f"c{i}.bvh")
    fourier = ["--codec", "naive-fourier", "-p", "k=1", "-p", "window=10", "-p", "iters=25", "--max-error", "none"]
    short, detail = "3 windows, K=1", "3 windows, K per window [1, 1, 1]"
    mrc = tmp_path / "c0.mrc"
    r = run("compress", src / "c0.bvh", "-o", mrc, *fourier)
    assert r.exit_code == 0, r.output
    assert f"codec naive-fourier: {detail}" in r.stdout
    assert re.search(r"^  train window=\d+-\d+ K=", r.stderr, re.M)  # progress, in the codec's words (windows
    # are coded side by side in worker processes, so which one reports first depends on timing)
    assert f"outcome:    {detail}" in run("info", mrc).output
    assert json.loads(run("info", mrc, "--json").output)["codec"]["description"] == detail
    archive = tmp_path / "all.h5"
    r = run("compress", src, "-o", archive, *fourier)
    assert r.exit_code == 0, r.output
    assert r.stdout.count("payload bits/bone/frame), L-inf") == 2
    assert all(line.endswith(short) for line in r.stdout.splitlines()[:2])
    assert [c["outcome"] for c in json.loads(run("info", archive, "--json").output)["clips"]] == [short, short]
    out = tmp_path / "bench"
    r = run("bench", src, "-c", "naive-fourier", "-p", "k=1", "-p", "window=10", "-p", "iters=25", "--max-error",
            "none", "--decode-poses", "0", "-q", "--out", out)
    assert r.exit_code == 0, r.output
    assert [row["outcome"] for row in json.loads((out / "bench.json").read_text())["rows"]] == [short, short]


def test_readme_quick_start_runs_in_a_scratch_directory(tmp_path):
    """The README's quick start as written: a virtual environment first, then the example in a scratch directory
    (``cd "$(mktemp -d)"``), never in the repository.  The install is not repeated here (this process runs the
    installed package); the rest of the line runs in a shell, with ``mktemp`` pointed at ``tmp_path``."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parent.parent
    text = (repo / "README.md").read_text(encoding="utf-8")
    block = text.split("## Quick start", 1)[1].split("```", 2)[1].strip().splitlines()
    assert block[0] == "python3 -m venv .venv && . .venv/bin/activate"
    install, rest = block[1].split(" && ", 1)
    assert install == "pip install -e ." and rest.startswith('cd "$(mktemp -d)" && ')
    before = set(os.listdir(repo))
    line = rest.replace("motionrep ", f"{sys.executable} -m motionrep ")
    env = dict(os.environ, TMPDIR=str(tmp_path))
    subprocess.run(["sh", "-c", line], env=env, check=True, capture_output=True, cwd=repo)
    scratch = [p for p in tmp_path.iterdir() if p.is_dir()]
    assert len(scratch) == 1 and {"walk.bvh", "walk.mrc"} <= set(os.listdir(scratch[0]))
    assert set(os.listdir(repo)) == before  # nothing written into the repository
