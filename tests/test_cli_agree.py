"""Commands agree (issue 26): `info DIR`, `convert` of a .mrc, `wrote ...` / --quiet, a closed pipe, help texts
checked against the code."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from motionrep.io import write
from motionrep.model.synthetic import chain_skeleton, synthetic_motion
from helpers import run_cli_caught


run = run_cli_caught  # helpers.run_cli_caught: the one CLI runner, exceptions kept


@pytest.fixture
def clips(tmp_path) -> Path:
    d = tmp_path / "clips"
    (d / "sub").mkdir(parents=True)
    write(synthetic_motion(chain_skeleton(4), frames=30, fps=30, seed=1), d / "a.bvh")
    write(synthetic_motion(chain_skeleton(3), frames=20, fps=30, seed=2), d / "sub" / "b.bvh")
    return d


def test_info_of_a_directory_is_a_table_one_row_per_file(clips):
    assert run("compress", clips / "a.bvh", "-o", clips / "a.mrc", "--codec", "svd").exit_code == 0
    r = run("info", clips)
    assert r.exit_code == 0, r.output
    lines = r.output.splitlines()
    assert lines[0].split()[:3] == ["file", "format", "kind"] and "payload bits/bone/frame" in lines[0]
    rows = {Path(line.split()[0]).name: line.split() for line in lines[1:]}
    assert set(rows) == {"a.bvh", "a.mrc", "b.bvh"}
    assert rows["a.mrc"][1:3] == ["mrc", "compressed"] and rows["b.bvh"][4] == "20"
    d = json.loads(run("info", clips, "--json").output)
    assert sorted(Path(x["file"]).name for x in d) == ["a.bvh", "a.mrc", "b.bvh"]


def test_convert_decodes_one_mrc_as_it_decodes_an_archive(clips, tmp_path):
    from motionrep.io import read

    mrc, archive = tmp_path / "a.mrc", tmp_path / "all.h5"
    assert run("compress", clips / "a.bvh", "-o", mrc, "--codec", "svd").exit_code == 0
    assert run("compress", clips, "-o", archive, "--codec", "svd").exit_code == 0
    r = run("convert", mrc, tmp_path / "one.bvh")
    assert r.exit_code == 0, r.output
    assert run("convert", archive, tmp_path / "arch.bvh", "--clip", "a").exit_code == 0
    one, arch = read(tmp_path / "one.bvh"), read(tmp_path / "arch.bvh")
    assert one.num_frames == arch.num_frames == 30
    # both were decoded from the same bytes by the one decode path: the same channel values (text round trip)
    assert (tmp_path / "one.bvh").read_text().split("MOTION")[1] == (tmp_path / "arch.bvh").read_text().split(
        "MOTION")[1]
    r = run("convert", clips / "a.bvh", tmp_path / "x.mrc")  # writing a .mrc stays compress's job
    assert r.exit_code == 2 and "motionrep compress" in r.output


@pytest.mark.parametrize("command", ["convert", "decompress", "merge", "example", "compress", "render", "view"])
def test_every_command_that_writes_says_wrote_or_nothing_with_quiet(clips, tmp_path, command):
    mrc = tmp_path / "a.mrc"
    assert run("compress", clips / "a.bvh", "-o", mrc, "--codec", "svd").exit_code == 0
    args = {"convert": ["convert", clips / "a.bvh", tmp_path / "{}.npz"],
            "decompress": ["decompress", mrc, "-o", tmp_path / "{}.bvh"],
            "merge": ["merge", mrc, "-o", tmp_path / "{}.h5"],
            "example": ["example", tmp_path / "{}.bvh"],
            "compress": ["compress", clips / "a.bvh", "-o", tmp_path / "{}.mrc", "--codec", "svd"],
            "render": ["render", clips / "a.bvh", mrc, "-o", tmp_path / "{}.png", "--count", "2"],
            "view": ["view", clips / "a.bvh", mrc, "-o", tmp_path / "{}.html"]}[command]
    loud = run(*[str(a).format("loud") for a in args])
    assert loud.exit_code == 0 and "wrote " in loud.output and "loud" in loud.output, loud.output
    quiet = run(*[str(a).format("quiet") for a in args], "--quiet")
    assert quiet.exit_code == 0 and quiet.output == "", quiet.output
    assert list(tmp_path.glob("quiet.*"))  # written all the same


@pytest.mark.parametrize("args", [["convert", "{walk}", "-"], ["decompress", "{mrc}", "-o", "-"]])
def test_a_reader_that_stops_ends_the_command_quietly_with_exit_0(tmp_path, args):
    """``motionrep convert walk.bvh - | head -1``: exit 0 and nothing on stderr.  The clip's BVH (about 3 MB) is
    more than any pipe holds (Linux's largest is 1 MiB, ``/proc/sys/fs/pipe-max-size``), so the writer always
    meets the closed pipe; the demo walk (117 kB written) sometimes fitted in what the pipe and the reader's
    buffer took, and the test then saw a complete write."""
    import subprocess
    import sys

    walk, mrc = tmp_path / "walk.bvh", tmp_path / "walk.mrc"
    write(synthetic_motion(chain_skeleton(24), frames=4000, fps=120, seed=3), walk)
    assert walk.stat().st_size > 2 << 20
    assert run("compress", walk, "-o", mrc, "--codec", "svd", "--max-error", "5%").exit_code == 0
    cmd = [sys.executable, "-m", "motionrep", *[a.format(walk=walk, mrc=mrc) for a in args]]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout.readline().strip() == b"HIERARCHY"
    proc.stdout.close()  # as head does after its line
    err = proc.stderr.read()
    assert proc.wait(timeout=60) == 0 and err == b"", err


@pytest.mark.parametrize("codec", ["adaptive-fourier", "naive-fourier"])
def test_a_clip_a_codec_cannot_code_gets_one_line_saying_what_and_which_codec_can(tmp_path, codec):
    one = tmp_path / "one.bvh"
    write(synthetic_motion(chain_skeleton(4), frames=1, fps=30, seed=1), one)
    r = run("compress", one, "-o", tmp_path / "one.mrc", "--codec", codec)
    assert r.exit_code == 1 and not (tmp_path / "one.mrc").exists()
    line = r.output.strip()
    assert line.count("\n") == 0 and "one.bvh" in line, line
    assert f"{codec} cannot code a clip of 1 frame: it needs at least 2 frames" in line, line
    assert "transform" in line and "svd" in line and "nan" not in line, line
    # the codecs it names do code it
    assert run("compress", one, "-o", tmp_path / "t.mrc", "--codec", "transform").exit_code == 0


def test_min_frames_is_checked_before_any_work():
    from motionrep.pipeline.compress import Pipeline
    from motionrep.errors import UncodableClipError

    pipeline = Pipeline.build("adaptive-fourier", "root-quat-axis-angle", {}, "2%", 0)
    assert pipeline.codec.min_frames == 2
    with pytest.raises(UncodableClipError, match="cannot code a clip of 1 frame"):
        pipeline.compress(synthetic_motion(chain_skeleton(3), frames=1, fps=30, seed=0),
                          progress=lambda *a, **k: pytest.fail("the codec started"))


def test_min_frames_is_part_of_the_codec_contract():
    from motionrep.plugin.codec import codec_problems
    from motionrep.plugin.registry import get_codec

    codec = get_codec("svd")
    assert codec.min_frames == 1 and not codec_problems(codec)
    bad = type("Bad", (type(codec),), {"min_frames": 0})()
    assert any("min_frames" in p for p in codec_problems(bad))


def test_plugins_describe_says_how_short_a_clip_a_codec_codes():
    d = json.loads(run("plugins", "--describe", "adaptive-fourier", "--json").output)
    assert d["min_frames"] == 2
    assert "codes clips of at least 2 frames" in run("plugins", "--describe", "naive-fourier").output
    assert json.loads(run("plugins", "--describe", "transform", "--json").output)["min_frames"] == 1


def test_info_of_an_archive_lists_each_clip_with_the_payload_figure(clips, tmp_path):
    archive = tmp_path / "all.h5"
    assert run("compress", clips, "-o", archive, "--codec", "svd").exit_code == 0
    r = run("info", archive)
    assert r.exit_code == 0 and "payload bits/bone/frame" in r.output, r.output
    d = json.loads(run("info", archive, "--json").output)
    for c in d["clips"]:
        assert f"{c['payload_bits_per_bone_frame']:.3f}" in r.output
        assert c["file_bits_per_bone_frame"] > c["payload_bits_per_bone_frame"]  # the container adds bytes
