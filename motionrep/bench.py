"""Benchmarks of codecs on clips: the grid codec x representation x bound (or fixed-size sweep) x clip.

Every run goes through :func:`motionrep.compress.compress_motion`, so what is measured is what ``motionrep
compress`` would write: the codec encodes, the payload is packed into ``.mrc`` bytes, decoded again from those
bytes and measured with the shared evaluator (:mod:`motionrep.evaluate`: FK-based L-infinity error over every
joint and end site).  A bound the codec cannot meet is an outcome (a row with status ``"failed"`` and the best
error reached), not an error.

Each run gives one :class:`BenchRow` (column reference: ``specs/bench.md``):

- the clip (name, source, frames, joints, frame rate, character height);
- the run (codec, representation, requested bound, fixed parameters of a sweep, seed);
- the outcome (status, ``K=5`` / ``rank=9`` or ``failed: best L-inf ...``), the error in file units and in
  percent of the character height, the four compression figures of :func:`motionrep.evaluate.compression_figures`
  (the paper's ratio, the bytes ratio against float32 channels, bits per joint per frame, the ratio against the
  source file);
- the cost: encode seconds (``CompressResult.seconds``: features, encoding, packing and the two checks, after
  :func:`warm_up`), and decode speed: poses per second when decoding :data:`DEFAULT_DECODE_POSES` poses at
  random times in batches (codec decode, then the representation to local joint rotations: the steps of
  :func:`motionrep.compress.decode_container`), feature vectors per second (the codec alone), and the median
  time to decode one pose at an arbitrary time.

:func:`summarize` gives the medians per codec, representation, bound and sweep value over the runs that
succeeded, with the failure count.  :func:`format_table`, :func:`write_csv`, :func:`write_json` and
:func:`plot_rate_distortion` all take the same rows, so the table, the CSV, the JSON and the plot agree.

Sweeps (``-p k=1..12``, ``-p rank=1,2,4``): :func:`parse_sweep` expands ranges ``a..b`` (integers, inclusive)
and comma lists (which may mix both: ``1..4,8``).  A parameter applies to every codec whose ``Params`` has a
field of that name; the values of several swept parameters of one codec are combined (cartesian product).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
import os
import platform
import statistics
import time
from dataclasses import dataclass, field
from datetime import datetime, timezone
from itertools import product
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np

from ._model import Motion
from .errors import BoundNotMetError, FormatError, MotionrepError, ParameterError

__all__ = [
    "BENCH_FORMAT",
    "BENCH_VERSION",
    "DEFAULT_DECODE_POSES",
    "BenchClip",
    "BenchTask",
    "BenchRow",
    "BenchSummary",
    "COLUMNS",
    "SUMMARY_COLUMNS",
    "collect_clips",
    "read_clip",
    "codec_parameter_names",
    "parse_sweep",
    "is_sweep",
    "bench_tasks",
    "run_task",
    "outcome_of",
    "run_bench",
    "warm_up",
    "summarize",
    "format_table",
    "plain_log_ticks",
    "csv_text",
    "write_csv",
    "read_csv",
    "write_json",
    "bench_json",
    "plot_rate_distortion",
    "plot_series",
    "machine_info",
]

#: ``format`` written into the JSON file.
BENCH_FORMAT = "motionrep-bench"
#: Version of the CSV/JSON layout (``specs/bench.md``); bumped when a column changes meaning or is removed.
BENCH_VERSION = 1
#: Poses decoded (at random times, in batches of :data:`DECODE_BATCH`) to measure decode throughput.
DEFAULT_DECODE_POSES = 20_000
#: Poses decoded per call when measuring throughput.
DECODE_BATCH = 8192
#: Single-pose decodes whose median is ``decode_pose_seconds``.
SINGLE_POSE_REPEATS = 25

_MOTION_SUFFIXES = (".bvh", ".npz", ".h5", ".hdf5")


# ---------------------------------------------------------------------------------------------------------------
# inputs
# ---------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BenchClip:
    """One input clip.

    Attributes:
        name: unique name in the results (file stem; path relative to a directory argument, without suffix;
            a database's clip name).
        path: the file holding it.
        clip: the clip's name inside an HDF5 database, else None.
        source_bytes: size of the source file (None for a clip of a database, whose size is shared).
    """

    name: str
    path: str
    clip: str | None = None
    source_bytes: int | None = None

    @property
    def source(self) -> str:
        """``path`` or ``path[clip]``."""
        return self.path if self.clip is None else f"{self.path}[{self.clip}]"


def _clips_of_file(path: Path, name: str, alone: bool) -> list[BenchClip]:
    """The clips of one file; a database's clips are named ``<name>/<clip>``, or ``<clip>`` when ``alone``."""
    from .io import format_of, list_clips

    size = path.stat().st_size
    if format_of(path) != "hdf5":
        return [BenchClip(name, str(path), None, size)]
    names = list_clips(path)
    if len(names) == 1:
        return [BenchClip(names[0] if alone else name, str(path), names[0], size)]
    return [BenchClip(c if alone else f"{name}/{c}", str(path), c, None) for c in names]


def collect_clips(inputs: Iterable[str | os.PathLike[str]]) -> list[BenchClip]:
    """The clips of files, directories (searched recursively for ``.bvh``, ``.npz``, ``.h5`` and ``.hdf5``
    files) and HDF5 databases (every clip).

    Names: a file's stem; below a directory, the path relative to it without suffix (``bvh11/131_01``); the
    clips of a database are ``<stem>/<clip>``, or just ``<clip>`` when the database is the only input.  A name
    that two inputs share is replaced by the clip's source (``path`` or ``path[clip]``).

    Raises:
        FormatError: for a missing file, an unknown suffix, an unreadable database, an input given twice, or no
            clips at all.
    """
    paths = [Path(p) for p in inputs]
    clips: list[BenchClip] = []
    for p in paths:
        if p.is_dir():
            files = sorted(f for f in p.rglob("*") if f.is_file() and f.suffix.lower() in _MOTION_SUFFIXES)
            for f in files:
                clips.extend(_clips_of_file(f, f.relative_to(p).with_suffix("").as_posix(), False))
        elif p.exists():
            clips.extend(_clips_of_file(p, p.stem, len(paths) == 1))
        else:
            raise FormatError("no such file or directory", p)
    if not clips:
        raise FormatError("no motion clips found (looked for .bvh, .npz, .h5 and .hdf5 files)",
                          ", ".join(map(str, paths)))
    sources = [c.source for c in clips]
    if len(set(sources)) != len(sources):
        raise FormatError("given more than once", next(s for s in sources if sources.count(s) > 1))
    count: dict[str, int] = {}
    for c in clips:
        count[c.name] = count.get(c.name, 0) + 1
    return [dataclasses.replace(c, name=c.source) if count[c.name] > 1 else c for c in clips]


def read_clip(clip: BenchClip) -> Motion:
    """Read one :class:`BenchClip`."""
    from .io import read

    return read(clip.path, clip=clip.clip) if clip.clip is not None else read(clip.path)


# ---------------------------------------------------------------------------------------------------------------
# sweeps and the grid
# ---------------------------------------------------------------------------------------------------------------
def is_sweep(value: str) -> bool:
    """True if a ``-p`` value is a range or a list (``1..12``, ``1,2,4``): a sweep, which turns the default bound
    off."""
    return ".." in value or "," in value


def _expand(key: str, text: str) -> list[str]:
    out: list[str] = []
    for part in text.split(","):
        part = part.strip()
        if not part:
            raise ParameterError(f"-p {key}={text}: empty item in the list")
        if ".." in part:
            a, _, b = part.partition("..")
            try:
                lo, hi = int(a), int(b)
            except ValueError:
                raise ParameterError(f"-p {key}={text}: a range is two integers a..b, got {part!r}") from None
            if hi < lo:
                raise ParameterError(f"-p {key}={text}: empty range {part!r} (the end is below the start)")
            if hi - lo >= 10_000:
                raise ParameterError(f"-p {key}={text}: range {part!r} has more than 10000 values")
            out.extend(str(v) for v in range(lo, hi + 1))
        else:
            out.append(part)
    return list(dict.fromkeys(out))


def parse_sweep(pairs: Iterable[str]) -> dict[str, list[str]]:
    """Parse ``-p KEY=VALUES`` options into ``{key: [value, ...]}`` (values as strings, in order, duplicates
    dropped).

    ``VALUES`` is one value (``4``, ``float16``), a range ``a..b`` of integers (both ends included), or a comma
    list whose items are values or ranges (``1..4,8,16``).

    Raises:
        ParameterError: for a pair without ``=``, an empty key, a key given twice, an empty or reversed range, or
            a range whose ends are not integers.
    """
    out: dict[str, list[str]] = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        key = key.strip()
        if not sep or not key:
            raise ParameterError(f"expected KEY=VALUE (or KEY=a..b, KEY=a,b,c), got {pair!r}")
        if key in out:
            raise ParameterError(f"parameter {key!r} given twice; give all its values in one -p {key}=a,b,...")
        out[key] = _expand(key, value.strip())
    return out


@dataclass(frozen=True)
class BenchTask:
    """One run of the grid: a clip, codec, representation, bound and fixed parameters.

    Attributes:
        index: position in the grid (rows are reported in this order).
        clip: the input clip.
        codec: codec name.
        representation: representation name.
        max_error: the requested bound as given (``"2%"``, ``"1.5"``), or None for none.
        params: codec parameters (strings, as from the command line), in the order given.
        seed: random seed of the codec.
        decode_poses: poses decoded to measure decode throughput (0: not measured).
    """

    index: int
    clip: BenchClip
    codec: str
    representation: str
    max_error: str | None
    params: tuple[tuple[str, str], ...] = ()
    seed: int = 0
    decode_poses: int = DEFAULT_DECODE_POSES


def codec_parameter_names(codec: str) -> list[str]:
    """Names of the fields of ``codec``'s ``Params`` (what ``-p`` may set).

    Raises:
        UnknownPluginError: for an unknown codec.
    """
    from .plugins import get_codec

    return [f.name for f in dataclasses.fields(get_codec(codec).Params)]


def bench_tasks(clips: Sequence[BenchClip], codecs: Sequence[str], representations: Sequence[str],
                max_errors: Sequence[str | None], sweep: Mapping[str, Sequence[str]] | None = None, *,
                seed: int = 0, decode_poses: int = DEFAULT_DECODE_POSES) -> list[BenchTask]:
    """The grid, clip by clip, then representation, codec, parameter combination and bound.

    Each parameter of ``sweep`` applies to the codecs whose ``Params`` has a field of that name; a codec's
    combinations are the cartesian product of the values of the parameters that apply to it.  Every
    combination is validated (``codec.parse_params``) and every bound parsed before any work.

    Raises:
        UnknownPluginError: for an unknown codec or representation.
        ParameterError: for a parameter no codec has, an invalid value, or an invalid bound.
    """
    from .compress import parse_max_error
    from .plugins import get_codec, get_representation

    sweep = dict(sweep or {})
    if not codecs:
        raise ParameterError("no codec to run")
    for rep in representations:
        get_representation(rep)
    bounds: list[str | None] = []
    for m in max_errors:
        limit = parse_max_error(m)
        bounds.append(None if limit is None else str(m).strip())
    used: set[str] = set()
    combos: dict[str, list[tuple[tuple[str, str], ...]]] = {}
    for codec in dict.fromkeys(codecs):
        codec_obj = get_codec(codec)
        names = [k for k in sweep if k in codec_parameter_names(codec)]
        used.update(names)
        combos[codec] = [tuple(zip(names, values)) for values in product(*(sweep[k] for k in names))]
        for combo in combos[codec]:
            codec_obj.parse_params(dict(combo))
    unused = [k for k in sweep if k not in used]
    if unused:
        known = sorted({f for c in combos for f in codec_parameter_names(c)})
        raise ParameterError(f"parameter {unused[0]!r} is not a parameter of codec(s) {', '.join(combos)}; their "
                             f"parameters: {', '.join(known)}")
    tasks: list[BenchTask] = []
    for clip in clips:
        for rep in dict.fromkeys(representations):
            for codec in combos:
                for combo in combos[codec]:
                    for bound in dict.fromkeys(bounds):
                        tasks.append(BenchTask(len(tasks), clip, codec, rep, bound, combo, seed, decode_poses))
    return tasks


# ---------------------------------------------------------------------------------------------------------------
# rows
# ---------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BenchRow:
    """The result of one run (one row of the table, CSV and JSON; column reference in ``specs/bench.md``).

    Error columns are in file units and in percent of the character height.  For a ``"failed"`` run (bound not
    met) ``error`` and ``error_percent`` hold the best error the codec reached, ``encode_seconds`` the time until
    it gave up, and the size and decode columns are None; for an ``"error"`` run (invalid parameters for this
    clip, unreadable input...) only ``message`` says what happened.
    """

    clip: str
    source: str
    frames: int
    joints: int
    fps: float
    height: float
    units: str | None
    codec: str
    representation: str
    max_error: str | None
    bound: float | None
    params: str
    seed: int
    status: str
    outcome: str
    error: float | None = None
    error_percent: float | None = None
    mean_error: float | None = None
    mean_error_percent: float | None = None
    worst_frame: int | None = None
    worst_joint: str | None = None
    paper_ratio: float | None = None
    bytes_ratio: float | None = None
    file_ratio: float | None = None
    bits_per_joint_frame: float | None = None
    bytes: int | None = None
    parameters: int | None = None
    feature_width: int | None = None
    encode_seconds: float | None = None
    evaluations: int | None = None
    decode_poses: int | None = None
    decode_poses_per_second: float | None = None
    decode_features_per_second: float | None = None
    decode_pose_seconds: float | None = None
    load_average: float | None = None
    info: dict[str, Any] = field(default_factory=dict)
    message: str = ""

    def as_dict(self) -> dict[str, Any]:
        """Every column, JSON-serialisable."""
        return dataclasses.asdict(self)


#: Column names of :class:`BenchRow`, in CSV order.
COLUMNS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(BenchRow))


def _params_text(params: Sequence[tuple[str, str]]) -> str:
    return " ".join(f"{k}={v}" for k, v in params)


def _fmt_num(v: Any) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def outcome_of(info: Mapping[str, Any]) -> str:
    """``K=5`` for the Fourier codecs, ``rank=9`` for svd, ``key=value, ...`` for other codecs."""
    if "windows" in info and isinstance(info.get("K"), list):
        return f"{info['windows']} windows, K={min(info['K'])}-{max(info['K'])}"
    if "K" in info:
        return f"K={info['K']}"
    if "rank" in info:
        return f"rank={info['rank']}"
    return ", ".join(f"{k}={_fmt_num(v)}" for k, v in info.items()
                     if isinstance(v, (int, float, str)) and not isinstance(v, bool)) or "ok"


def _load() -> float | None:
    try:
        return round(os.getloadavg()[0], 2)
    except OSError:  # pragma: no cover - platforms without getloadavg
        return None


def _decode_speed(result, poses: int, seed: int) -> tuple[float | None, float | None, float | None]:
    """Decode speed of a compressed clip at random times: (poses per second in batches, feature vectors per
    second in batches (codec only), median seconds for one pose at an arbitrary time)."""
    from .codec import Payload
    from .compress import fixed_axes_restored
    from .plugins import get_codec, get_representation

    if poses <= 0:
        return None, None, None
    c = result.container
    codec = get_codec(c.codec)
    rep = get_representation(c.representation)
    payload = Payload(arrays=c.arrays, info=c.info)
    rng = np.random.default_rng(seed)

    def decode(times):
        return fixed_axes_restored(rep.from_features(codec.decode(payload, times), c.skeleton, c.fps))

    times = rng.random(poses)
    decode(times[:min(poses, 64)])  # warm up (imports, caches)
    start = time.perf_counter()
    for i in range(0, poses, DECODE_BATCH):
        decode(times[i:i + DECODE_BATCH])
    batch = time.perf_counter() - start
    start = time.perf_counter()
    for i in range(0, poses, DECODE_BATCH):
        codec.decode(payload, times[i:i + DECODE_BATCH])
    features = time.perf_counter() - start
    singles = []
    for t in rng.random(SINGLE_POSE_REPEATS):
        s = time.perf_counter()
        decode(np.array([t]))
        singles.append(time.perf_counter() - s)
    return (poses / batch if batch > 0 else math.inf, poses / features if features > 0 else math.inf,
            statistics.median(singles))


def run_task(task: BenchTask, motion: Motion | None = None) -> BenchRow:
    """Run one task through :func:`~motionrep.compress.compress_motion` (reading the clip unless ``motion`` is
    given) and measure its decode speed.

    A bound that is not met gives a ``"failed"`` row; another :class:`~motionrep.errors.MotionrepError` raised
    while compressing gives an ``"error"`` row.  Errors reading the clip are raised.
    """
    from .compress import compress_motion, parse_max_error
    from .kinematics import character_height

    if motion is None:
        motion = read_clip(task.clip)
    sk = motion.skeleton
    height = character_height(sk)
    limit = parse_max_error(task.max_error)
    bound = None if limit is None or (limit.percent and height <= 0) else limit.bound(height)
    base = dict(clip=task.clip.name, source=task.clip.source, frames=motion.num_frames, joints=sk.num_joints,
                fps=float(motion.fps), height=float(height), units=sk.units, codec=task.codec,
                representation=task.representation, max_error=task.max_error, bound=bound,
                params=_params_text(task.params), seed=task.seed)
    start = time.perf_counter()
    try:
        result = compress_motion(motion, task.codec, representation=task.representation,
                                 max_error=task.max_error, params=dict(task.params), seed=task.seed,
                                 source_bytes=task.clip.source_bytes)
    except BoundNotMetError as exc:
        best = exc.best_error
        pct = None if best is None or height <= 0 else 100.0 * best / height
        text = "failed: best L-inf " + ("unknown" if best is None else
                                        f"{best:.4g}" + ("" if pct is None else f" ({pct:.2f}%)"))
        return BenchRow(**base, status="failed", outcome=text, error=best, error_percent=pct,
                        encode_seconds=time.perf_counter() - start, load_average=_load(), message=str(exc))
    except MotionrepError as exc:
        return BenchRow(**base, status="error", outcome=f"error: {type(exc).__name__}",
                        load_average=_load(), message=str(exc))
    speed, features_speed, single = _decode_speed(result, task.decode_poses, task.seed)
    r, f = result.report, result.figures
    return BenchRow(
        **base, status="ok", outcome=outcome_of(result.container.info),
        error=r.max_error, error_percent=r.max_error_percent, mean_error=r.mean_error,
        mean_error_percent=r.mean_error_percent, worst_frame=r.frame, worst_joint=r.joint,
        paper_ratio=f.paper_ratio, bytes_ratio=f.float32_ratio, file_ratio=f.file_ratio,
        bits_per_joint_frame=f.bits_per_joint_frame, bytes=f.compressed_bytes, parameters=f.num_parameters,
        feature_width=f.feature_width, encode_seconds=result.seconds, evaluations=result.evaluations,
        decode_poses=task.decode_poses or None, decode_poses_per_second=speed,
        decode_features_per_second=features_speed, decode_pose_seconds=single,
        load_average=_load(), info=json.loads(json.dumps(dict(result.container.info))), message="")


def warm_up(threads: int | None = None) -> None:
    """Pay the one-time costs of the shipped neural codecs before anything is timed: importing torch and its
    deterministic-algorithms machinery takes 3-6 s on the first Fourier encode in a process, which would
    otherwise be counted in the encode seconds of whichever run comes first.  ``threads`` sets torch's
    intra-op threads.  Does nothing when torch is not installed."""
    try:
        import torch
    except ImportError:  # pragma: no cover - installs without torch can still bench svd
        return
    if threads is not None:
        torch.set_num_threads(threads)
    state = torch.are_deterministic_algorithms_enabled()
    torch.use_deterministic_algorithms(True)
    torch.use_deterministic_algorithms(state)
    import scipy.fft  # noqa: F401  (the adaptive codec's DCT and line search)
    import scipy.optimize  # noqa: F401


# worker side ---------------------------------------------------------------------------------------------------
_WORKER_CACHE: dict[tuple[str, str | None], Motion] = {}


def _worker_init(warm: bool) -> None:
    if warm:
        warm_up(threads=1)


def _needs_warm_up(tasks: Sequence[BenchTask]) -> bool:
    """Every codec but the pure-numpy ``svd`` may use torch (a third-party codec that does not only pays the
    warm-up once)."""
    return any(t.codec != "svd" for t in tasks)


def _worker_run(task: BenchTask) -> BenchRow:
    """Worker entry point (top level, so it works with the ``spawn`` start method); keeps the last clip read."""
    key = (task.clip.path, task.clip.clip)
    if key not in _WORKER_CACHE:
        _WORKER_CACHE.clear()
        _WORKER_CACHE[key] = read_clip(task.clip)
    return run_task(task, _WORKER_CACHE[key])


def run_bench(tasks: Sequence[BenchTask], *, jobs: int = 1, motions: Mapping[str, Motion] | None = None,
              on_done: Callable[[BenchRow], None] | None = None) -> list[BenchRow]:
    """Run every task, in ``jobs`` spawned worker processes when > 1; rows in task order.

    Args:
        tasks: from :func:`bench_tasks`.
        jobs: worker processes (each with one torch and one BLAS thread).
        motions: clips already read, by clip name (used in this process when ``jobs`` is 1).
        on_done: called with each row as its run finishes (in completion order).
    """
    motions = dict(motions or {})
    rows: dict[int, BenchRow] = {}

    def done(task: BenchTask, row: BenchRow) -> None:
        rows[task.index] = row
        if on_done is not None:
            on_done(row)

    if jobs <= 1 or len(tasks) <= 1:
        if _needs_warm_up(tasks):
            warm_up()
        for task in tasks:
            motion = motions.get(task.clip.name)
            if motion is None:
                motion = motions[task.clip.name] = read_clip(task.clip)
            done(task, run_task(task, motion))
    else:
        import concurrent.futures as cf
        import multiprocessing

        saved = {k: os.environ.get(k) for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
        os.environ.update({k: "1" for k in saved})  # spawned workers inherit one BLAS thread each
        try:
            with cf.ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn"),
                                        initializer=_worker_init, initargs=(_needs_warm_up(tasks),)) as pool:
                futures = {pool.submit(_worker_run, task): task for task in tasks}
                try:
                    for fut in cf.as_completed(futures):
                        done(futures[fut], fut.result())
                except BaseException:
                    pool.shutdown(wait=False, cancel_futures=True)
                    raise
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
    return [rows[t.index] for t in tasks]


# ---------------------------------------------------------------------------------------------------------------
# medians
# ---------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BenchSummary:
    """Medians of one group of runs (one codec, representation, bound and parameter combination) over the runs
    that succeeded; None when none did.

    Attributes:
        runs, ok, failed, errors: how many runs the group has, and how many succeeded, missed the bound, or
            raised an error.
    """

    codec: str
    representation: str
    max_error: str | None
    params: str
    runs: int
    ok: int
    failed: int
    errors: int
    median_error_percent: float | None
    median_paper_ratio: float | None
    median_bytes_ratio: float | None
    median_bits_per_joint_frame: float | None
    median_encode_seconds: float | None
    median_decode_poses_per_second: float | None

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


#: Column names of :class:`BenchSummary`.
SUMMARY_COLUMNS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(BenchSummary))


def _median(values: Iterable[float | None]) -> float | None:
    vals = [float(v) for v in values if v is not None]
    return statistics.median(vals) if vals else None


def summarize(rows: Sequence[BenchRow]) -> list[BenchSummary]:
    """Medians per (codec, representation, bound, parameters), groups in order of first appearance."""
    groups: dict[tuple, list[BenchRow]] = {}
    for r in rows:
        groups.setdefault((r.codec, r.representation, r.max_error, r.params), []).append(r)
    out = []
    for (codec, rep, bound, params), members in groups.items():
        ok = [r for r in members if r.status == "ok"]
        out.append(BenchSummary(
            codec=codec, representation=rep, max_error=bound, params=params, runs=len(members), ok=len(ok),
            failed=sum(r.status == "failed" for r in members), errors=sum(r.status == "error" for r in members),
            median_error_percent=_median(r.error_percent for r in ok),
            median_paper_ratio=_median(r.paper_ratio for r in ok),
            median_bytes_ratio=_median(r.bytes_ratio for r in ok),
            median_bits_per_joint_frame=_median(r.bits_per_joint_frame for r in ok),
            median_encode_seconds=_median(r.encode_seconds for r in ok),
            median_decode_poses_per_second=_median(r.decode_poses_per_second for r in ok)))
    return out


# ---------------------------------------------------------------------------------------------------------------
# the table
# ---------------------------------------------------------------------------------------------------------------
def _f(v: float | None, spec: str) -> str:
    return "-" if v is None else format(v, spec)


def _bound_text(v: str | None) -> str:
    return "none" if v is None else v


def _row_cells(r: BenchRow, reps: bool, params: bool) -> list[str]:
    units = f" {r.units}" if r.units and r.error is not None else ""
    cells = [r.clip, str(r.frames), str(r.joints), r.codec]
    if reps:
        cells.append(r.representation)
    cells.append(_bound_text(r.max_error))
    if params:
        cells.append(r.params or "-")
    cells += [r.outcome, _f(r.error, ".4g") + units, _f(r.error_percent, ".3f"), _f(r.paper_ratio, ".2f"),
              _f(r.bytes_ratio, ".2f"), _f(r.bits_per_joint_frame, ".3f"), _f(r.encode_seconds, ".2f"),
              _f(r.decode_poses_per_second, ",.0f")]
    return cells


def _summary_cells(s: BenchSummary, reps: bool, params: bool) -> list[str]:
    cells = [s.codec]
    if reps:
        cells.append(s.representation)
    cells.append(_bound_text(s.max_error))
    if params:
        cells.append(s.params or "-")
    cells += [f"{s.ok}/{s.runs}", str(s.failed + s.errors), _f(s.median_error_percent, ".3f"),
              _f(s.median_paper_ratio, ".2f"), _f(s.median_bytes_ratio, ".2f"),
              _f(s.median_bits_per_joint_frame, ".3f"), _f(s.median_encode_seconds, ".2f"),
              _f(s.median_decode_poses_per_second, ",.0f")]
    return cells


def _layout(header: list[str], body: list[list[str]], markdown: bool, right: set[int]) -> list[str]:
    if markdown:
        esc = [[c.replace("|", "\\|") for c in row] for row in [header] + body]
        lines = ["| " + " | ".join(esc[0]) + " |",
                 "|" + "|".join("---:" if i in right else "---" for i in range(len(header))) + "|"]
        return lines + ["| " + " | ".join(row) + " |" for row in esc[1:]]
    widths = [max(len(row[i]) for row in [header] + body) for i in range(len(header))]

    def line(row: list[str]) -> str:
        return "  ".join(c.rjust(w) if i in right else c.ljust(w) for i, (c, w) in enumerate(zip(row, widths))).rstrip()

    return [line(header), "  ".join("-" * w for w in widths)] + [line(row) for row in body]


def format_table(rows: Sequence[BenchRow], summaries: Sequence[BenchSummary] | None = None, *,
                 markdown: bool = False) -> str:
    """The runs and, below them, the medians per group, as aligned text (or Markdown tables).

    Columns: clip, frames, joints, codec, (representation when several), bound, (parameters for a sweep),
    outcome, L-inf (file units), L-inf % of height, the paper's ratio, bytes ratio (float32 channels / file
    bytes), bits per joint per frame, encode seconds, decode poses per second.
    """
    summaries = summarize(rows) if summaries is None else summaries
    reps = len({r.representation for r in rows}) > 1
    params = any(r.params for r in rows)
    head = ["clip", "frames", "joints", "codec"] + (["representation"] if reps else []) + ["bound"] + \
        (["params"] if params else []) + ["outcome", "L-inf", "L-inf %", "paper ratio", "bytes ratio",
                                          "bits/joint/frame", "encode s", "decode poses/s"]
    n = len(head)
    right = {1, 2} | set(range(n - 7, n))
    out = _layout(head, [_row_cells(r, reps, params) for r in rows], markdown, right)
    shead = ["codec"] + (["representation"] if reps else []) + ["bound"] + (["params"] if params else []) + \
        ["ok/runs", "failed", "median L-inf %", "paper ratio", "bytes ratio", "bits/joint/frame", "encode s",
         "decode poses/s"]
    m = len(shead)
    out += ["", "Medians over the runs that succeeded (failed: bound not met or error):", ""]
    out += _layout(shead, [_summary_cells(s, reps, params) for s in summaries], markdown, set(range(m - 8, m)))
    return "\n".join(out) + "\n"


# ---------------------------------------------------------------------------------------------------------------
# CSV and JSON
# ---------------------------------------------------------------------------------------------------------------
def _csv_cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, dict):
        return json.dumps(v, sort_keys=True)
    return str(v)


def csv_text(rows: Sequence[BenchRow]) -> str:
    """The rows as CSV text (header :data:`COLUMNS`; floats written exactly, ``repr``; None as an empty cell;
    ``info`` as JSON)."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(COLUMNS)
    for r in rows:
        d = r.as_dict()
        writer.writerow([_csv_cell(d[c]) for c in COLUMNS])
    return buf.getvalue()


def write_csv(rows: Sequence[BenchRow], path: str | os.PathLike[str]) -> None:
    """Write the rows as CSV, atomically."""
    from .io import atomic_path

    with atomic_path(path) as tmp:
        Path(tmp).write_text(csv_text(rows), encoding="utf-8")


_FIELD_TYPES = {f.name: f.type for f in dataclasses.fields(BenchRow)}


def _from_cell(name: str, text: str) -> Any:
    kind = str(_FIELD_TYPES[name])
    if name == "info":
        return json.loads(text) if text else {}
    if text == "" and "None" in kind:
        return None
    if kind.startswith("int"):
        return int(text)
    if kind.startswith("float"):
        return float(text)
    return text


def read_csv(path: str | os.PathLike[str]) -> list[BenchRow]:
    """Read rows written by :func:`write_csv`.

    Raises:
        FormatError: if the header is not :data:`COLUMNS` or a cell does not convert.
    """
    with open(path, newline="", encoding="utf-8") as fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        if header is None or tuple(header) != COLUMNS:
            raise FormatError("not a motionrep bench CSV (unexpected header)", path)
        rows = []
        for line, cells in enumerate(reader, start=2):
            try:
                rows.append(BenchRow(**{c: _from_cell(c, v) for c, v in zip(COLUMNS, cells, strict=True)}))
            except (ValueError, TypeError) as exc:
                raise FormatError(f"bad row: {exc}", path, line) from None
    return rows


def machine_info() -> dict[str, Any]:
    """The machine and software a benchmark ran on: CPU model and count, load average, Python and library
    versions, the date (UTC)."""
    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    versions: dict[str, str | None] = {}
    from importlib import metadata

    for dist in ("motionrep", "numpy", "scipy", "torch", "h5py", "matplotlib"):
        try:
            versions[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            versions[dist] = None
    try:
        load = [round(x, 2) for x in os.getloadavg()]
    except OSError:  # pragma: no cover
        load = None
    return {"date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"), "cpu": cpu,
            "cpus": os.cpu_count(), "load_average": load, "python": platform.python_version(),
            "platform": platform.platform(), "versions": versions}


def bench_json(rows: Sequence[BenchRow], summaries: Sequence[BenchSummary] | None = None,
               settings: Mapping[str, Any] | None = None, machine: Mapping[str, Any] | None = None) -> dict:
    """The JSON document of a benchmark (layout in ``specs/bench.md``)."""
    summaries = summarize(rows) if summaries is None else summaries
    return {"format": BENCH_FORMAT, "format_version": BENCH_VERSION,
            "machine": dict(machine) if machine is not None else machine_info(),
            "settings": dict(settings or {}), "columns": list(COLUMNS), "rows": [r.as_dict() for r in rows],
            "medians": [s.as_dict() for s in summaries]}


def write_json(rows: Sequence[BenchRow], path: str | os.PathLike[str], **kwargs: Any) -> None:
    """Write :func:`bench_json` to ``path``, atomically (non-finite floats as null)."""
    from .io import atomic_path

    doc = _finite(bench_json(rows, **kwargs))
    with atomic_path(path) as tmp:
        Path(tmp).write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n", encoding="utf-8")


def _finite(obj: Any) -> Any:
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    return obj


# ---------------------------------------------------------------------------------------------------------------
# the plot
# ---------------------------------------------------------------------------------------------------------------
def _series_label(r: BenchRow, reps: bool) -> str:
    return f"{r.codec} / {r.representation}" if reps else r.codec


_RATIOS = {"paper_ratio": "compression ratio (Tojo et al.: frames x features / stored parameters)",
           "bytes_ratio": "bytes ratio (BVH channels as float32 / .mrc bytes)"}


def plot_series(rows: Sequence[BenchRow], ratio: str = "paper_ratio") -> dict[str, list[tuple[float, float]]]:
    """The points :func:`plot_rate_distortion` draws: ``{series: [(ratio, error_percent), ...]}`` for the runs
    that succeeded, in row order; one series per codec (per codec and representation when the rows have several
    representations).  ``ratio`` is ``"paper_ratio"`` or ``"bytes_ratio"``."""
    if ratio not in _RATIOS:
        raise ParameterError(f"ratio must be one of {', '.join(_RATIOS)}, got {ratio!r}")
    reps = len({r.representation for r in rows}) > 1
    out: dict[str, list[tuple[float, float]]] = {}
    for r in rows:
        x = getattr(r, ratio)
        if r.status == "ok" and x is not None and r.error_percent is not None:
            out.setdefault(_series_label(r, reps), []).append((x, r.error_percent))
    return out


def plain_log_ticks(axis) -> None:
    """Label a log-scaled matplotlib ``axis`` with plain numbers (``2``, ``5``, ``10``, ``20`` ...) rather than
    ``2 x 10^0``: powers of ten and the 2x and 5x minor ticks are labelled, the other minor ticks are not."""
    from matplotlib.ticker import FuncFormatter

    def label(v, _pos, minor=False):
        if v <= 0:
            return ""
        lead = round(v / 10 ** math.floor(math.log10(v) + 1e-9), 6)
        if minor and lead not in (2.0, 5.0):
            return ""
        return f"{v:g}"

    axis.set_major_formatter(FuncFormatter(label))
    axis.set_minor_formatter(FuncFormatter(lambda v, pos: label(v, pos, minor=True)))


def plot_rate_distortion(rows: Sequence[BenchRow], path: str | os.PathLike[str], *, title: str | None = None,
                         log_error: bool | None = None, ratio: str = "paper_ratio"
                         ) -> dict[str, list[tuple[float, float]]]:
    """Draw error (% of character height) against the paper's compression ratio, one series per codec and one
    marker per run (Tojo et al. 2022, Fig. 3 style), and write it to ``path`` (``.png``, ``.svg`` or ``.pdf``)
    atomically.

    Runs of the same parameter values (a sweep) are joined by a line through their medians; a bound given in
    percent is drawn as a dashed horizontal line.  Failed runs are not drawn (they have no ratio); the legend
    counts them.

    Args:
        rows: the runs.
        path: the picture.
        title: a title (default: a summary of the clips).
        log_error: logarithmic error axis; default: when the errors drawn span more than a factor of 20 (the
            ratio axis is logarithmic when the ratios span more than a factor of 20).
        ratio: the horizontal axis: ``"paper_ratio"`` (default) or ``"bytes_ratio"`` (which does not depend on
            the representation's width, for comparing representations).

    Returns:
        The points drawn, as :func:`plot_series`.

    Raises:
        MotionrepError: matplotlib is not installed.
        FormatError: for an unsupported suffix.
    """
    from .io import atomic_path

    suffix = Path(path).suffix.lower()
    if suffix not in (".png", ".svg", ".pdf"):
        raise FormatError(f"cannot draw a plot as {suffix or '(no suffix)'!r}; use .png, .svg or .pdf", path)
    series = plot_series(rows, ratio)
    Figure, FigureCanvasAgg = _matplotlib()
    reps = len({r.representation for r in rows}) > 1
    fig = Figure(figsize=(7.5, 5.0), dpi=120)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    colours = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"]
    markers = ["o", "s", "^", "D", "v", "P", "X", "*"]
    labels = list(dict.fromkeys(_series_label(r, reps) for r in rows))
    all_y: list[float] = []
    for i, label in enumerate(labels):
        pts = series.get(label, [])
        members = [r for r in rows if _series_label(r, reps) == label]
        missed = sum(r.status != "ok" for r in members)
        colour, marker = colours[i % len(colours)], markers[i % len(markers)]
        text = f"{label} ({len(pts)} runs" + (f", {missed} failed" if missed else "") + ")"
        if pts:
            xs, ys = zip(*pts)
            all_y += ys
            ax.scatter(xs, ys, s=18, alpha=0.55, color=colour, marker=marker, label=text, linewidths=0)
        else:
            ax.scatter([], [], color=colour, marker=marker, label=text)
        # a line through the medians of each sweep value
        groups: dict[str, list[BenchRow]] = {}
        for r in members:
            if r.status == "ok" and r.params:
                groups.setdefault(f"{r.max_error}|{r.params}", []).append(r)
        if len(groups) > 1:
            med = sorted((statistics.median(getattr(r, ratio) for r in g),
                          statistics.median(r.error_percent for r in g)) for g in groups.values())
            ax.plot([m[0] for m in med], [m[1] for m in med], color=colour, linewidth=1.5, alpha=0.9)
    for bound in dict.fromkeys(r.max_error for r in rows):
        if bound is not None and bound.endswith("%"):
            ax.axhline(float(bound[:-1]), color="0.4", linestyle="--", linewidth=0.8)
            ax.annotate(f"bound {bound}", xy=(1.0, float(bound[:-1])), xycoords=("axes fraction", "data"),
                        xytext=(-4, 2), textcoords="offset points", ha="right", fontsize=7, color="0.3")
    positive = [y for y in all_y if y > 0]
    if log_error is None:
        log_error = bool(positive) and max(positive) / min(positive) > 20
    if log_error and positive:
        ax.set_yscale("log")
        plain_log_ticks(ax.yaxis)
    ratios = [x for pts in series.values() for x, _ in pts if x > 0]
    if ratios and max(ratios) / min(ratios) > 20:
        ax.set_xscale("log")
        plain_log_ticks(ax.xaxis)
    ax.set_xlabel(_RATIOS[ratio])
    ax.set_ylabel("L-inf joint position error (% of character height)")
    clips = list(dict.fromkeys(r.clip for r in rows))
    ax.set_title(title or (clips[0] if len(clips) == 1 else f"{len(clips)} clips"), fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=suffix[1:])
    return series


def _matplotlib() -> Any:
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise MotionrepError("drawing plots needs matplotlib, which is not installed: "
                             "pip install 'motionrep[plot]'") from None
    return Figure, FigureCanvasAgg
