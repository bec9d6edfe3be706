"""`motionrep bench` as issue 26 wants it: a default table within 120 columns in the size vocabulary, `--wide`
for every column, the plot on payload bits per bone per frame with ACL's anchors where the project has them."""

from __future__ import annotations

import pytest

from motionrep.present.bench.anchors import acl_anchors_for, acl_strict
from motionrep.io import write
from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, synthetic_motion
from helpers import run_cli_caught


def test_acl_anchors_match_by_source_path_never_by_a_bare_name():
    assert len(acl_strict()) == 27 and all(a.payload_bits_per_bone_frame > 0 for a in acl_strict())
    found = acl_anchors_for(["/data/shared/cmu/bvh11/131_01.bvh"], [2.0])
    assert [(a.clip, a.bound_percent, a.payload_bits_per_bone_frame) for a in found] == \
        [("cmu/bvh11/131_01", 2.0, 3.64)]
    assert len(acl_anchors_for(["/data/shared/cmu/bvh11/131_01.bvh"])) == 3  # every bound
    assert acl_anchors_for(["/tmp/walk.bvh", "/x/131_01.bvh"]) == []  # the demo walk is not CMU's walk


def test_default_table_fits_120_columns_and_wide_has_every_column(tmp_path):
    clips = tmp_path / "a_rather_long_directory_name"
    clips.mkdir()
    write(synthetic_motion(humanoid_skeleton(), frames=30, seed=1), clips / "a_clip_with_a_long_long_name.bvh")
    write(synthetic_motion(chain_skeleton(4), frames=20, seed=2), clips / "short.bvh")
    args = ["bench", str(clips), "-c", "svd", "-c", "transform", "--max-error", "1%", "--max-error", "2%",
            "--decode-poses", "0", "-q"]
    r = run_cli_caught(*args)
    assert r.exit_code == 0, r.output
    lines = [line for line in r.stdout.splitlines() if not line.startswith("totals: ")]
    assert max(len(line) for line in lines) <= 120
    assert "payload" in lines[0] and "file" in lines[0] and lines[1].count("bits/bone/frame") == 2
    assert "paper ratio" not in r.stdout
    wide = run_cli_caught(*args + ["--wide"])
    assert wide.exit_code == 0 and "paper ratio" in wide.stdout and "decode poses/s" in wide.stdout
    assert max(len(line) for line in wide.stdout.splitlines()) > 120


def test_plot_is_drawn_on_payload_bits_with_acl_where_known(tmp_path):
    cmu = tmp_path / "cmu" / "bvh11"
    cmu.mkdir(parents=True)
    write(synthetic_motion(humanoid_skeleton(), frames=30, seed=1), cmu / "131_01.bvh")
    plot = tmp_path / "rd.png"
    r = run_cli_caught("bench", str(cmu / "131_01.bvh"), "-c", "transform", "--max-error", "2%",
                                 "--decode-poses", "0", "--plot", str(plot))
    assert r.exit_code == 0, r.output
    assert plot.read_bytes()[:4] == b"\x89PNG" and f"wrote {plot}" in r.stdout
    from motionrep.present.bench.plot import DEFAULT_X

    assert DEFAULT_X == "payload_bits_per_bone_frame"


@pytest.mark.parametrize("flag", ["--quiet"])
def test_bench_quiet_keeps_the_table_and_drops_wrote(tmp_path, flag):
    path = tmp_path / "c.bvh"
    write(synthetic_motion(chain_skeleton(3), frames=20, seed=3), path)
    r = run_cli_caught("bench", str(path), "-c", "svd", "--decode-poses", "0", "--out",
                                 str(tmp_path / "res"), flag)
    assert r.exit_code == 0 and "wrote" not in r.output and "svd" in r.stdout and r.stderr == ""


def test_bench_is_not_silent_while_a_run_takes_long(tmp_path, monkeypatch):
    """The heartbeat with its ETA on stderr while no run has finished (every 10 s; 0.05 s here, so that even a fast machine sees one)."""
    path = tmp_path / "c.bvh"
    write(synthetic_motion(chain_skeleton(4), frames=120, seed=3), path)
    monkeypatch.setenv("MOTIONREP_PROGRESS_SECONDS", "0.05")
    r = run_cli_caught("bench", str(path), "-c", "adaptive-fourier", "-p", "k=6", "-p", "iters=4000",
                                 "--max-error", "none", "--decode-poses", "0")
    assert r.exit_code == 0, r.output
    assert any(line.startswith("[0/1] working, ") and "ETA" in line for line in r.stderr.splitlines()), r.stderr
