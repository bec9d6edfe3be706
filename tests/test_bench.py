"""``motionrep bench`` and ``motionrep.present.bench``: the grid, the table arithmetic, CSV/JSON/plot agreement, the CLI."""

from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path

import pytest

from motionrep.present.bench import (COLUMNS, BenchRow, BenchTask, bench_tasks, csv_text, format_table, is_sweep,
                             parse_sweep, plot_series, read_csv, run_bench, run_task, summarize, write_csv,
                             write_json)
from motionrep.pipeline.compress import compress_motion, decompress
from motionrep.errors import FormatError, ParameterError, UnknownPluginError
from motionrep.pipeline.evaluate import max_joint_error
from motionrep.io import read, write, write_database
from motionrep.model.kinematics import character_height
from motionrep.pipeline.sources import ClipRef, collect_clips
from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, synthetic_motion

from helpers import SHARED_DATA, one_line_error, requires_shared, run_cli


run = run_cli  # helpers.run_cli: the one CLI runner of the tests


def _one_line_error(result, code: int, *needles: str) -> None:
    one_line_error(result, *needles, code=code, in_line=False)


@pytest.fixture
def short_chain():
    return synthetic_motion(chain_skeleton(3), frames=30, fps=30, seed=5)


@pytest.fixture
def clip_dir(tmp_path) -> Path:
    d = tmp_path / "clips"
    (d / "sub").mkdir(parents=True)
    write(synthetic_motion(humanoid_skeleton(), frames=40, fps=30, seed=1), d / "walk.bvh")
    write(synthetic_motion(chain_skeleton(4), frames=36, fps=30, seed=2), d / "sub" / "arm.bvh")
    write(synthetic_motion(chain_skeleton(3), frames=32, fps=25, seed=3), d / "sub" / "short.npz")
    (d / "notes.txt").write_text("not a clip")
    return d


@pytest.fixture
def database(tmp_path) -> Path:
    path = tmp_path / "db.h5"
    write_database([("one", synthetic_motion(humanoid_skeleton(), frames=40, fps=30, seed=7)),
                    ("two", synthetic_motion(humanoid_skeleton(), frames=50, fps=30, seed=8))], path)
    return path


# ---- sweeps ----------------------------------------------------------------------------------------------------
def test_parse_sweep_ranges_lists_and_single_values():
    assert parse_sweep(["k=1..4"]) == {"k": ["1", "2", "3", "4"]}
    assert parse_sweep(["rank=1,2,4", "dtype=float16"]) == {"rank": ["1", "2", "4"], "dtype": ["float16"]}
    assert parse_sweep(["k=1..3,8,2..4"]) == {"k": ["1", "2", "3", "8", "4"]}  # duplicates dropped, order kept
    assert parse_sweep([" tol = 0.01,0.001 "]) == {"tol": ["0.01", "0.001"]}
    assert parse_sweep(["k=-1..1"]) == {"k": ["-1", "0", "1"]}
    assert parse_sweep([]) == {}
    assert is_sweep("1..12") and is_sweep("1,2") and not is_sweep("4") and not is_sweep("float16")


@pytest.mark.parametrize("bad, needle", [
    ("k", "KEY=VALUE"), ("=3", "KEY=VALUE"), ("k=3..1", "empty range"), ("k=a..b", "two integers"),
    ("k=1.5..3", "two integers"), ("k=1,,2", "empty item"), ("k=", "empty item"), ("k=0..20000", "10000"),
])
def test_parse_sweep_rejects(bad, needle):
    with pytest.raises(ParameterError, match=re.escape(needle)):
        parse_sweep([bad])


def test_parse_sweep_rejects_a_key_given_twice():
    with pytest.raises(ParameterError, match="given twice"):
        parse_sweep(["k=1", "k=2"])


def test_grid_applies_each_parameter_to_the_codecs_that_have_it(tmp_path):
    clips = [ClipRef("a", str(tmp_path / "a.bvh")), ClipRef("b", str(tmp_path / "b.bvh"))]
    tasks = bench_tasks(clips, ["svd", "adaptive-fourier"], ["root-quat-axis-angle"], [None, "2%"],
                        parse_sweep(["rank=1..3", "k=0,2", "dtype=float32,float16"]))
    # per clip: svd 3 ranks x 2 dtypes, fourier 2 k x 2 dtypes; times 2 bounds
    assert len(tasks) == 2 * (3 * 2 + 2 * 2) * 2
    assert [t.index for t in tasks] == list(range(len(tasks)))
    svd = [t for t in tasks if t.codec == "svd" and t.clip.name == "a" and t.max_error is None]
    assert [dict(t.params) for t in svd] == [{"rank": r, "dtype": d} for r in "123" for d in ("float32", "float16")]
    assert all("rank" not in dict(t.params) for t in tasks if t.codec == "adaptive-fourier")
    assert tasks[0].clip.name == "a" and tasks[-1].clip.name == "b"


def test_grid_validates_before_any_work(tmp_path):
    clips = [ClipRef("a", str(tmp_path / "missing.bvh"))]  # never read: validation comes first
    with pytest.raises(ParameterError, match="'nope' is not a parameter"):
        bench_tasks(clips, ["svd"], ["root-quat-axis-angle"], ["2%"], {"nope": ["1"]})
    with pytest.raises(ParameterError, match="rank"):
        bench_tasks(clips, ["svd"], ["root-quat-axis-angle"], ["2%"], {"rank": ["-1"]})
    with pytest.raises(ParameterError, match="invalid max_error "):
        bench_tasks(clips, ["svd"], ["root-quat-axis-angle"], ["two percent"])
    with pytest.raises(UnknownPluginError):
        bench_tasks(clips, ["zip"], ["root-quat-axis-angle"], ["2%"])
    with pytest.raises(UnknownPluginError):
        bench_tasks(clips, ["svd"], ["quaternions"], ["2%"])


# ---- one run: the table's arithmetic -----------------------------------------------------------------------------
def test_row_arithmetic_against_hand_computed_values(tmp_path, short_chain):
    path = tmp_path / "chain.bvh"
    write(short_chain, path)
    motion = read(path)
    F, J, r = 30, 3, 2
    D = 3 + 4 + 3 * (J - 1)  # root translation, root quaternion, axis-angle of the two other joints
    channels = 6 + 3 * (J - 1)
    clip = collect_clips([path])[0]
    row = run_task(BenchTask(0, clip, "svd", "root-quat-axis-angle", None, (("rank", str(r)),), seed=0,
                             decode_poses=500), motion)
    assert row.status == "ok" and row.outcome == f"rank={r}" and row.params == f"rank={r}"
    assert (row.frames, row.joints, row.feature_width) == (F, J, D)
    stored = D + F * r + r * D  # mean, coefficients, basis
    assert row.parameters == stored
    assert row.paper_ratio == pytest.approx(F * D / stored, rel=1e-12)
    assert row.bits_per_joint_frame == pytest.approx(8 * row.bytes / (F * J), rel=1e-12)
    assert row.bytes_ratio == pytest.approx(F * channels * 4 / row.bytes, rel=1e-12)
    assert row.file_ratio == pytest.approx(path.stat().st_size / row.bytes, rel=1e-12)
    # the error is the shared evaluator's, measured on what the bytes decode to
    again = compress_motion(motion, "svd", max_error=None, params={"rank": r}, seed=0)
    assert len(again.data) == row.bytes
    report = max_joint_error(motion, decompress(again.data))
    assert row.error == pytest.approx(report.max_error, rel=1e-12)
    assert row.error_percent == pytest.approx(100 * report.max_error / character_height(motion.skeleton), rel=1e-12)
    assert row.height == pytest.approx(character_height(motion.skeleton))
    assert row.bound is None and row.max_error is None
    assert row.decode_poses == 500 and row.decode_poses_per_second > 0 and row.decode_features_per_second > 0
    assert 0 < row.decode_pose_seconds < 1 and row.encode_seconds > 0


def test_bound_not_met_is_a_failed_row_with_the_best_error(short_chain, tmp_path):
    path = tmp_path / "chain.bvh"
    write(short_chain, path)
    clip = collect_clips([path])[0]
    row = run_task(BenchTask(0, clip, "svd", "root-quat-axis-angle", "0.0001%", (("rank", "1"),)))
    height = character_height(read(path).skeleton)
    assert row.status == "failed"
    assert row.bound == pytest.approx(1e-6 * height)
    assert row.error > row.bound and row.error_percent == pytest.approx(100 * row.error / height)
    assert row.outcome == f"failed: best L-inf {row.error:.4g} ({row.error_percent:.2f}%)"
    assert row.paper_ratio is None and row.bytes is None and row.decode_poses_per_second is None
    assert 0 < row.encode_seconds < 60
    assert "did not meet" in row.message or "bound" in row.message


def test_an_invalid_setting_for_a_clip_is_an_error_row(short_chain, tmp_path):
    path = tmp_path / "chain.bvh"
    write(short_chain, path)
    clip = collect_clips([path])[0]
    row = run_task(BenchTask(0, clip, "svd", "root-quat-axis-angle", None, (("rank", "500"),)))
    assert row.status == "error" and "exceeds" in row.message and row.error is None


def _row(**kw) -> BenchRow:
    base = dict(clip="c", source="c.bvh", frames=10, joints=3, fps=30.0, height=10.0, units=None, codec="svd",
                representation="root-quat-axis-angle", max_error="2%", bound=0.2, params="", seed=0, status="ok",
                outcome="rank=1")
    base.update(kw)
    return BenchRow(**base)


def test_medians_count_only_the_runs_that_succeeded():
    rows = [
        _row(clip="a", error_percent=1.0, paper_ratio=4.0, bytes_ratio=2.0, bits_per_joint_frame=10.0,
             encode_seconds=1.0, decode_poses_per_second=100.0, bits_per_bone_frame=2.0),
        _row(clip="b", error_percent=1.5, paper_ratio=9.0, bytes_ratio=3.0, bits_per_joint_frame=30.0,
             encode_seconds=5.0, decode_poses_per_second=300.0, bits_per_bone_frame=3.0),
        _row(clip="c", error_percent=2.0, paper_ratio=6.0, bytes_ratio=7.0, bits_per_joint_frame=20.0,
             encode_seconds=3.0, decode_poses_per_second=200.0, bits_per_bone_frame=1.0),
        _row(clip="d", status="failed", outcome="failed: best L-inf 9", error_percent=90.0),
        _row(clip="e", status="error", outcome="error: ParameterError"),
        _row(clip="a", max_error="1%", status="failed", outcome="failed: best L-inf 3", error_percent=30.0),
        _row(clip="a", codec="adaptive-fourier", error_percent=0.5, paper_ratio=12.0, bytes_ratio=5.0,
             bits_per_joint_frame=4.0, encode_seconds=10.0, decode_poses_per_second=1e5),
        _row(clip="b", codec="adaptive-fourier", error_percent=1.5, paper_ratio=8.0, bytes_ratio=4.0,
             bits_per_joint_frame=6.0, encode_seconds=20.0, decode_poses_per_second=3e5),
    ]
    s = {(x.codec, x.max_error): x for x in summarize(rows)}
    assert list(s) == [("svd", "2%"), ("svd", "1%"), ("adaptive-fourier", "2%")]
    svd = s["svd", "2%"]
    assert (svd.runs, svd.ok, svd.failed, svd.errors) == (5, 3, 1, 1)
    assert (svd.median_error_percent, svd.median_paper_ratio, svd.median_bytes_ratio) == (1.5, 6.0, 3.0)
    assert (svd.median_bits_per_joint_frame, svd.median_encode_seconds, svd.median_decode_poses_per_second) == \
        (20.0, 3.0, 200.0)
    none = s["svd", "1%"]
    assert (none.runs, none.ok, none.failed) == (1, 0, 1) and none.median_paper_ratio is None
    af = s["adaptive-fourier", "2%"]
    assert af.median_paper_ratio == 10.0 and af.median_error_percent == 1.0 and af.median_encode_seconds == 15.0
    table = format_table(rows)
    assert "failed: best L-inf 9" in table and "error: ParameterError" in table
    medians = table.split("Medians")[1]
    assert svd.median_bits_per_bone_frame == 2.0 and af.median_bits_per_bone_frame is None
    assert re.search(r"svd\s+2%\s+3/5\s+2\s+1\.500\s+6\.00\s+3\.00\s+20\.000\s+2\.000\s+-\s+-\s+-\s+3\.00\s+200$",
                     medians, re.M), medians
    assert re.search(r"adaptive-fourier\s+2%\s+2/2\s+0\s+1\.000\s+10\.00\s+4\.50\s+5\.000\s+-\s+-\s+-\s+-\s+15\.00\s+"
                     r"200,000$", medians, re.M), medians
    assert re.search(r"svd\s+1%\s+0/1\s+1\s+-\s+-", medians), medians


# ---- CSV, JSON, table and plot agree ----------------------------------------------------------------------------
def _table_rows(markdown: str) -> list[list[str]]:
    lines = [ln for ln in markdown.split("Medians")[0].splitlines() if ln.startswith("|")]
    return [[c.strip() for c in re.split(r"(?<!\\)\|", ln)[1:-1]] for ln in lines[2:]]


def _check_agreement(out: Path, stdout: str) -> list[dict]:
    with open(out / "bench.csv", newline="") as fh:
        csv_rows = list(csv.DictReader(fh))
    doc = json.loads((out / "bench.json").read_text())
    assert doc["format"] == "motionrep-bench" and doc["format_version"] == 1
    assert tuple(doc["columns"]) == COLUMNS and tuple(csv_rows[0].keys()) == COLUMNS
    assert len(csv_rows) == len(doc["rows"])
    for c, j in zip(csv_rows, doc["rows"]):
        for name in COLUMNS:
            v = j[name]
            if v is None:
                assert c[name] == "", name
            elif isinstance(v, float):
                assert float(c[name]) == v, name  # written exactly
            elif isinstance(v, dict):
                assert json.loads(c[name]) == v
            else:
                assert c[name] == str(v), name
    # the table (stdout and bench.md) shows the same numbers, rounded
    md = (out / "bench.md").read_text()
    table = _table_rows(md)
    assert len(table) == len(csv_rows)
    header = [h.strip() for h in md.splitlines()[0].strip("|").split("|")]
    col = {h: i for i, h in enumerate(header)}
    # the default table: two header lines and the rule, then one line per run, within 120 columns
    text_lines = stdout.split("\ntotals: ")[0].strip().splitlines()[3:]
    assert len(text_lines) == len(csv_rows)
    assert all(len(line) <= 120 for line in stdout.splitlines() if not line.startswith(("totals: ", "wrote ")))
    for line, j in zip(text_lines, doc["rows"]):
        if j["payload_bits_per_bone_frame"] is not None:  # the size vocabulary, first
            assert f"{j['payload_bits_per_bone_frame']:.3f}" in line and f"{j['file_bits_per_bone_frame']:.3f}" in line
    for cells, line, j in zip(table, text_lines, doc["rows"]):
        assert cells[col["clip"]] == j["clip"] and cells[col["codec"]] == j["codec"]
        assert int(cells[col["frames"]]) == j["frames"] and int(cells[col["joints"]]) == j["joints"]
        for name, key, digits in (("L-inf %", "error_percent", 3), ("paper ratio", "paper_ratio", 2),
                                  ("bytes ratio", "bytes_ratio", 2), ("bits/joint/frame", "bits_per_joint_frame", 3),
                                  ("encode s", "encode_seconds", 2)):
            if j[key] is None:
                assert cells[col[name]] == "-"
            else:
                assert float(cells[col[name]]) == pytest.approx(j[key], abs=0.51 * 10 ** -digits), name
        if j["decode_poses_per_second"] is not None:
            assert float(cells[col["decode poses/s"]].replace(",", "")) == \
                pytest.approx(j["decode_poses_per_second"], abs=0.51)
        assert cells[col["outcome"]] == j["outcome"]
        # a run that did not meet its bound is "failed" there, its best error in the L-inf column
        assert line.startswith(j["clip"] + " ") and f" {'failed' if j['status'] == 'failed' else j['outcome']} " in line
        if j["error_percent"] is not None:
            assert f" {j['error_percent']:.3f} " in line
    # medians in the JSON are the medians of the rows
    assert doc["medians"] == [s.as_dict() for s in summarize(read_csv(out / "bench.csv"))]
    return doc["rows"]


def test_cli_on_a_directory(clip_dir, tmp_path):
    out, plot = tmp_path / "results", tmp_path / "rd.png"
    r = run("bench", clip_dir, "-c", "svd", "--max-error", "1%", "--max-error", "5%", "--out", out, "--plot", plot,
            "--decode-poses", "300")
    assert r.exit_code == 0, r.output
    rows = _check_agreement(out, r.stdout)
    assert [(x["clip"], x["max_error"]) for x in rows] == [(c, b) for c in ("sub__arm", "sub__short", "walk")
                                                           for b in ("1%", "5%")]
    assert all(x["status"] == "ok" and x["error_percent"] <= float(x["max_error"][:-1]) for x in rows)
    assert all(x["outcome"] == f"rank={x['info']['rank']}" for x in rows)
    # tighter bound, higher rank, lower ratio
    for a, b in zip(rows[::2], rows[1::2]):
        assert a["info"]["rank"] >= b["info"]["rank"] and a["paper_ratio"] <= b["paper_ratio"]
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert plot_series(read_csv(out / "bench.csv")) == {"svd": [(x["payload_bits_per_bone_frame"], x["error_percent"])
                                                            for x in rows]}  # one scale for every codec
    assert plot_series(read_csv(out / "bench.csv"), "paper_ratio") == \
        {"svd": [(x["paper_ratio"], x["error_percent"]) for x in rows]}
    assert plot_series(read_csv(out / "bench.csv"), "bytes_ratio") == \
        {"svd": [(x["bytes_ratio"], x["error_percent"]) for x in rows]}
    with pytest.raises(ParameterError, match="ratio"):
        plot_series(read_csv(out / "bench.csv"), "file_size")
    assert "Medians" in r.stdout and re.search(r"svd\s+1%\s+3/3\s+0", r.stdout)
    assert "[6/6]" in r.stderr  # progress on stderr (one line per run when stderr is not a terminal)


def test_cli_sweep_on_a_database_turns_the_bound_off(database, tmp_path):
    out = tmp_path / "res"
    r = run("bench", database, "-p", "rank=1..3", "--out", out, "--decode-poses", "0", "-q")
    assert r.exit_code == 0, r.output
    rows = _check_agreement(out, r.stdout)
    # without --codec, only the codecs that take a -p parameter run
    assert [(x["clip"], x["codec"], x["params"]) for x in rows] == [
        (c, "svd", f"rank={k}") for c in ("one", "two") for k in (1, 2, 3)]
    assert all(x["max_error"] is None and x["bound"] is None and x["status"] == "ok" for x in rows)
    assert all(x["decode_poses_per_second"] is None for x in rows)
    for c in ("one", "two"):  # more rank, less error, lower ratio
        errs = [x["error"] for x in rows if x["clip"] == c]
        ratios = [x["paper_ratio"] for x in rows if x["clip"] == c]
        assert errs == sorted(errs, reverse=True) and ratios == sorted(ratios, reverse=True)
    assert r.stderr == ""
    doc = json.loads((out / "bench.json").read_text())
    assert doc["settings"]["params"] == {"rank": ["1", "2", "3"]} and doc["settings"]["max_errors"] == [None]
    assert doc["machine"]["cpus"] >= 1 and doc["machine"]["versions"]["numpy"]


def test_cli_sweep_with_an_explicit_bound_and_failures(database, tmp_path):
    out = tmp_path / "res"
    r = run("bench", database, "-c", "svd", "-p", "rank=1,40", "--max-error", "3%", "--out", out,
            "--decode-poses", "0", "-q")
    assert r.exit_code == 0, r.output  # a missed bound is an outcome, not an error
    rows = _check_agreement(out, r.stdout)
    low = [x for x in rows if x["params"] == "rank=1"]
    high = [x for x in rows if x["params"] == "rank=40"]
    assert all(x["status"] == "failed" and x["outcome"].startswith("failed: best L-inf") for x in low)
    assert all(x["error_percent"] > 3 for x in low)
    assert all(x["status"] == "ok" and x["error_percent"] <= 3 for x in high)
    assert re.search(r"svd\s+3%\s+rank=1\s+0/2\s+2\s+-", r.stdout)


@pytest.mark.slow  # worker processes (the batch pool's fast smoke test: test_batch_survives.py, the broken pool)
def test_jobs_give_the_same_rows_as_one_process(database, tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    assert run("bench", database, "-c", "svd", "--max-error", "2%", "--out", a, "--decode-poses", "0",
               "-q").exit_code == 0
    assert run("bench", database, "-c", "svd", "--max-error", "2%", "--out", b, "--decode-poses", "0", "-q",
               "--jobs", "2").exit_code == 0
    timing = {"encode_seconds", "load_average"}
    ra, rb = read_csv(a / "bench.csv"), read_csv(b / "bench.csv")
    assert [{k: v for k, v in x.as_dict().items() if k not in timing} for x in ra] == \
        [{k: v for k, v in x.as_dict().items() if k not in timing} for x in rb]


def test_tiny_fourier_run_and_representations(tmp_path):
    path = tmp_path / "tiny.bvh"
    write(synthetic_motion(chain_skeleton(3), frames=24, fps=30, seed=9), path)
    out = tmp_path / "res"
    # the paper's raw layout (float32 weights), where the stored numbers are the network's
    r = run("bench", path, "-c", "adaptive-fourier", "-p", "k=1", "-p", "iters=25", "-p", "dtype=float32",
            "--max-error", "none", "-r", "root-quat-axis-angle", "-r", "dual-quaternion", "--out", out,
            "--decode-poses", "200", "-q")
    assert r.exit_code == 0, r.output
    rows = _check_agreement(out, r.stdout)
    assert [x["representation"] for x in rows] == ["root-quat-axis-angle", "dual-quaternion"]
    assert all(x["outcome"] == "K=1" and x["info"]["K"] == 1 and len(x["info"]["omega"]) == 1 for x in rows)
    assert rows[1]["feature_width"] > rows[0]["feature_width"]
    # h = 2 (2K + 1) = 6 hidden units: W0 6x3, b0 6, W1 6x6, b1 6, W2 Dx6, b2 D, omega 1
    for x in rows:
        D = x["feature_width"]
        assert x["parameters"] == 18 + 6 + 36 + 6 + 6 * D + D + 1
        assert x["paper_ratio"] == pytest.approx(24 * D / x["parameters"])
    assert "represe" in r.stdout.splitlines()[1]  # shown when there are several (cut to fit 120 columns)
    assert "representation" in run("bench", path, "-c", "adaptive-fourier", "-p", "k=1", "-p", "iters=25",
                                   "--max-error", "none", "-r", "root-quat-axis-angle", "-r", "dual-quaternion",
                                   "--decode-poses", "0", "-q", "--wide").stdout.splitlines()[0]


def test_read_csv_round_trip(tmp_path):
    rows = [_row(error=0.1 + 0.2, error_percent=1 / 3, info={"rank": 2}, paper_ratio=math.pi, units="cm"),
            _row(status="failed", outcome="failed: best L-inf 3", error=3.0, max_error=None, bound=None)]
    write_csv(rows, tmp_path / "x.csv")
    assert read_csv(tmp_path / "x.csv") == rows
    assert csv_text(rows).splitlines()[0] == ",".join(COLUMNS)
    (tmp_path / "bad.csv").write_text("a,b\n1,2\n")
    with pytest.raises(FormatError, match="bad.csv"):
        read_csv(tmp_path / "bad.csv")
    write_json(rows, tmp_path / "x.json", machine={"cpus": 1})
    doc = json.loads((tmp_path / "x.json").read_text())
    assert doc["rows"][0]["error"] == 0.1 + 0.2 and doc["medians"][0]["ok"] == 1


def test_run_bench_keeps_task_order_and_reports_each_row(clip_dir):
    clips = collect_clips([clip_dir])
    tasks = bench_tasks(clips, ["svd"], ["root-quat-axis-angle"], ["2%", "4%"], decode_poses=0)
    seen = []
    rows = run_bench(tasks, on_done=seen.append)
    assert [(r.clip, r.max_error) for r in rows] == [(t.clip.name, t.max_error) for t in tasks]
    assert sorted(id(r) for r in seen) == sorted(id(r) for r in rows)


# ---- bad inputs ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("args, needle", [
    (["-p", "rank"], "KEY=VALUE"),
    (["-p", "rank=3..1"], "empty range"),
    (["-p", "rank=1", "-p", "rank=2"], "given twice"),
    (["--plot", "rd.gif"], ".png"),
    (["--jobs", "0"], "--jobs"),
])
def test_usage_errors_exit_2(clip_dir, tmp_path, args, needle):
    r = run("bench", clip_dir, "-c", "svd", *args)
    _one_line_error(r, 2, needle)


@pytest.mark.parametrize("args, needle", [
    (["-c", "zip"], "zip"),
    (["-c", "svd", "-r", "quaternions"], "quaternions"),
    (["-c", "svd", "-p", "k=3"], "'k' is not a parameter"),
    (["-c", "svd", "-p", "rank=-2"], "rank"),
    (["-c", "svd", "--max-error", "lots"], "max-error"),
])
def test_library_errors_exit_1_before_any_work(clip_dir, tmp_path, args, needle):
    out = tmp_path / "res"
    r = run("bench", clip_dir, *args, "--out", out)
    _one_line_error(r, 1, needle)
    assert not out.exists() and r.stdout == ""


def test_malformed_input_names_the_file(tmp_path, clip_dir):
    (clip_dir / "broken.bvh").write_text("HIERARCHY\nROOT Hips\n{\n")
    out = tmp_path / "res"
    r = run("bench", clip_dir, "-c", "svd", "--out", out)
    _one_line_error(r, 1, "broken.bvh")
    assert not out.exists()


def test_runs_that_end_with_an_error_exit_1_after_the_table(clip_dir, tmp_path):
    out = tmp_path / "res"
    r = run("bench", clip_dir, "-c", "svd", "--max-error", "none", "--out", out, "--decode-poses", "0", "-q")
    _one_line_error(r, 1, "3 of 3 runs ended with an error", "rank")
    assert "error: ParameterError" in r.stdout  # the table is still printed and written
    assert len(read_csv(out / "bench.csv")) == 3


def test_out_and_plot_do_not_replace_an_earlier_run_without_force(clip_dir, tmp_path):
    out, plot = tmp_path / "res", tmp_path / "rd.png"
    out.mkdir()
    (out / "bench.json").write_text("an earlier run")
    plot.write_bytes(b"an earlier plot")
    r = run("bench", clip_dir, "-c", "svd", "--out", out, "--plot", plot, "--decode-poses", "0", "-q")
    _one_line_error(r, 1, "bench.json", "--force")
    assert (out / "bench.json").read_text() == "an earlier run" and r.stdout == ""
    assert not (out / "bench.csv").exists()
    (out / "bench.json").unlink()
    r = run("bench", clip_dir, "-c", "svd", "--out", out, "--plot", plot, "--decode-poses", "0", "-q")
    _one_line_error(r, 1, "rd.png", "--force")
    assert plot.read_bytes() == b"an earlier plot"
    r = run("bench", clip_dir, "-c", "svd", "--out", out, "--plot", plot, "--decode-poses", "0", "-q", "-f")
    assert r.exit_code == 0, r.output
    assert (out / "bench.json").read_text() != "an earlier run" and plot.read_bytes() != b"an earlier plot"


def test_missing_input_is_a_usage_error(tmp_path):
    r = run("bench", tmp_path / "nope.bvh")
    assert r.exit_code == 2 and "does not exist" in r.stderr


# ---- real clips --------------------------------------------------------------------------------------------------
@requires_shared
@pytest.mark.realdata
def test_cli_on_real_clips_and_a_database_of_them(tmp_path):
    src = SHARED_DATA / "cmu" / "InverseKinematics"  # one 343-frame, 31-joint CMU walk
    r = run("bench", src, "-c", "svd", "--max-error", "2%", "--out", tmp_path / "dir", "--decode-poses", "1000",
            "-q")
    assert r.exit_code == 0, r.output
    rows = _check_agreement(tmp_path / "dir", r.stdout)
    assert [x["clip"] for x in rows] == ["02_01"]
    assert all(x["status"] == "ok" and x["error_percent"] <= 2 and x["joints"] == 31 for x in rows)
    db = tmp_path / "db.h5"
    assert run("convert", src, db).exit_code == 0
    r = run("bench", db, "-c", "svd", "--max-error", "2%", "--out", tmp_path / "db", "--decode-poses", "0", "-q")
    assert r.exit_code == 0, r.output
    again = _check_agreement(tmp_path / "db", r.stdout)
    assert [x["clip"] for x in again] == ["02_01"]
    # the database holds the same motions: same outcome and error; only the file-size figure differs
    for a, b in zip(rows, again):
        assert (a["outcome"], a["error"], a["paper_ratio"], a["bytes"]) == \
            (b["outcome"], b["error"], b["paper_ratio"], b["bytes"])


def test_log_axes_are_labelled_with_plain_numbers():
    pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    from motionrep.present.bench import plain_log_ticks

    ax = Figure().add_subplot()
    ax.set_xscale("log")
    plain_log_ticks(ax.xaxis)
    major, minor = ax.xaxis.get_major_formatter(), ax.xaxis.get_minor_formatter()
    assert [major(v, 0) for v in (0.1, 1.0, 10.0, 100.0)] == ["0.1", "1", "10", "100"]
    assert [minor(v, 0) for v in (0.2, 0.3, 2.0, 3.0, 5.0, 7.0, 20.0, 50.0, 60.0)] == \
        ["0.2", "", "2", "", "5", "", "20", "50", ""]


def test_codecs_describe_their_own_outcomes():
    from motionrep.plugin.codec import describe_info
    from motionrep.plugin.registry import get_codec

    fourier, svd = get_codec("adaptive-fourier"), get_codec("svd")
    assert fourier.describe({"K": 5, "omega": [1.0, 2.5], "hidden": 22}) == "K=5"
    assert fourier.describe({"K": 5, "omega": [1.0, 2.5], "hidden": 22}, detail=True) == \
        "K=5, omega=[1, 2.5] cycles/clip, hidden 22"
    windows = {"windows": 3, "K": [4, 2, 7], "omega": [[1.0]], "hidden": [18]}
    assert fourier.describe(windows) == "3 windows, K=2-7"
    assert fourier.describe(windows, detail=True) == "3 windows, K per window [4, 2, 7]"
    assert svd.describe({"rank": 9}) == svd.describe({"rank": 9}, detail=True) == "rank=9"
    # the generic description, for codecs that do not describe themselves
    assert describe_info({"keyframes": 12, "name": "x", "flag": True, "steps": [1, 2]}) == "keyframes=12, name=x"
    assert describe_info({"keyframes": 12, "steps": [1, 2.5]}, detail=True) == "keyframes=12, steps=[1, 2.5]"
    assert describe_info({}) == "-"


# ---- what anyone can do without motionrep, totals, clips told apart (issue 16) ---------------------------------
def test_xz_baseline_totals_and_clip_markers(clip_dir, tmp_path):
    import lzma

    out = tmp_path / "res"
    r = run("bench", clip_dir, "-c", "svd", "--decode-poses", "0", "-q", "--out", out, "--plot", tmp_path / "rd.png")
    assert r.exit_code == 0, r.output
    rows = {row.clip: row for row in read_csv(out / "bench.csv")}
    walk = rows["walk"]
    # a whole BVH file: xz -9 of its bytes; another format: of the clip written as BVH text
    assert walk.xz_bytes == len(lzma.compress((clip_dir / "walk.bvh").read_bytes(), preset=9))
    assert walk.xz_ratio == pytest.approx(walk.xz_bytes / walk.bytes, rel=1e-12)
    from motionrep.io import format_bvh

    short = read(clip_dir / "sub" / "short.npz")
    assert rows["sub__short"].xz_bytes == len(lzma.compress(format_bvh(short).encode(), preset=9))
    table = (out / "bench.md").read_text()
    total = sum(row.xz_bytes for row in rows.values())
    assert "totals: 3 runs on 3 clips: 3 ok, 0 failed (bound not met), 0 errors; encode " in r.output
    assert f"xz -9 of the sources {total:,} bytes" in r.output and "| xz -9 bytes |" in table
    # the plot: one colour per codec, one marker shape per clip
    from motionrep.present.bench.plot import plot_rate_distortion

    import matplotlib.figure

    shapes = []
    real_scatter = matplotlib.axes.Axes.scatter

    def spy(self, *args, **kwargs):
        shapes.append(kwargs.get("marker"))
        return real_scatter(self, *args, **kwargs)

    matplotlib.axes.Axes.scatter = spy
    try:
        plot_rate_distortion(list(rows.values()), tmp_path / "again.png")
    finally:
        matplotlib.axes.Axes.scatter = real_scatter
    assert len(set(shapes)) == 3


def test_an_older_csv_without_the_new_columns_still_reads(tmp_path):
    rows = [_row(clip="a", error_percent=1.0)]
    text = csv_text(rows).splitlines()
    keep = COLUMNS.index("xz_bytes")
    old = "\n".join(",".join(next(csv.reader([line]))[:keep]) for line in text) + "\n"
    (tmp_path / "old.csv").write_text(old)
    back = read_csv(tmp_path / "old.csv")
    assert back[0].clip == "a" and back[0].xz_bytes is None


def test_csv_of_an_older_writer_without_the_payload_columns_still_reads(tmp_path):
    """payload_bytes and bits_per_bone_frame were appended within layout version 1: files without them read,
    with None there."""
    rows = [_row(clip="a", payload_bytes=120, bits_per_bone_frame=0.5), _row(clip="b")]
    new = tmp_path / "new.csv"
    write_csv(rows, new)
    back = read_csv(new)
    assert back[0].payload_bytes == 120 and back[0].bits_per_bone_frame == 0.5 and back[1].payload_bytes is None
    old = tmp_path / "old.csv"
    with open(new, newline="") as fh:
        lines = list(csv.reader(fh))
    with open(old, "w", newline="") as fh:
        csv.writer(fh).writerows([line[:-5] for line in lines])  # before payload_bytes and the columns after it
    back = read_csv(old)
    assert [r.clip for r in back] == ["a", "b"] and back[0].bits_per_bone_frame is None
    bad = tmp_path / "bad.csv"
    with open(bad, "w", newline="") as fh:
        csv.writer(fh).writerows([lines[0][:-1] + ["bits_per_bone"]] + lines[1:])
    with pytest.raises(FormatError):
        read_csv(bad)
