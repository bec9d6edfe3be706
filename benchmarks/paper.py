"""Reproduce the experiments of Tojo et al. (2022) on the CMU clips in ../shared/data/cmu.

Stages (each runs its grid through ``motionrep.present.bench``, i.e. ``compress_motion`` and the shared evaluator, and
appends every finished run to ``benchmarks/results/paper_runs.jsonl``, so an interrupted run resumes where it
stopped; runs made with other codec or pipeline sources than the current ones (:func:`code_hash`) are run
again unless ``--keep-stale``; ``--fresh`` starts over). Every Fourier run pins the paper's layout,
``dtype=float32 window=0`` (:data:`PAPER_LAYOUT`), so the paper's ratio is the paper's whatever the codecs'
defaults; the runs recorded before it was pinned are read with it (:func:`paper_params`)):

``fig2``
    Fig. 2: ``adaptive-fourier`` at 2 % of the character height over every CMU clip (and ``svd`` at the same
    bound, for reference), after removing the leading transition most of these BVH conversions start with (a
    T-pose or rest-pose frame, or a few frames blending from it; see :func:`leading_transition`);
    ``--fig2-bounds 1% 2% 5%`` adds other bounds.
``fig2raw``
    The effect of that transition: the 31- and 165-joint clips that have one, as they are in the files and
    without it, in one run (same code on both sides).
``fig3``
    Fig. 3: error against the paper's compression ratio for ``svd`` (rank 1..40), ``naive-fourier`` and
    ``adaptive-fourier`` (K = 1..10), no bound, on four 31-joint clips as they are in the files.
``fig3t``
    The same on the two of them that start with a T-pose frame, without it.
``reps``
    The representations under the same codec: ``adaptive-fourier`` and ``svd`` at 2 % on the four clips
    (without their leading T-pose frame), with each installed representation (``root-quat-axis-angle``,
    ``dual-quaternion``, ``ortho6d``, ``euler``).
``report``
    Writes ``benchmarks/results/paper.md`` (tables, the comparison with the paper, the ``.mrc`` and payload bytes
    and bits/bone/frame of every run, machines and date), the CSV and JSON of each stage (``fig2.csv`` ...) and the plots (``fig2.png``, ``fig3*.png``, ``reps.png``).

The trimmed clips are written to an HDF5 database outside the repository (``$TMPDIR/motionrep_paper/
cmu_trimmed.h5``, rebuilt deterministically from ../shared/data when missing).

Usage::

    nohup python benchmarks/paper.py run fig3 fig3t reps fig2 fig2raw --jobs 2 > /tmp/paper.log 2>&1 &
    python benchmarks/paper.py report

Not part of the test suite: the full run takes hours on two shared cores.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import statistics
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DATA = Path(os.environ.get("MOTIONREP_SHARED_DATA", REPO.parent / "shared" / "data"))
CMU = DATA / "cmu"
RESULTS = REPO / "benchmarks" / "results"
RUNS = RESULTS / "paper_runs.jsonl"

#: Four 31-joint clips of different kinds for Fig. 3 and the representation comparison.
SUBSET = ("InverseKinematics__02_01", "pybvh__cmu_12_01_walk", "bvh11__131_03", "RGBDAcquisition__102_01cc")
REPRESENTATIONS = ("root-quat-axis-angle", "dual-quaternion", "ortho6d", "euler")
RIGS = {31: "31-joint cgspeed rig (120 fps)", 43: "43-joint Second-Life-style rig (120 fps)",
        165: "165-joint retargeted rig (MocapNET, 25 fps)"}
PAPER_CLAIM = "2-15x at < 2 % of the character height (Fig. 2, 116 CMU clips, 'in most cases')"

#: The paper's layout, pinned for every Fourier run: float32 weights and one network for the whole clip
#: (Algorithm 1). The codecs' defaults are the quantised, range-coded payload (version 3) and windows chosen by
#: measurement; with those the parameter count, hence the paper's ratio, would not be the paper's.
PAPER_LAYOUT: dict[str, list[str]] = {"dtype": ["float32"], "window": ["0"]}
FOURIER = ("adaptive-fourier", "naive-fourier")

#: Code versions (:func:`code_hash`) of the runs recorded before the layout was pinned (2026-11-22, payload
#: versions 1 and 2): the Fourier codecs' defaults were then ``dtype=float32`` and ``window=0``, so their runs
#: without those parameters are the pinned runs (:func:`paper_params`). A run from another code version that
#: does not name the layout is not taken for one.
RAW_DEFAULT_CODES = frozenset({"5d10d7d576ad", "0a11ab28fb09", "4b9cbd20ea10"})
#: The machine of those runs (they did not record it; from the report written with them on 2026-11-22).
RAW_DEFAULT_MACHINE = "2 CPUs (Intel(R) Xeon(R) Processor @ 2.50GHz), Python 3.11.7, torch 2.13.0+cpu"


def code_hash() -> str:
    """Short SHA-256 of the codec, representation and pipeline sources the results depend on (their C sources
    included)."""
    h = hashlib.sha256()
    files = sorted((REPO / "plugins").glob("motionrep_*/*.py")) + sorted((REPO / "plugins").glob("motionrep_*/_c/*"))
    files += [REPO / "motionrep" / n for n in ("pipeline/compress.py", "pipeline/evaluate.py", "io/container.py",
                                                "model/kinematics.py", "model/rotations.py", "model/poseplan.py",
                                                "plugin/codec.py")]
    files += sorted(p for p in (REPO / "motionrep" / "_c").rglob("*") if p.is_file())
    for f in files:
        h.update(f.name.encode())
        h.update(f.read_bytes())
    return h.hexdigest()[:12]


def paper_params(row: dict, code: str) -> str:
    """The parameters of a recorded run as :func:`stage_grid` spells them now: a Fourier run recorded by a code
    version of :data:`RAW_DEFAULT_CODES` without ``dtype`` / ``window`` gets the values it was made with (the
    defaults of that time, the paper's layout); other runs keep theirs."""
    text = row["params"]
    names = {p.split("=", 1)[0] for p in text.split()}
    if row["codec"] in FOURIER and code.split("->")[0] in RAW_DEFAULT_CODES and not names & set(PAPER_LAYOUT):
        text = " ".join([text] * bool(text) + [f"{k}={v[0]}" for k, v in PAPER_LAYOUT.items()])
    return text


def clip_name(name: str) -> str:
    """A clip's name as :func:`motionrep.pipeline.sources.collect_clips` gives it (runs recorded before 2026-12-01 named
    ``InverseKinematics/02_01`` what is now ``InverseKinematics__02_01``)."""
    return name.replace("/", "__")


def _trimmed_source(source: str) -> bool:
    """Whether a run's source is the clip without its leading transition (a clip of :data:`TRIMMED`), wherever
    ``$TMPDIR`` was when it ran."""
    return f"{TRIMMED.name}[" in source


def run_key(row: dict, code: str) -> tuple:
    """What makes two runs the same: the clip (by name, as in the file or trimmed; not by path, which depends
    on the worktree), codec, representation, bound, parameters (:func:`paper_params`) and seed."""
    return (clip_name(row["clip"]), _trimmed_source(row["source"]), row["codec"], row["representation"],
            row["max_error"], paper_params(row, code), row["seed"])


def task_key(task) -> tuple:
    """:func:`run_key` of the run a :class:`~motionrep.present.bench.BenchTask` makes."""
    return (task.clip.name, _trimmed_source(task.clip.source), task.codec, task.representation, task.max_error,
            " ".join(f"{k}={v}" for k, v in task.params), task.seed)


def load_runs() -> list[dict]:
    if not RUNS.exists():
        return []
    out = []
    for line in RUNS.read_text().splitlines():
        if line.strip():
            out.append(json.loads(line))
    return out


TRIMMED = Path(os.environ.get("TMPDIR", "/tmp")) / "motionrep_paper" / "cmu_trimmed.h5"


def leading_transition(motion) -> int:
    """Frames to drop at the start of ``motion``: the leading frames whose largest joint displacement to the next
    frame is above 4 times the clip's median and above 5 % of the character height (a T-pose frame, or a few
    frames blending from one, as most of these BVH conversions start with), at most 10; 0 when there is none."""
    import numpy as np

    from motionrep.model.kinematics import character_height, global_positions

    if motion.num_frames < 20:
        return 0
    p = global_positions(motion)
    step = np.linalg.norm(np.diff(p, axis=0), axis=-1).max(axis=1) / character_height(motion.skeleton) * 100
    limit = max(4 * float(np.median(step)), 5.0)
    n = 0
    while n < 10 and step[n] > limit:
        n += 1
    return n


def trimmed_clips(clips) -> tuple[list, dict[str, int]]:
    """The clips without their leading transition, from (or written to) the database :data:`TRIMMED`; and the
    number of frames dropped per clip name."""
    from motionrep.io import list_clips, write_database
    from motionrep.pipeline.sources import ClipRef

    dropped: dict[str, int] = {}
    names = {c.name: c.name.replace("/", "__") for c in clips}
    if TRIMMED.exists() and set(list_clips(TRIMMED)) == set(names.values()):
        meta = json.loads((TRIMMED.with_suffix(".json")).read_text())
        dropped = {clip_name(k): v for k, v in meta["dropped"].items()}
    else:
        TRIMMED.parent.mkdir(parents=True, exist_ok=True)
        items = []
        for c in clips:
            m = c.read()
            n = leading_transition(m)
            dropped[c.name] = n
            items.append((names[c.name], m.frames(slice(n, None)) if n else m))
        write_database(items, TRIMMED)
        TRIMMED.with_suffix(".json").write_text(json.dumps({"dropped": dropped}, indent=1))
    out = [ClipRef(c.name, str(TRIMMED), names[c.name], None) for c in clips]
    return out, dropped


def stage_grid(stage: str, clips, bounds: list[str]):
    from motionrep.present.bench import bench_tasks, parse_sweep

    trimmed, dropped = trimmed_clips(clips)
    by_name = {c.name: c for c in clips}
    trimmed_by_name = {c.name: c for c in trimmed}
    subset = [by_name[n] for n in SUBSET if n in by_name]
    layout = dict(PAPER_LAYOUT)
    if stage == "fig2":
        ordered = sorted(trimmed, key=lambda c: (_joints(by_name[c.name]) != 31, _joints(by_name[c.name]) == 43,
                                                 _frames(by_name[c.name]), c.name))
        return (bench_tasks(ordered, ["adaptive-fourier"], ["root-quat-axis-angle"], bounds, layout)
                + bench_tasks(ordered, ["svd"], ["root-quat-axis-angle"], bounds))
    if stage == "fig2raw":
        # the 31- and 165-joint clips that start with a transition, as in the file and without it, in one run
        # (so that both sides use the same code); the salsa clips are left out (4 min per failed run)
        names = [c.name for c in clips if dropped[c.name] and _joints(c) != 43]
        pool = [c for n in names for c in (by_name[n], trimmed_by_name[n])]
        return (bench_tasks(pool, ["adaptive-fourier"], ["root-quat-axis-angle"], bounds, layout)
                + bench_tasks(pool, ["svd"], ["root-quat-axis-angle"], bounds))
    if stage in ("fig3", "fig3t"):
        pool = subset if stage == "fig3" else [trimmed_by_name[c.name] for c in subset if dropped[c.name]]
        return (bench_tasks(pool, ["svd"], ["root-quat-axis-angle"], [None], parse_sweep(["rank=1..40"]))
                + bench_tasks(pool, list(FOURIER), ["root-quat-axis-angle"], [None],
                              {**parse_sweep(["k=1..10"]), **layout}))
    if stage == "reps":
        pool = [trimmed_by_name[c.name] for c in subset]
        return (bench_tasks(pool, ["svd"], list(REPRESENTATIONS), ["2%"])
                + bench_tasks(pool, ["adaptive-fourier"], list(REPRESENTATIONS), ["2%"], layout))
    raise SystemExit(f"unknown stage {stage!r}")


_INFO: dict[str, tuple[int, int, int, int]] = {}


def _joints(clip) -> int:
    return _info(clip)[0]


def _frames(clip) -> int:
    return _info(clip)[1]


def _info(clip) -> tuple[int, int, int, int]:
    """Joints, frames, end sites and BVH channels per frame of ``clip``."""
    if clip.name not in _INFO:
        m = clip.read()
        _INFO[clip.name] = (m.num_joints, m.num_frames, m.skeleton.num_end_sites, m.skeleton.num_channels)
    return _INFO[clip.name]


def run(stages: list[str], jobs: int, bounds: list[str], fresh: bool, rerun_stale: bool = True) -> None:
    from motionrep.present.bench import machine_info, run_bench
    from motionrep.pipeline.sources import collect_clips

    RESULTS.mkdir(parents=True, exist_ok=True)
    if fresh and RUNS.exists():
        RUNS.unlink()
    clips = collect_clips([CMU])
    machine = machine_info()
    where = (f"{machine['cpus']} CPUs ({machine['cpu']}), Python {machine['python']}, "
             + ", ".join(f"{k} {v}" for k, v in machine["versions"].items() if v))
    for stage in stages:
        # each stage starts new worker processes, which import the sources as they are now
        code = code_hash()
        done = {run_key(r["row"], r["code"]) for r in load_runs() if r["code"] == code or not rerun_stale}
        tasks = [t for t in stage_grid(stage, clips, bounds)]
        todo = [t for t in tasks if task_key(t) not in done]
        print(f"{stage}: {len(tasks)} runs, {len(tasks) - len(todo)} already done, {len(todo)} to run "
              f"({time.strftime('%H:%M:%S')})", flush=True)
        if not todo:
            continue
        count = [0]

        def on_done(row, stage=stage, total=len(todo), code=code, where=where):
            count[0] += 1
            now = code_hash()  # the sources changed during the run: the row is marked stale (rerun next time)
            with RUNS.open("a") as fh:
                fh.write(json.dumps({"stage": stage, "code": code if now == code else f"{code}->{now}",
                                     "load": os.getloadavg()[0], "machine": where,
                                     "row": _finite(row.as_dict())}) + "\n")
            err = "-" if row.error_percent is None else f"{row.error_percent:.2f}%"
            ratio = "-" if row.paper_ratio is None else f"{row.paper_ratio:.2f}"
            secs = "-" if row.encode_seconds is None else f"{row.encode_seconds:.0f}s"
            print(f"  [{count[0]}/{total} {time.strftime('%H:%M:%S')}] {row.clip} {row.codec} {row.representation} "
                  f"{row.max_error} {row.params}: {row.outcome} L-inf {err} ratio {ratio} {secs} "
                  f"(load {os.getloadavg()[0]:.1f})", flush=True)

        run_bench(todo, jobs=jobs, on_done=on_done)
    print("machine:", json.dumps(machine), flush=True)


def _finite(obj):
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_finite(v) for v in obj]
    return obj


# ---------------------------------------------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------------------------------------------
def rows_of(stage: str, clips) -> list:
    """The latest row of every run in the grid of ``stage``, in the grid's order. A run is shared between stages
    (``run`` does not repeat a run another stage already made with the same code), so the latest row with the
    same key is taken whichever stage wrote it."""
    from motionrep.present.bench import BenchRow

    latest: dict[tuple, dict] = {}
    codes: dict[tuple, str] = {}
    bounds: set = set()
    for r in load_runs():
        key = run_key(r["row"], r["code"])
        latest[key] = {**r["row"], "clip": key[0], "params": key[5]}
        codes[key] = r["code"]
        if r["stage"] == stage:
            bounds.add(r["row"]["max_error"])
    grid = [task_key(t) for t in stage_grid(stage, clips, _bounds_of([{"max_error": b} for b in bounds]))]
    keys = [k for k in dict.fromkeys(grid) if k in latest]
    _STAGE_CODES[stage] = sorted({codes[k] for k in keys})
    refs = {c.name: c for c in clips}
    return [BenchRow(**with_bone_figures(latest[k], refs)) for k in keys]


def with_bone_figures(row: dict, refs: dict) -> dict:
    """``row`` with ``payload_bytes`` and ``bits_per_bone_frame`` (figure (e) of :mod:`motionrep.pipeline.evaluate`:
    payload bits per frame and bone, bones = joints + end sites, ACL's count) where a run recorded before
    ``motionrep.present.bench`` wrote them lacks them.  Its payload is then derived from its stored numbers: every
    array of those runs' layouts is float32 (svd: ``mean``, ``coefficients``, ``basis``; a Fourier network with
    ``dtype=float32``: ``omega``, ``W0`` ... ``b2``), so it is 4 bytes per parameter; the figure itself comes
    from :func:`motionrep.pipeline.figures.compression_figures` with the clip's skeleton. Rows of other layouts are
    left without it."""
    from motionrep.pipeline.figures import compression_figures

    if row.get("payload_bytes") is not None or row["status"] != "ok" or not _all_float32(row):
        return row
    joints, _, end_sites, channels = _info(refs[row["clip"]])
    f = compression_figures(num_frames=row["frames"], feature_width=row["feature_width"],
                            num_parameters=row["parameters"], num_channels=channels, num_joints=joints,
                            compressed_bytes=row["bytes"], num_end_sites=end_sites,
                            payload_bytes=4 * row["parameters"])
    return {**row, "payload_bytes": f.payload_bytes, "bits_per_bone_frame": f.bits_per_bone_frame}


def _all_float32(row: dict) -> bool:
    params = dict(p.split("=", 1) for p in row["params"].split())
    if row["codec"] == "svd":
        return params.get("dtype", "float32") == "float32"
    return row["codec"] in FOURIER and params.get("dtype") == "float32" and params.get("window") == "0"


_STAGE_CODES: dict[str, list[str]] = {}


def _code_line(stage: str) -> str:
    codes = _STAGE_CODES.get(stage, [])
    return (f"Code version of these runs: {', '.join(codes)}." if len(codes) <= 1 else
            f"**Mixed code versions** in these runs: {', '.join(codes)} (rerun `paper.py run {stage}`).")


def _bounds_of(rows) -> list[str]:
    return list(dict.fromkeys(r["max_error"] for r in rows if r["max_error"] is not None)) or ["2%"]


def _pct(v):
    return "-" if v is None else f"{v:.2f}"


def _bytes(v):
    return "-" if v is None else f"{v:,.0f}"


def _med(vals):
    vals = [v for v in vals if v is not None]
    return statistics.median(vals) if vals else None


def _interp_error(curve: list[tuple[float, float]], ratio: float) -> float | None:
    """Error of a codec's curve at ``ratio`` (log-log linear interpolation); None outside its range."""
    pts = sorted(curve)
    for (x0, y0), (x1, y1) in zip(pts, pts[1:]):
        if x0 <= ratio <= x1 and y0 > 0 and y1 > 0:
            if x1 == x0:
                return min(y0, y1)
            a = (math.log(ratio) - math.log(x0)) / (math.log(x1) - math.log(x0))
            return math.exp(math.log(y0) + a * (math.log(y1) - math.log(y0)))
    return None


def report() -> None:
    from motionrep.present.bench import format_table, machine_info, plot_rate_distortion, write_csv, write_json
    from motionrep.pipeline.sources import collect_clips

    RESULTS.mkdir(parents=True, exist_ok=True)
    clips = collect_clips([CMU])
    runs = load_runs()
    codes = sorted({r["code"] for r in runs})
    loads = [r["load"] for r in runs if r.get("load") is not None]
    machine = machine_info()
    md: list[str] = ["# Tojo et al. (2022) reproduced on the CMU clips in ../shared/data/cmu", ""]
    md += [f"Generated by `benchmarks/paper.py report` on {machine['date']} from {len(runs)} runs in "
           f"`paper_runs.jsonl`.", "",
           "Runs made on: " + "; ".join(sorted({_machine_of(r) for r in runs})) + ". "
           f"Report written on: {machine['cpus']} CPUs ({machine['cpu']}). Shared with other engineers' jobs: the 1-minute load average while the runs finished was "
           f"{min(loads):.1f}-{max(loads):.1f} (median {statistics.median(loads):.1f}) on 2 cores, so encode "
           f"seconds are pessimistic and noisy; errors and ratios do not depend on load." if loads else "", "",
           f"Code (SHA-256 of codec, representation and pipeline sources): {', '.join(codes)}.", "",
           "Every number comes from `motionrep.present.bench` (`compress_motion`: encode, pack to `.mrc` bytes, decode "
           "from the bytes, shared FK-based L-inf error over all joints and end sites). Error is in % of the "
           "character height; the ratio is the paper's: frames x feature width / stored parameters (every stored "
           "number counted, frequencies and biases included). The Fourier runs pin the paper's layout, "
           "`-p dtype=float32 window=0` (float32 weights, one network for the whole clip; the codecs' defaults "
           "are now the quantised, range-coded payload and windows chosen by measurement, whose ratio would not "
           "be the paper's); other parameters are the codec defaults unless stated (adaptive-fourier: max_k 24, "
           "seed 0). Sizes: `bytes` is the `.mrc` file, `payload bytes` the codec's arrays without the skeleton "
           "and metadata every file has, and bits/bone/frame is `8 x payload bytes / (frames x (joints + end "
           "sites))` (`motionrep.pipeline.figures.compression_figures`, ACL's bone count, as `motionrep info` and "
           "`motionrep bench` report it). Runs recorded before `motionrep bench` wrote the payload size (code "
           + ", ".join(sorted(RAW_DEFAULT_CODES)) + ") have it derived: every array of their layouts is float32, "
           "so their payload is 4 bytes per stored parameter (checked against `Container.payload_bytes` for "
           "svd and both Fourier codecs with `dtype=float32 window=0`); failed runs have no file.", ""]

    # ---- data ------------------------------------------------------------------------------------------------
    trimmed, dropped = trimmed_clips(clips)
    md += ["## The clips", "",
           "Most of these BVH conversions start with a frame the capture did not produce: a T-pose or rest pose "
           "(the cgspeed 31-joint conversions: one frame, 45-62 % of the character height away from the next "
           "frame), or a few frames blending from one (the salsa and the 165-joint conversions: 3-4 frames moving "
           "12-22 % of the height per frame, against a median of 1-2 %). A network of a few frequencies cannot "
           "follow such a jump, and under an L-inf bound that one frame decides the outcome. The paper's clips "
           "came from the CMU database itself; whether they had such frames is not said. So Fig. 2 is run on the "
           "clips without this leading transition (`leading_transition`: leading frames whose largest joint "
           "displacement to the next frame exceeds 4x the clip's median and 5 % of the height, at most 10), and, "
           "for comparison, on the files as they are (`fig2raw`). Mid-clip glitches (marker swaps in several "
           "salsa clips, up to 51 % of the height in one frame) are left in: they are in the data.", "",
           "| rig | clips | frames | leading frames dropped |", "|---|---:|---|---|"]
    for joints in (31, 43, 165):
        g = [c for c in clips if _joints(c) == joints]
        if g:
            frames = [_frames(c) for c in g]
            drops = sorted({dropped[c.name] for c in g})
            md.append(f"| {_rig(joints)} | {len(g)} | {min(frames)}-{max(frames)} | "
                      f"{', '.join(str(d) for d in drops)} ({sum(dropped[c.name] > 0 for c in g)} clips with some) |")
    md += [""]

    # ---- Fig. 2 ------------------------------------------------------------------------------------------------
    rows2 = rows_of("fig2", clips)
    rows2raw = rows_of("fig2raw", clips)
    if rows2:
        write_csv(rows2, RESULTS / "fig2.csv")
        write_json(rows2, RESULTS / "fig2.json", machine=machine, settings={"stage": "fig2", "code": codes})
        md += ["## Fig. 2: adaptive-fourier at 2 %, every CMU clip (leading transition removed)", "",
               _code_line("fig2"), ""]
        md += _fig2_section(rows2)
        _fig2_plot(rows2, RESULTS / "fig2.png")
        md += ["![Fig. 2](fig2.png)", ""]
    if rows2raw:
        write_csv(rows2raw, RESULTS / "fig2raw.csv")
        write_json(rows2raw, RESULTS / "fig2raw.json", machine=machine, settings={"stage": "fig2raw", "code": codes})
        md += ["## The leading transition: the same clips with and without it (adaptive-fourier and svd at 2 %)",
               "", _code_line("fig2raw"), ""]
        md += _raw_vs_trimmed(rows2raw, dropped)

    # ---- Fig. 3 ------------------------------------------------------------------------------------------------
    for stage, title, suffix in (("fig3", "the four clips as they are in the files", ""),
                                 ("fig3t", "the two clips that start with a T-pose frame, without it", "_trimmed")):
        rows3 = rows_of(stage, clips)
        if not rows3:
            continue
        write_csv(rows3, RESULTS / f"{stage}.csv")
        write_json(rows3, RESULTS / f"{stage}.json", machine=machine, settings={"stage": stage, "code": codes})
        md += [f"## Fig. 3: svd vs naive-fourier vs adaptive-fourier, {title} (sweeps, no bound)", "",
               _code_line(stage), ""]
        md += _fig3_section(rows3)
        plot_rate_distortion(rows3, RESULTS / f"{stage}.png", title=f"Fig. 3 reproduced: {title}")
        md += [f"![Fig. 3, {title}]({stage}.png)", ""]
        for clip in dict.fromkeys(r.clip for r in rows3):
            safe = clip.replace("/", "__") + suffix
            plot_rate_distortion([r for r in rows3 if r.clip == clip], RESULTS / f"fig3_{safe}.png",
                                 title=f"{clip}{' (without frame 0)' if suffix else ''}: error vs compression ratio")
            md += [f"![Fig. 3, {clip}](fig3_{safe}.png)"]
        md += [""]

    # ---- representations ---------------------------------------------------------------------------------------
    rowsr = rows_of("reps", clips)
    if rowsr:
        write_csv(rowsr, RESULTS / "reps.csv")
        write_json(rowsr, RESULTS / "reps.json", machine=machine, settings={"stage": "reps", "code": codes})
        md += ["## Representations under the same codec, at 2 % (the four Fig. 3 clips, leading T-pose removed)",
               "", _code_line("reps"), ""]
        md += _reps_section(rowsr)
        plot_rate_distortion(rowsr, RESULTS / "reps.png", title="representations at 2 % (4 clips)",
                             ratio="bytes_ratio")
        md += ["![representations](reps.png)", ""]
        md += ["<details><summary>All runs</summary>", "", format_table(rowsr, markdown=True), "</details>", ""]
    text = "\n".join(md).rstrip() + "\n"
    (RESULTS / "paper.md").write_text(text)
    print(f"wrote {RESULTS / 'paper.md'}")


def _machine_of(record: dict) -> str:
    if "machine" in record:
        return record["machine"]
    return RAW_DEFAULT_MACHINE if record["code"].split("->")[0] in RAW_DEFAULT_CODES else "not recorded"


def _rig(joints: int) -> str:
    return RIGS.get(joints, f"{joints}-joint rig")


def _fig2_section(rows) -> list[str]:
    from motionrep.present.bench import format_table

    md = []
    for bound in dict.fromkeys(r.max_error for r in rows):
        ad = [r for r in rows if r.codec == "adaptive-fourier" and r.max_error == bound]
        sv = {r.clip: r for r in rows if r.codec == "svd" and r.max_error == bound}
        if not ad:
            continue
        md += [f"### Bound {bound}", "",
               "| rig | clips | met the bound | paper ratio: min / median / max (runs that met it) | K median "
               "| .mrc bytes, median | bits/bone/frame, median | failed: best error %, median (max) "
               "| svd met / ratio median / bits/bone/frame median (same bound) | encode s, median |",
               "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|"]
        for joints in sorted({r.joints for r in ad}):
            g = [r for r in ad if r.joints == joints]
            ok = [r for r in g if r.status == "ok"]
            ratios = [r.paper_ratio for r in ok]
            ks = [r.info.get("K") for r in ok if r.info.get("K") is not None]
            svr = [sv[r.clip].paper_ratio for r in g if r.clip in sv and sv[r.clip].status == "ok"]
            rng = (f"{min(ratios):.2f} / {statistics.median(ratios):.2f} / {max(ratios):.2f}" if ratios else "-")
            bad = [r.error_percent for r in g if r.status == "failed" and r.error_percent is not None]
            fail = f"{statistics.median(bad):.2f} ({max(bad):.2f})" if bad else "-"
            svn = sum(1 for r in g if r.clip in sv and sv[r.clip].status == "ok")
            svb = [sv[r.clip].bits_per_bone_frame for r in g if r.clip in sv and sv[r.clip].status == "ok"]
            md.append(f"| {_rig(joints)} | {len(g)} | {len(ok)} | {rng} | "
                      f"{statistics.median(ks) if ks else '-'} | {_bytes(_med(r.bytes for r in ok))} | "
                      f"{_pct(_med(r.bits_per_bone_frame for r in ok))} | {fail} | "
                      f"{svn} / {_pct(_med(svr))} / {_pct(_med(svb))} | {_pct(_med(r.encode_seconds for r in ok))} |")
        ok = [r for r in ad if r.status == "ok"]
        ratios = sorted(r.paper_ratio for r in ok)
        in_claim = sum(2 <= x <= 15 for x in ratios)
        md += ["", f"Overall at {bound}: {len(ok)} of {len(ad)} clips met the bound with adaptive-fourier (max_k "
               f"24); their paper ratios range {ratios[0]:.2f}-{ratios[-1]:.2f}x (median "
               f"{statistics.median(ratios):.2f}x), {in_claim} of them within 2-15x; their files are "
               f"{_bytes(min(r.bytes for r in ok))}-{_bytes(max(r.bytes for r in ok))} bytes, "
               f"{_pct(min(r.bits_per_bone_frame for r in ok))}-{_pct(max(r.bits_per_bone_frame for r in ok))} "
               f"bits/bone/frame (median {_pct(_med(r.bits_per_bone_frame for r in ok))})." if ratios else
               f"Overall at {bound}: no clip met the bound.", ""]
        wins = [(r, sv[r.clip]) for r in ok if r.clip in sv and sv[r.clip].status == "ok"]
        if wins:
            better = sum(a.paper_ratio > s.paper_ratio for a, s in wins)
            md += [f"Against svd at the same bound, adaptive-fourier compresses more on {better} of the {len(wins)} "
                   f"clips both codecs met (median ratio adaptive / svd: "
                   f"{statistics.median(a.paper_ratio / s.paper_ratio for a, s in wins):.2f}).", ""]
        md += ["<details><summary>Every clip</summary>", "", format_table(ad + list(sv.values()), markdown=True),
               "</details>", ""]
    return md


def _raw_vs_trimmed(rows, dropped) -> list[str]:
    """Rows of ``fig2raw``: each clip as in the file and without its leading transition (same run)."""
    trimmed = {(r.clip, r.codec, r.max_error): r for r in rows if _trimmed_source(r.source)}
    raw = [r for r in rows if not _trimmed_source(r.source)]
    md = ["| clip | frames dropped | codec | bound | as in the file | without the leading transition |",
          "|---|---:|---|---|---|---|"]

    def cell(r):
        if r is None:
            return "not run"
        if r.status == "ok":
            return f"{r.outcome}, {r.error_percent:.2f}%, ratio {r.paper_ratio:.2f}"
        return r.outcome

    for r in raw:
        md.append(f"| {r.clip} | {dropped.get(r.clip, 0)} | {r.codec} | {r.max_error} | {cell(r)} | "
                  f"{cell(trimmed.get((r.clip, r.codec, r.max_error)))} |")
    for codec in dict.fromkeys(r.codec for r in raw):
        a = [r for r in raw if r.codec == codec]
        b = [trimmed.get((r.clip, r.codec, r.max_error)) for r in a]
        md += ["", f"{codec}: {sum(r.status == 'ok' for r in a)} of {len(a)} files met the bound as they are; "
               f"{sum(x is not None and x.status == 'ok' for x in b)} of {sum(x is not None for x in b)} without "
               f"their leading transition."]
    return md + [""]


def failed_ratio(row, width: int) -> float:
    """The paper's ratio of the network a Fourier codec gives up with (K = max_k): where a failed run would sit
    on the ratio axis, had the codec stored its last network (the paper's Fig. 2 shows such clips, with their
    error).  ``K + h (2K + 1) + h + h^2 + h + D h + D`` parameters, ``h = 2 (2K + 1)``."""
    from motionrep.plugin.registry import get_codec

    params = dict(p.split("=", 1) for p in row.params.split()) if row.params else {}
    K = int(params.get("max_k", get_codec(row.codec).Params().max_k))
    h = 2 * (2 * K + 1)
    return row.frames * width / (K + h * (2 * K + 1) + 2 * h + h * h + width * h + width)


def _fig2_plot(rows, path: Path) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from motionrep.present.bench import plain_log_ticks

    ad = [r for r in rows if r.codec == "adaptive-fourier"]
    bounds = list(dict.fromkeys(r.max_error for r in ad))
    fig = Figure(figsize=(13, 5.6), dpi=110)
    FigureCanvasAgg(fig)
    ax1, ax2, ax3 = fig.subplots(1, 3)
    colours = {31: "#1f77b4", 43: "#d62728", 165: "#2ca02c"}
    markers = {b: m for b, m in zip(bounds, "os^D")}
    widths = {r.clip: r.feature_width for r in rows if r.feature_width}
    for joints in sorted({r.joints for r in ad}):
        for b in bounds:
            ok = [r for r in ad if r.joints == joints and r.max_error == b and r.status == "ok"]
            bad = [r for r in ad if r.joints == joints and r.max_error == b and r.status == "failed"
                   and r.error_percent is not None and r.clip in widths]
            label = f"{_rig(joints).split(' (')[0]} @ {b}"
            colour = colours.get(joints, "k")
            ax1.scatter([r.paper_ratio for r in ok], [r.error_percent for r in ok], color=colour,
                        marker=markers[b], s=24, alpha=0.7, label=f"{label}: {len(ok)} met the bound")
            if bad:
                ax1.scatter([failed_ratio(r, widths[r.clip]) for r in bad], [r.error_percent for r in bad],
                            facecolors="none", edgecolors=colour, marker=markers[b], s=24, alpha=0.8,
                            label=f"{label}: {len(bad)} failed (best error, ratio at max_k)")
    for b in bounds:
        if b and b.endswith("%"):
            ax1.axhline(float(b[:-1]), color="0.5", linestyle="--", linewidth=0.8)
    ax1.axvspan(2, 15, color="0.85", alpha=0.4, label="paper: 2-15x")
    ax1.set_xlabel("paper compression ratio")
    ax1.set_ylabel("L-inf error (% of height)")
    ax1.set_title("adaptive-fourier: each clip", fontsize=10)
    ax1.set_yscale("log")
    plain_log_ticks(ax1.yaxis)
    handles, labels = ax1.get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=7.5, frameon=False)
    ax1.grid(alpha=0.3)
    ok = [r for r in ad if r.status == "ok"]
    for b in bounds:
        vals = [r.paper_ratio for r in ok if r.max_error == b]
        if vals:
            ax2.hist(vals, bins=12, alpha=0.6, label=f"{b} ({len(vals)} clips)")
    ax2.set_xlabel("paper compression ratio")
    ax2.set_ylabel("clips")
    ax2.set_title("ratio of the clips that met the bound", fontsize=10)
    ax2.legend(fontsize=7)
    for b in bounds:
        vals = [r.error_percent for r in ad if r.max_error == b and r.error_percent is not None]
        if vals:
            ax3.hist(vals, bins=12, alpha=0.6, label=f"{b} (failed runs: best error)")
    ax3.set_xlabel("L-inf error (% of height)")
    ax3.set_title("error (all clips)", fontsize=10)
    ax3.legend(fontsize=7)
    fig.tight_layout(rect=(0, 0.03 + 0.035 * math.ceil(len(labels) / 3), 1, 1))
    fig.savefig(path)


def _fig3_section(rows) -> list[str]:
    md = ["Each codec is swept over its size (svd: rank 1..40; Fourier codecs: K = 1..10, each K trained from "
          "scratch with the warm start of Algorithm 1 from K = 0, as `-p k=K` does); the bound is off. The table "
          "compares the codecs at equal ratio: for every adaptive-fourier point, the error of the other codec's "
          "curve at the same ratio (log-log interpolation between its two neighbouring points; points outside "
          "the other curve's range are not compared).", "",
          "| clip | frames | adaptive points | adaptive below svd at equal ratio | adaptive below naive at equal ratio "
          "| adaptive at K=10: error %, ratio | naive at K=10: error % | svd at the adaptive K=10 ratio: error % |",
          "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for clip in dict.fromkeys(r.clip for r in rows):
        g = [r for r in rows if r.clip == clip and r.status == "ok"]
        curves = {c: [(r.paper_ratio, r.error_percent) for r in g if r.codec == c] for c in
                  ("adaptive-fourier", "naive-fourier", "svd")}
        cmp = {}
        for other in ("svd", "naive-fourier"):
            n = wins = 0
            for x, y in curves["adaptive-fourier"]:
                e = _interp_error(curves[other], x)
                if e is not None:
                    n += 1
                    wins += y < e
            cmp[other] = f"{wins} of {n}" if n else "- (no overlap)"
        k10 = {c: next((r for r in g if r.codec == c and "k=10" in r.params.split()), None) for c in
               ("adaptive-fourier", "naive-fourier")}
        a10 = k10["adaptive-fourier"]
        svd_at = _interp_error(curves["svd"], a10.paper_ratio) if a10 else None
        frames = g[0].frames if g else "-"
        md.append(f"| {clip} | {frames} | {len(curves['adaptive-fourier'])} | {cmp['svd']} | {cmp['naive-fourier']} "
                  f"| {_pct(a10.error_percent if a10 else None)} (ratio {a10.paper_ratio:.2f}) "
                  f"| {_pct(k10['naive-fourier'].error_percent if k10['naive-fourier'] else None)} "
                  f"| {_pct(svd_at)} |" if a10 else f"| {clip} | {frames} | - | - | - | - | - | - |")
    md += ["", "Per-K medians over the clips:", ""]
    from motionrep.present.bench import summarize

    md += ["| codec | size | clips | median L-inf % | median paper ratio | median .mrc bytes "
           "| median payload bytes | median bits/bone/frame |", "|---|---|---:|---:|---:|---:|---:|---:|"]
    for s in summarize(rows):
        if s.codec == "svd" and s.params not in {f"rank={k}" for k in (1, 2, 3, 5, 8, 10, 15, 20, 30, 40)}:
            continue
        ok = [r for r in rows if r.status == "ok" and (r.codec, r.params) == (s.codec, s.params)]
        md.append(f"| {s.codec} | {s.params} | {s.ok} | {_pct(s.median_error_percent)} | "
                  f"{_pct(s.median_paper_ratio)} | {_bytes(_med(r.bytes for r in ok))} | "
                  f"{_bytes(_med(r.payload_bytes for r in ok))} | {_pct(s.median_bits_per_bone_frame)} |")
    return md + [""]


def _reps_section(rows) -> list[str]:
    md = ["The paper's ratio divides `frames x feature width` by the stored parameters, so a wider representation "
          "(dual-quaternion: 8 numbers per joint; ortho6d: 6; root-quat-axis-angle and euler: 3) looks better by "
          "that measure for the same file. Representations are therefore compared by the bytes ratio (float32 BVH "
          "channels / `.mrc` bytes), which does not depend on the representation; the paper's ratio is shown in "
          "brackets.", "",
          "| clip | codec | " + " | ".join(REPRESENTATIONS) + " |", "|---|---|" + "---|" * len(REPRESENTATIONS)]
    for clip in dict.fromkeys(r.clip for r in rows):
        for codec in ("adaptive-fourier", "svd"):
            cells = []
            for rep in REPRESENTATIONS:
                r = next((x for x in rows if x.clip == clip and x.codec == codec and x.representation == rep), None)
                if r is None:
                    cells.append("not run")
                elif r.status == "ok":
                    cells.append(f"{r.outcome}: {r.error_percent:.2f}%, bytes ratio {r.bytes_ratio:.2f} "
                                 f"({r.paper_ratio:.2f})")
                else:
                    cells.append(r.outcome.replace("|", "/"))
            md.append(f"| {clip} | {codec} | " + " | ".join(cells) + " |")
    md += ["", "Median bytes ratio at 2 % (paper's ratio and median bits/bone/frame in brackets; runs that met "
           "the bound / runs):", "",
           "| codec | " + " | ".join(REPRESENTATIONS) + " |", "|---|" + "---|" * len(REPRESENTATIONS)]
    for codec in ("adaptive-fourier", "svd"):
        cells = []
        for rep in REPRESENTATIONS:
            g = [r for r in rows if r.codec == codec and r.representation == rep]
            ok = [r for r in g if r.status == "ok"]
            cells.append(f"{statistics.median(r.bytes_ratio for r in ok):.2f} "
                         f"({statistics.median(r.paper_ratio for r in ok):.2f}, "
                         f"{_pct(_med(r.bits_per_bone_frame for r in ok))} b/bone/frame) ({len(ok)}/{len(g)})" if ok
                         else f"- (0/{len(g)})")
        md.append(f"| {codec} | " + " | ".join(cells) + " |")
    return md + [""]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run stages, appending to paper_runs.jsonl")
    r.add_argument("stages", nargs="+", choices=["fig2", "fig2raw", "fig3", "fig3t", "reps"])
    r.add_argument("--jobs", type=int, default=2)
    r.add_argument("--fig2-bounds", nargs="+", default=["2%"])
    r.add_argument("--fresh", action="store_true", help="forget earlier runs")
    r.add_argument("--keep-stale", action="store_true",
                   help="do not rerun runs made with other codec/pipeline sources (see code_hash)")
    sub.add_parser("report", help="write paper.md, CSV/JSON and plots from paper_runs.jsonl")
    args = parser.parse_args(argv)
    if not CMU.is_dir():
        sys.exit(f"CMU clips not found at {CMU} (set MOTIONREP_SHARED_DATA)")
    if args.command == "run":
        run(args.stages, args.jobs, args.fig2_bounds, args.fresh, not args.keep_stale)
    else:
        report()


if __name__ == "__main__":
    main()
