"""Unix habits of the command line (issue 16): ``-`` for standard input and output, several inputs and glob
patterns, ``--force`` before overwriting, ``--debug`` anywhere, a light start, messages that name what differs,
reports in argument order that say how ``--max-error`` was read."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from motionrep.cli import cli
from motionrep.io import read, write
from motionrep.synthetic import humanoid_skeleton, synthetic_motion


def run(*args, input: bytes | None = None):
    return CliRunner().invoke(cli, [str(a) for a in args], input=input)


def error_line(result) -> str:
    lines = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert len(lines) == 1, result.output
    return lines[0]


@pytest.fixture
def walk(tmp_path) -> Path:
    path = tmp_path / "walk.bvh"
    write(synthetic_motion(humanoid_skeleton(), frames=40, fps=30.0), path)
    return path


@pytest.fixture
def walk_mrc(tmp_path, walk) -> Path:
    out = tmp_path / "walk.mrc"
    r = run("compress", walk, "-o", out, "--codec", "svd")
    assert r.exit_code == 0, r.output
    return out


# ---- standard input and output ---------------------------------------------------------------------------------
def test_dash_is_standard_output_not_a_directory(tmp_path, walk, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = run("convert", walk, "-")
    assert r.exit_code == 0, r.output
    assert r.stdout_bytes.startswith(b"HIERARCHY") and not (tmp_path / "-").exists()
    (tmp_path / "piped.bvh").write_bytes(r.stdout_bytes)
    assert read(tmp_path / "piped.bvh").num_frames == 40


def test_bvh_from_standard_input(tmp_path, walk):
    r = run("convert", "-", tmp_path / "from_stdin.npz", input=walk.read_bytes())
    assert r.exit_code == 0, r.output
    assert np.array_equal(read(tmp_path / "from_stdin.npz").rotations, read(walk).rotations)
    r = run("convert", "-", tmp_path / "x.npz", input=b"not a motion")
    assert r.exit_code == 2 and "standard input is not BVH text" in error_line(r)


def test_a_compressed_clip_from_standard_input(tmp_path, walk, walk_mrc):
    r = run("info", "-", "--json", input=walk_mrc.read_bytes())  # .mrc on standard input, told by its magic
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["format"] == "mrc" and json.loads(r.output)["file"] == "<stdin>"
    r = run("view", walk, "-", "-o", tmp_path / "v.html", input=walk_mrc.read_bytes())
    assert r.exit_code == 0, r.output


def test_errors_about_standard_input_name_it(tmp_path):
    r = run("info", "-", input=b"HIERARCHY\nROOT Hips\n{\n")
    assert r.exit_code == 1 and error_line(r).startswith("Error: <stdin>")


# ---- several inputs and glob patterns --------------------------------------------------------------------------
def test_globs_and_several_inputs(tmp_path, walk):
    (tmp_path / "clips").mkdir()
    for name in ("a", "b"):
        write(synthetic_motion(humanoid_skeleton(), frames=10, fps=30.0), tmp_path / "clips" / f"{name}.bvh")
    pattern = str(tmp_path / "clips" / "*.bvh")
    r = run("compress", pattern, "-o", tmp_path / "out", "--codec", "svd")
    assert r.exit_code == 0, r.output
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["a.mrc", "b.mrc"]
    r = run("info", str(tmp_path / "out" / "*.mrc"), walk, "--json")
    assert r.exit_code == 0, r.output
    assert [d["format"] for d in json.loads(r.output)] == ["mrc", "mrc", "bvh"]
    r = run("convert", str(tmp_path / "nothing" / "*.bvh"), tmp_path / "x.h5")
    assert r.exit_code == 2 and "no file matches" in error_line(r)


# ---- one overwrite policy ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("command, output", [
    (["convert", "{walk}", "{out}"], "out.npz"),
    (["compress", "{walk}", "-o", "{out}", "--codec", "svd"], "out.mrc"),
    (["decompress", "{mrc}", "-o", "{out}"], "out.bvh"),
    (["render", "{walk}", "-o", "{out}", "--count", "1", "--size", "200x160"], "out.png"),
    (["view", "{walk}", "-o", "{out}"], "out.html"),
    (["example", "{out}"], "out.bvh"),
])
def test_existing_outputs_need_force(tmp_path, walk, walk_mrc, command, output):
    target = tmp_path / output
    args = [a.format(walk=walk, mrc=walk_mrc, out=target) for a in command]
    target.write_bytes(b"precious")
    r = run(*args)
    assert r.exit_code == 1 and f"{target}: exists; use --force to overwrite it" in error_line(r)
    assert target.read_bytes() == b"precious"
    r = run(*args, "--force")
    assert r.exit_code == 0, r.output
    assert target.read_bytes() != b"precious"


def test_force_covers_the_files_of_a_directory_output(tmp_path, walk):
    out = tmp_path / "out"
    out.mkdir()
    (out / "walk.npz").write_bytes(b"precious")
    r = run("convert", walk, out, "--format", "npz")
    assert r.exit_code == 1 and "walk.npz: exists; use --force" in error_line(r)
    assert run("convert", walk, out, "--format", "npz", "--force").exit_code == 0


# ---- --debug anywhere, a light start -----------------------------------------------------------------------------
def test_debug_anywhere_on_the_line(tmp_path):
    missing = tmp_path / "missing.bvh"
    for args in (["--debug", "info", missing], ["info", missing, "--debug"], ["info", "--debug", missing]):
        r = CliRunner().invoke(cli, [str(a) for a in args])
        assert r.exit_code != 0 and r.exception is not None and not isinstance(r.exception, SystemExit), args
    r = run("info", missing)
    assert r.exit_code == 1 and isinstance(r.exception, SystemExit)


def _imported_by(args: list[str]) -> set[str]:
    code = ("import sys, runpy; sys.argv = ['motionrep'] + %r\n"
            "try:\n    runpy.run_module('motionrep', run_name='__main__')\nexcept SystemExit:\n    pass\n"
            "print('\\nMODULES', ' '.join(sorted(sys.modules)))" % (args,))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    return set(out.rsplit("MODULES", 1)[1].split())


def _tops(modules: set[str]) -> set[str]:
    return {m.split(".")[0] for m in modules}


def test_help_and_info_start_light(walk):
    """`motionrep --help` imports no numpy; `motionrep info walk.bvh` none of scipy.spatial, h5py, torch,
    matplotlib or pygltflib (numba comes with the compiled BVH reader).  The start-up budget is 0.3 s
    (benchmarks/startup.py)."""
    heavy = {"scipy", "h5py", "torch", "matplotlib", "pygltflib", "numba", "constriction", "pluggy", "numpy"}
    assert not _tops(_imported_by(["--help"])) & heavy
    info = _imported_by(["info", str(walk)])
    assert not _tops(info) & {"h5py", "torch", "matplotlib", "pygltflib", "constriction", "pluggy"}
    assert "scipy.spatial" not in info


# ---- messages -------------------------------------------------------------------------------------------------
def test_evaluate_names_the_first_differing_joint_and_keeps_argument_order(tmp_path, walk):
    text = walk.read_text().replace("LeftUpLeg", "leftupleg")
    other = tmp_path / "lower.bvh"
    other.write_text(text)
    r = run("evaluate", walk, other)
    line = error_line(r)
    assert r.exit_code == 1
    assert "'LeftUpLeg' in the reference but 'leftupleg' in the candidate (the names differ only in case)" in line
    assert f"{walk} vs {other}" in line
    r = run("evaluate", walk, walk)
    assert r.output.startswith(f"{walk} vs {walk}:")


def test_render_and_view_say_how_max_error_was_read(tmp_path, walk, walk_mrc):
    r = run("view", walk, walk_mrc, "-o", tmp_path / "v.html", "--max-error", "2")
    assert r.exit_code == 0, r.output
    page = (tmp_path / "v.html").read_text()
    assert "2 file units = 1.32% of height (read as a distance in file units; write 2% for a percentage)" in page
    r = run("render", walk, walk_mrc, "-o", tmp_path / "r.png", "--count", "1", "--size", "240x200")
    assert r.exit_code == 0, r.output
    assert "bound: 2% of height 152 = 3.04 file units, as" in r.stderr


# ---- set-up: one install ---------------------------------------------------------------------------------------
def test_the_core_install_draws_and_reads_gltf():
    from importlib.metadata import requires

    core = [r for r in requires("motionrep") if "extra ==" not in r]
    for needed in ("matplotlib", "pygltflib"):  # render and bench --plot; glTF files
        assert any(r.startswith(needed) for r in core), needed
    assert not any(r.startswith("torch") for r in core)
