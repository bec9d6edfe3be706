"""Unix habits of the command line (issue 16): ``-`` for standard input and output, several inputs and glob
patterns, ``-f`` / ``--force`` before overwriting, ``--debug`` anywhere, a light start, messages that name what
differs, reports in argument order that say how ``--max-error`` was read."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from motionrep.cli import cli
from motionrep.io import read, write
from motionrep.model.synthetic import humanoid_skeleton, synthetic_motion
from helpers import run_cli_caught


def run(*args, input: bytes | None = None):
    return run_cli_caught(*args, input=input)


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
    assert r.exit_code == 1 and error_line(r).startswith("Error: <stdin>: is not BVH text, an NPZ file")


def test_a_compressed_clip_from_standard_input(tmp_path, walk, walk_mrc):
    r = run("info", "-", "--json", input=walk_mrc.read_bytes())  # .mrc on standard input, told by its magic
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["format"] == "mrc" and json.loads(r.output)["file"] == "<stdin>"
    r = run("view", walk, "-", "-o", tmp_path / "v.html", input=walk_mrc.read_bytes())
    assert r.exit_code == 0, r.output


def test_errors_about_standard_input_name_it(tmp_path):
    r = run("info", "-", input=b"HIERARCHY\nROOT Hips\n{\n")
    assert r.exit_code == 1 and error_line(r).startswith("Error: <stdin>")


def test_compress_from_standard_input_to_standard_output(tmp_path, walk, walk_mrc):
    r = run("compress", "-", "-o", "-", "--codec", "svd", input=walk.read_bytes())
    assert r.exit_code == 0, r.output
    assert r.stdout_bytes == walk_mrc.read_bytes()  # the same bytes as from the file to a file
    assert "<stdin>: 40 frames" in r.stderr and "wrote <stdout>: " in r.stderr  # the report on stderr
    r = run("compress", "-", "-o", tmp_path / "piped.mrc", "--codec", "svd", input=walk.read_bytes())
    assert r.exit_code == 0 and (tmp_path / "piped.mrc").read_bytes() == walk_mrc.read_bytes()
    assert r.stdout.startswith("<stdin>: 40 frames")


def test_compress_to_standard_output_writes_nothing_on_error(walk):
    broken = walk.read_bytes()[:300]
    r = run("compress", "-", "-o", "-", "--codec", "svd", input=broken)
    assert r.exit_code == 1 and error_line(r).startswith("Error: <stdin>:") and r.stdout_bytes == b""
    r = run("compress", walk, "-o", "-", "--codec", "svd", "-p", "rank=1", "--max-error", "0.01%")
    assert r.exit_code == 1 and "above the bound" in error_line(r) and r.stdout_bytes == b""
    r = run("compress", walk, "-o", "-", "--json")
    assert r.exit_code == 2 and "--json" in error_line(r) and r.stdout_bytes == b""


def test_decompress_from_standard_input_to_standard_output(tmp_path, walk_mrc):
    assert run("decompress", walk_mrc, "-o", tmp_path / "file.bvh").exit_code == 0
    r = run("decompress", "-", "-o", "-", input=walk_mrc.read_bytes())
    assert r.exit_code == 0, r.output
    assert r.stdout_bytes == (tmp_path / "file.bvh").read_bytes() and "wrote <stdout>: 40 frames" in r.stderr
    r = run("decompress", walk_mrc, "-o", "-", "--format", "npz")
    assert r.exit_code == 0, r.output
    (tmp_path / "piped.npz").write_bytes(r.stdout_bytes)
    assert run("decompress", walk_mrc, "-o", tmp_path / "file.npz").exit_code == 0
    assert np.array_equal(read(tmp_path / "piped.npz").rotations, read(tmp_path / "file.npz").rotations)


def test_decompress_standard_input_errors(tmp_path, walk, walk_mrc):
    r = run("decompress", "-", "-o", "-", input=walk_mrc.read_bytes()[:-20])  # truncated: nothing written
    assert r.exit_code == 1 and error_line(r).startswith("Error: <stdin>: ") and r.stdout_bytes == b""
    r = run("decompress", "-", "-o", tmp_path / "x.bvh", input=walk.read_bytes())
    assert r.exit_code == 1 and "<stdin>: is BVH text; this command reads a .mrc file or an HDF5 file" \
        in error_line(r)
    assert not (tmp_path / "x.bvh").exists()
    r = run("decompress", walk_mrc, "-o", tmp_path / "x.bvh", "--format", "npz")
    assert r.exit_code == 2 and "--format applies only" in error_line(r)


def test_decompress_format_names_the_files_of_a_directory(tmp_path, walk):
    (tmp_path / "clips").mkdir()
    write(read(walk), tmp_path / "clips" / "a.bvh")
    write(read(walk), tmp_path / "clips" / "b.bvh")
    assert run("compress", tmp_path / "clips", "-o", tmp_path / "mrc", "--codec", "svd").exit_code == 0
    r = run("decompress", tmp_path / "mrc", "-o", tmp_path / "out", "--format", "npz")
    assert r.exit_code == 0, r.output
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["a.npz", "b.npz"]
    r = run("decompress", tmp_path / "mrc", "-o", "-")
    assert r.exit_code == 2 and "<stdout> holds one clip but the inputs hold 2" in error_line(r)


def test_evaluate_one_side_from_standard_input(walk, walk_mrc):
    expected = json.loads(run("evaluate", walk, walk_mrc, "--json").output)
    r = run("evaluate", walk, "-", "--json", input=walk_mrc.read_bytes())
    assert r.exit_code == 0, r.output
    got = json.loads(r.output)
    assert got["candidate"] == "<stdin>" and got["reference"] == str(walk)
    assert got["max_error"] == expected["max_error"] and got["frame"] == expected["frame"]
    r = run("evaluate", "-", walk_mrc, input=walk.read_bytes())
    assert r.exit_code == 0 and r.output.startswith(f"<stdin> vs {walk_mrc}: 40 frames")
    r = run("evaluate", "-", "-", input=walk.read_bytes())
    assert r.exit_code == 2 and "can be read only once" in error_line(r)
    r = run("evaluate", walk, "-", input=b"HIERARCHY\nROOT Hips\n{\n")
    assert r.exit_code == 1 and error_line(r).startswith("Error: <stdin>:")


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


def test_f_is_force_in_every_command_that_writes(tmp_path, walk):
    """One shared definition: every command with --force takes -f too, and -f means nothing else anywhere."""
    with_force = set()
    for name, command in cli.commands.items():
        for param in command.params:
            if "-f" in param.opts or "--force" in param.opts:
                assert set(param.opts) == {"-f", "--force"}, (name, param.opts)
                with_force.add(name)
    assert {"convert", "compress", "decompress", "render", "view", "merge", "example", "bench"} <= with_force
    target = tmp_path / "out.npz"
    target.write_bytes(b"precious")
    assert run("convert", walk, target).exit_code == 1
    r = run("convert", walk, target, "-f")
    assert r.exit_code == 0, r.output
    assert read(target).num_frames == 40


# ---- --debug anywhere, a light start -----------------------------------------------------------------------------
def test_debug_anywhere_on_the_line(tmp_path):
    missing = tmp_path / "missing.bvh"
    for args in (["--debug", "info", missing], ["info", missing, "--debug"], ["info", "--debug", missing]):
        r = run_cli_caught(*args)
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
    """`motionrep --help` imports no numpy; `motionrep info walk.bvh` none of numba (the BVH reader is compiled C),
    scipy, h5py, torch, matplotlib or pygltflib.  The start-up budget is 0.3 s (benchmarks/startup.py)."""
    heavy = {"scipy", "h5py", "torch", "matplotlib", "pygltflib", "numba", "constriction", "pluggy", "numpy"}
    assert not _tops(_imported_by(["--help"])) & heavy
    info = _imported_by(["info", str(walk)])
    assert not _tops(info) & (heavy - {"numpy"})


def test_evaluating_and_converting_bvh_import_no_numba(tmp_path, walk):
    """The BVH reader and writer and FK are the compiled core (C, built at install time): `evaluate` of two BVH
    files and `convert` to BVH and to NPZ import neither numba nor llvmlite (`evaluate` imported numba for FK)."""
    for args in (["evaluate", str(walk), str(walk)], ["convert", str(walk), str(tmp_path / "w.bvh")],
                 ["convert", str(walk), str(tmp_path / "w.npz")]):
        assert not _tops(_imported_by(args)) & {"numba", "llvmlite", "torch"}, args
    assert (tmp_path / "w.bvh").exists() and (tmp_path / "w.npz").exists()


def test_compressing_and_decompressing_bvh_import_no_scipy(tmp_path, walk):
    """The quick start's `compress` (transform of root-quat-axis-angle features) and `decompress` to BVH convert
    rotations in the compiled core (quaternions to rotation vectors and to Euler angles, scipy's operations in C):
    neither imports scipy, whose `scipy.spatial` alone costs about 0.15 s of every process."""
    mrc = tmp_path / "w.mrc"
    assert not _tops(_imported_by(["compress", str(walk), "-o", str(mrc)])) & {"scipy", "numba", "torch"}
    assert not _tops(_imported_by(["decompress", str(mrc), "-o", str(tmp_path / "w.bvh")])) & {"scipy", "numba"}
    assert mrc.exists() and (tmp_path / "w.bvh").exists()


def test_info_on_hdf5_leaves_h5py_to_the_reader_process(tmp_path, walk):
    """Reading HDF5 runs h5py in a worker process (motionrep.io._h5read); the command's own process does not
    import it (nor numba or scipy)."""
    h5 = tmp_path / "walk.h5"
    write(read(walk), h5)
    info = _imported_by(["info", str(h5)])
    assert not _tops(info) & {"h5py", "numba", "scipy", "torch", "pluggy"}


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


def test_compress_says_how_max_error_was_read(tmp_path, walk):
    out = tmp_path / "w.mrc"
    r = run("compress", walk, "-o", out, "--codec", "svd")
    assert r.exit_code == 0, r.output
    assert "bound --max-error 2% of height 152 = 3.04 file units" in r.output
    phrase = "1.5 file units = 0.987% of height (read as a distance in file units; write 1.5% for a percentage)"
    r = run("compress", walk, "-o", out, "--codec", "svd", "--max-error", "1.5", "--json", "-f")
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["max_error_read_as"] == phrase
    assert f"bound --max-error {phrase}" in run("info", out).output  # info says it in the same words
    r = run("compress", walk, "-o", out, "--codec", "svd", "-p", "rank=6", "--max-error", "none", "--json", "-f")
    assert r.exit_code == 0 and json.loads(r.output)["max_error_read_as"] is None
    (tmp_path / "clips").mkdir()
    write(read(walk), tmp_path / "clips" / "a.bvh")
    r = run("compress", tmp_path / "clips", "-o", tmp_path / "arch.h5", "--codec", "svd", "--json")
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["clips"]["a"]["max_error_read_as"] == "2% of height 152 = 3.04 file units"
    r = run("compress", tmp_path / "clips", "-o", tmp_path / "arch.h5", "--codec", "svd", "-f")
    assert r.exit_code == 0, r.output
    line = next(x for x in r.stdout.splitlines() if x.startswith("a: "))  # clip a's line
    assert "%), bound --max-error 2% of height 152 = 3.04 file units, rank=" in line


# ---- set-up: one install ---------------------------------------------------------------------------------------
def test_the_core_install_draws_and_reads_gltf():
    from importlib.metadata import requires

    core = [r for r in requires("motionrep") if "extra ==" not in r]
    for needed in ("matplotlib", "pygltflib"):  # render and bench --plot; glTF files
        assert any(r.startswith(needed) for r in core), needed
    assert not any(r.startswith("torch") for r in core)
