"""Commands agree (issue 26): `info DIR`, `convert` of a .mrc, `wrote ...` / --quiet, a closed pipe, help texts
checked against the code."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from motionrep.cli import cli
from motionrep.io import write
from motionrep.synthetic import chain_skeleton, synthetic_motion


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


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
