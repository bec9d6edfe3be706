"""Library errors name the Python parameter (``max_error``, ``fps``, ``clip=``); the command line shows the flag
(``--max-error``, ``--fps``, ``--clip``), rewritten in its one error funnel (``motionrep.cli._flags.flagged``)."""

from __future__ import annotations

import pickle

import pytest

from motionrep.model.bound import parse_max_error
from motionrep.cli import cli
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
