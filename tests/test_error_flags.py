"""Library errors name the Python parameter (``max_error``, ``fps``, ``clip=``); the command line shows the flag
(``--max-error``, ``--fps``, ``--clip``), rewritten in its one error funnel (``motionrep.cli._flags.flagged``)."""

from __future__ import annotations

import pickle

import pytest

from motionrep.model.bound import parse_max_error
from motionrep.cli._flags import FLAGS, flagged
from motionrep.errors import FormatError, MotionrepError, ParameterError, TimeLimitError, ValidationError, naming
from motionrep.io import read, write, write_database
from motionrep.model.ops import resample
from motionrep.pipeline.pairing import MatchOptions
from motionrep.model.synthetic import chain_skeleton, synthetic_motion
from helpers import run_cli_caught


run = run_cli_caught  # helpers.run_cli_caught: the one CLI runner, exceptions kept


@pytest.fixture
def walk(tmp_path):
    path = tmp_path / "walk.bvh"
    write(synthetic_motion(chain_skeleton(3), frames=20, fps=30, seed=1), path)
    return path


def test_a_python_caller_reads_parameter_names_not_flags(walk):
    with pytest.raises(ParameterError) as bound:
        parse_max_error("0")
    with pytest.raises(ParameterError) as rate:
        resample(read(walk), fps=0)
    with pytest.raises(FormatError) as clip:
        read(walk, clip="x")
    assert str(bound.value).startswith("max_error must be > 0")
    assert str(rate.value).startswith("fps must be > 0")
    assert "one clip; clip= applies to HDF5" in str(clip.value)
    for exc in (bound.value, rate.value, clip.value):
        assert "--" not in str(exc)
        assert exc.parameters and all(p in str(exc) and p in FLAGS for p in exc.parameters)
    with pytest.raises(ValidationError) as match:
        MatchOptions(strip_prefix=("a:",))
    assert str(match.value) == "strip_prefix needs match='names'"
    assert flagged(match.value) == "--strip-prefix needs --match names"
    assert flagged(bound.value).startswith("--max-error must be > 0")
    assert "one clip; --clip applies to HDF5" in flagged(clip.value)


def test_the_command_line_shows_the_flag(walk, tmp_path):
    r = run("compress", walk, "-o", tmp_path / "walk.mrc", "--max-error", "0")
    assert r.exit_code == 1 and "--max-error must be > 0" in r.output and "max_error" not in r.output
    clips = {name: synthetic_motion(chain_skeleton(3), frames=20, fps=30, seed=seed) for seed, name in enumerate("xy")}
    write_database(clips.items(), tmp_path / "db.h5")
    with pytest.raises(FormatError, match="the database holds 2 clips; choose one with clip=NAME: x, y"):
        read(tmp_path / "db.h5")
    r = run("render", tmp_path / "db.h5", "-o", tmp_path / "db.gif")
    assert r.exit_code == 1 and "db.h5: the database holds 2 clips; choose one with --clip NAME: x, y" in r.output
    assert "clip=" not in r.output and not (tmp_path / "db.gif").exists()


def test_parameter_mentions_survive_pickling_and_unknown_errors_are_unchanged():
    exc = pickle.loads(pickle.dumps(naming(FormatError("choose one with clip=NAME: a, b", "db.h5"), "clip=NAME")))
    assert exc.parameters == ("clip=NAME",) and flagged(exc) == "db.h5: choose one with --clip NAME: a, b"
    limit = pickle.loads(pickle.dumps(naming(TimeLimitError("time limit of 1 s (timeout=)", 1.0), "timeout=")))
    assert limit.seconds == 1.0 and flagged(limit) == "time limit of 1 s (--timeout)"
    plain = MotionrepError("fps= is untouched without a mention")
    assert flagged(plain) == str(plain)


def test_no_library_string_names_a_flag():
    """Outside ``motionrep/cli/`` (and the plugins' own tests), no string but a docstring spells a command-line
    flag: hints and notes name the parameter, and the command line maps it."""
    import ast
    import re
    from pathlib import Path

    repo = Path(__file__).resolve().parent.parent
    flag = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")
    files = [p for p in (repo / "motionrep").rglob("*.py") if "cli" not in p.relative_to(repo).parts] + \
        [p for p in (repo / "plugins").rglob("*.py") if not {"tests", "examples"} & set(p.parts)]
    found = []
    for path in sorted(files):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        docs = {id(node.body[0].value) for node in ast.walk(tree)
                if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
                and node.body and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant)}
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs:
                found += [f"{path.relative_to(repo)}:{node.lineno}: {m}" for m in flag.findall(node.value)]
    assert not found, found


def test_hints_name_the_codec_parameter_and_the_command_line_the_flag(tmp_path):
    from motionrep.errors import UncodableClipError
    from motionrep.pipeline.compress import compress_motion

    one = synthetic_motion(chain_skeleton(3), frames=1, fps=30, seed=1)
    with pytest.raises(UncodableClipError) as info:
        compress_motion(one, "adaptive-fourier")
    assert "(codec=transform)" in str(info.value) and "--" not in str(info.value)
    assert "(--codec transform)" in flagged(info.value)
    write(one, tmp_path / "one.bvh")
    r = run("compress", tmp_path / "one.bvh", "-o", tmp_path / "one.mrc", "--codec", "naive-fourier")
    assert r.exit_code == 1 and "(--codec transform)" in r.output and "codec=" not in r.output


def test_a_fourier_hint_names_params_and_codec_and_the_flags_on_the_command_line(walk, tmp_path):
    from motionrep.errors import BoundNotMetError
    from motionrep.pipeline.compress import compress_motion

    with pytest.raises(BoundNotMetError) as info:
        compress_motion(read(walk), "adaptive-fourier", max_error="0.01%",
                        params={"max_k": 0, "iters": 25, "window": 0})
    assert "or params window=125), or use codec=svd" in str(info.value)
    assert "or -p window=125), or use --codec svd" in flagged(info.value)
    r = run("compress", walk, "-o", tmp_path / "w.mrc", "--codec", "adaptive-fourier", "--max-error", "0.01%",
            "-p", "max_k=0", "-p", "iters=25", "-p", "window=0")
    assert r.exit_code == 1 and "or -p window=125), or use --codec svd" in r.output, r.output


def test_notes_name_parameters_and_the_command_line_the_flags(tmp_path):
    import numpy as np

    from motionrep.errors import Note
    from motionrep.io import gltf_scale
    from motionrep.present.render import frames as render_frames

    _, _, notes = render_frames.animation_frames(np.arange(300), False, 30.0, None, 10, ".gif")
    (note,) = notes
    assert isinstance(note, Note) and note.endswith("(max_frames=10)") and note.parameters == ("max_frames=",)
    assert flagged(note).endswith("(--max-frames 10)")
    _, _, notes = render_frames.animation_frames(np.arange(0, 40, 10), True, 30.0, None, 150, ".gif", worst_frame=5)
    assert flagged(notes[0]) == "the worst frame, 5, is not among the frames that --frames selects"
    assert pickle.loads(pickle.dumps(note)).parameters == note.parameters  # notes cross process boundaries
    motion = synthetic_motion(chain_skeleton(3), frames=5, fps=30, seed=1)
    _, unit = gltf_scale(motion)
    assert unit.endswith("units= or scale= to choose") and flagged(unit).endswith("--units or --scale to choose")
    write(motion, tmp_path / "c.bvh")
    r = run("convert", tmp_path / "c.bvh", tmp_path / "c.glb")
    assert r.exit_code == 0 and "--units or --scale to choose" in r.output and "units=" not in r.output


def test_bench_rows_name_parameters_and_the_command_line_the_flags(walk, tmp_path):
    from motionrep.present.bench import COLUMNS, bench_tasks, read_csv, run_bench
    from motionrep.pipeline.sources import collect_clips

    tasks = bench_tasks(collect_clips([walk]), ["naive-fourier"], ["root-quat-axis-angle"], ["0.01%"],
                        {"max_k": ["0"], "iters": ["25"]}, seed=0)
    (row,) = run_bench(tasks, jobs=1)
    assert row.status == "failed" and "use codec=svd" in row.message and "codec=" in row.mentions
    assert "mentions" not in COLUMNS and "mentions" not in row.as_dict()
    r = run("bench", walk, "-c", "naive-fourier", "--max-error", "0.01%", "-p", "max_k=0", "-p", "iters=25",
            "--out", tmp_path / "out", "-q")
    assert r.exit_code == 0, r.output
    (shown,) = read_csv(tmp_path / "out" / "bench.csv")
    assert "use --codec svd" in shown.message and "codec=" not in shown.message


def test_the_facts_of_a_compressed_clip_name_the_bound_parameter_and_info_the_flag(walk, tmp_path):
    from motionrep.pipeline.compress import compress_file
    from motionrep.present.info import compressed_facts, info_dict

    mrc = tmp_path / "w.mrc"
    compress_file(walk, mrc, "svd", max_error="2%")
    facts = dict(compressed_facts(info_dict(mrc), verbose=True))
    assert "bound max_error=2% of height" in facts["L-inf"] and facts["L-inf"].parameters == ("max_error=",)
    r = run("info", mrc)
    assert r.exit_code == 0 and "bound --max-error 2% of height" in r.output and "max_error" not in r.output
