"""Running a benchmark: every task through the compression pipeline, then its decode speed; many tasks on the
batch engine (:func:`motionrep.batch.engine.run_batch`).

Every run goes through :meth:`motionrep.pipeline.compress.Pipeline.compress`, so what is measured is what ``motionrep
compress`` would write.  A bound the codec cannot meet is an outcome (a ``"failed"`` row with the best error
reached), not an error.  Encode seconds are taken after the codec's warm-up (``Codec.warm_up``); decode speed
is measured by :func:`decode_speed` through the one decode path, :func:`motionrep.pipeline.compress.decode_at`.
"""

from __future__ import annotations

import concurrent.futures as cf
import json
import math
import os
import statistics
import time
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ...model._pose import Motion
from ...errors import BoundNotMetError, MotionrepError
from ...formats import suffix_format
from .grid import BenchTask
from .report import BenchRow

__all__ = ["DECODE_BATCH", "SINGLE_POSE_REPEATS", "decode_speed", "xz_size", "run_task", "run_bench"]

#: Poses decoded per call when measuring throughput.
DECODE_BATCH = 8192
#: Single-pose decodes whose median is ``decode_pose_seconds``.
SINGLE_POSE_REPEATS = 25


def _params_text(params: Sequence[tuple[str, str]]) -> str:
    return " ".join(f"{k}={v}" for k, v in params)


def _load() -> float | None:
    try:
        return round(os.getloadavg()[0], 2)
    except OSError:  # pragma: no cover - platforms without getloadavg
        return None


def decode_speed(container: Any, poses: int, seed: int) -> tuple[float | None, float | None, float | None]:
    """Decode speed of a compressed clip at ``poses`` uniformly random times: (poses per second in batches of
    :data:`DECODE_BATCH` through :func:`~motionrep.pipeline.compress.decode_at`, feature vectors per second in batches
    (the codec alone), median seconds for one pose at an arbitrary time); Nones when ``poses`` is 0."""
    from ...plugin.codec import Payload
    from ...pipeline.compress import decode_at
    from ...plugin.registry import get_codec, get_representation

    if poses <= 0:
        return None, None, None
    c = container
    codec = get_codec(c.codec, version=c.codec_version)
    rep = get_representation(c.representation, version=c.representation_version)
    payload = Payload(arrays=c.arrays, info=c.info, version=c.codec_version)
    rng = np.random.default_rng(seed)

    def decode(times: np.ndarray) -> Motion:
        return decode_at(c, times, codec=codec, representation=rep)

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


_XZ_CACHE: dict[tuple, int] = {}


def xz_size(clip: Any, motion: Motion) -> int:
    """Bytes of ``xz -9`` (``lzma``, preset 9, the xz container) of what anyone could compress without motionrep:
    the clip's source file when it is a whole BVH file, otherwise the clip written as BVH text (6 decimals).
    Remembered per file (size and modification time) and clip, so each is compressed once per process."""
    import lzma
    from pathlib import Path

    path = Path(clip.path)
    try:
        stat = path.stat()
        key: tuple = (str(path.resolve()), clip.clip, stat.st_size, stat.st_mtime_ns)
    except OSError:
        key = (str(path), clip.clip, None, None)
    if key not in _XZ_CACHE:
        if clip.clip is None and suffix_format(path) == "bvh":
            data = path.read_bytes()
        else:
            from ...io import format_bvh

            data = format_bvh(motion).encode("utf-8")
        _XZ_CACHE[key] = len(lzma.compress(data, format=lzma.FORMAT_XZ, preset=9))
    return _XZ_CACHE[key]


def run_task(task: BenchTask, motion: Motion | None = None) -> BenchRow:
    """Run one task (reading its clip unless ``motion`` is given) and measure its decode speed.

    A bound that is not met gives a ``"failed"`` row; another :class:`~motionrep.errors.MotionrepError` raised
    while compressing gives an ``"error"`` row.  Errors reading the clip are raised.
    """
    from ...model.kinematics import character_height

    if motion is None:
        motion = task.clip.read()
    sk = motion.skeleton
    height = character_height(sk)
    try:
        limit = task.resolved().max_error
    except MotionrepError:  # a setting that does not build: an "error" row below
        limit = None
    bound = None if limit is None or (limit.percent and height <= 0) else limit.bound(height)
    base = dict(clip=task.clip.name, source=task.clip.source, frames=motion.num_frames, joints=sk.num_joints,
                fps=float(motion.fps), height=float(height), units=sk.units, codec=task.codec,
                representation=task.representation, max_error=task.max_error, bound=bound,
                params=_params_text(task.params), seed=task.seed)
    try:
        xz = xz_size(task.clip, motion)
    except (OSError, MotionrepError):  # a clip BVH cannot hold: no xz baseline
        xz = None
    start = time.perf_counter()
    try:
        result = task.resolved().compress(motion, source_bytes=task.clip.source_bytes)
    except BoundNotMetError as exc:
        best = exc.best_error
        pct = None if best is None or height <= 0 else 100.0 * best / height
        text = "failed: best L-inf " + ("unknown" if best is None else
                                        f"{best:.4g}" + ("" if pct is None else f" ({pct:.2f}%)"))
        return BenchRow(**base, status="failed", outcome=text, error=best, error_percent=pct,
                        encode_seconds=time.perf_counter() - start, load_average=_load(), message=str(exc),
                        mentions=exc.parameters, xz_bytes=xz)
    except MotionrepError as exc:
        return BenchRow(**base, status="error", outcome=f"error: {type(exc).__name__}",
                        load_average=_load(), message=str(exc), mentions=exc.parameters, xz_bytes=xz)
    speed, features_speed, single = decode_speed(result.container, task.decode_poses, task.seed)
    r, f = result.report, result.figures
    return BenchRow(
        **base, status="ok", outcome=result.outcome,
        error=r.max_error, error_percent=r.max_error_percent, mean_error=r.mean_error,
        mean_error_percent=r.mean_error_percent, worst_frame=r.frame, worst_joint=r.joint,
        paper_ratio=f.paper_ratio, bytes_ratio=f.float32_ratio, file_ratio=f.file_ratio,
        bits_per_joint_frame=f.bits_per_joint_frame, bytes=f.compressed_bytes, parameters=f.num_parameters,
        payload_bytes=f.payload_bytes, bits_per_bone_frame=f.bits_per_bone_frame,
        payload_bits_per_bone_frame=f.payload_bits_per_bone_frame,
        file_bits_per_bone_frame=f.file_bits_per_bone_frame, ratio_vs_source=f.ratio_vs_source,
        feature_width=f.feature_width, encode_seconds=result.seconds, evaluations=result.evaluations,
        decode_poses=task.decode_poses or None, decode_poses_per_second=speed,
        decode_features_per_second=features_speed, decode_pose_seconds=single,
        load_average=_load(), info=json.loads(json.dumps(dict(result.container.info))), message="",
        xz_bytes=xz, xz_ratio=None if xz is None else xz / f.compressed_bytes)


def _run_in_worker(task: BenchTask) -> BenchRow:
    """Worker entry point: the clip is read once for a run of tasks on it (:func:`motionrep.batch.engine.read_clip`)."""
    from ...batch.engine import read_clip

    return run_task(task, read_clip(task.clip))


def run_bench(tasks: Sequence[BenchTask], *, jobs: int = 1, motions: Mapping[str, Motion] | None = None,
              on_done: Callable[[BenchRow], None] | None = None,
              executor: cf.Executor | None = None) -> list[BenchRow]:
    """Run every task on the batch engine (in this process, in ``jobs`` worker processes, or on ``executor``);
    rows in task order.

    Args:
        tasks: from :func:`~motionrep.present.bench.bench_tasks`.
        jobs: worker processes (each with one BLAS thread; see :mod:`motionrep.batch.engine`).
        motions: clips already read, by clip name (used when the tasks run in this process).
        on_done: called with each row as its run finishes (in completion order).
        executor: a :class:`concurrent.futures.Executor` to run on instead.
    """
    from ...batch.engine import run_batch

    codecs = [t.codec for t in tasks]
    done = None if on_done is None else (lambda i, task, row: on_done(row))
    if executor is None and (jobs <= 1 or len(tasks) <= 1):
        cache = dict(motions or {})

        def in_process(task: BenchTask) -> BenchRow:
            if task.clip.name not in cache:
                cache[task.clip.name] = task.clip.read()
            return run_task(task, cache[task.clip.name])

        return run_batch(in_process, tasks, warm_up=codecs, on_done=done)
    return run_batch(_run_in_worker, tasks, jobs=jobs, executor=executor, warm_up=codecs, on_done=done)
