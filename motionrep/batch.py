"""The batch engine: the one way many clips are worked on (``compress`` of many clips, ``bench``, ``evaluate`` of
two databases), with one worker pool and one thread policy.

:func:`run_batch` runs ``work(item)`` for every item and returns the results in item order:

* ``jobs=1`` (and no executor): in this process, one item after the other;
* ``jobs=N``: in ``N`` worker processes (a ``ProcessPoolExecutor`` with the ``spawn`` start method, the same on
  every platform);
* ``executor=``: on any :class:`concurrent.futures.Executor` the caller owns (a Dask cluster's
  ``Client.get_executor()``, a pool shared by several runs); it is not shut down.

``work`` and the items must pickle when they run in other processes (``work`` a module-level function).

Thread policy, the same for every command: the parent process keeps its threads; every *worker process* (of
the pool, or of any executor whose workers are other processes) runs with one BLAS thread (``threadpoolctl``
and the ``OPENBLAS/OMP/MKL_NUM_THREADS`` variables its spawned children inherit) and warms up the codecs named
in ``warm_up`` (``Codec.warm_up``: imports that would otherwise be counted in the first clip's time) once,
before its first item.  ``jobs`` workers of one thread each use ``jobs`` cores, and a result never depends on
how many threads computed it.

:func:`compress_clips` and :func:`evaluate_clips` are the batch jobs of ``motionrep compress`` and ``motionrep
evaluate``; ``motionrep bench`` runs :func:`motionrep.bench.run_bench` on the same engine.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import os
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Iterator, Sequence, TypeVar

from ._model import Motion
from .errors import FormatError, MotionrepError, ParameterError
from .sources import ClipRef, Source, listing

__all__ = ["run_batch", "worker_threads", "read_clip", "ClipOutcome", "compress_clips", "pair_clips",
           "evaluate_clips", "THREAD_VARIABLES"]

_Item = TypeVar("_Item")
_Result = TypeVar("_Result")

#: Environment variables that set the thread count of the BLAS libraries numpy and scipy may use.
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")

_WORKER: dict[str, Any] = {"pid": None, "warmed": set(), "limits": None}


def _prepare_worker(parent: int, warm_up: tuple[str, ...]) -> None:
    """The thread policy and warm-up, once per worker process (nothing in the parent process)."""
    pid = os.getpid()
    if pid == parent:
        return
    if _WORKER["pid"] != pid:
        _WORKER.update(pid=pid, warmed=set(), limits=None)
        try:
            from threadpoolctl import threadpool_limits

            _WORKER["limits"] = threadpool_limits(limits=1)  # kept: the limit holds for the process's life
        except ImportError:  # pragma: no cover - threadpoolctl is a dependency; the variables still apply
            pass
    todo = [name for name in warm_up if name not in _WORKER["warmed"]]
    if todo:
        from .plugins import get_codec

        for name in todo:
            get_codec(name).warm_up()
            _WORKER["warmed"].add(name)


def _call(work: Callable[[Any], Any], item: Any, parent: int, warm_up: tuple[str, ...]) -> Any:
    """Worker entry point (module level, so it pickles)."""
    _prepare_worker(parent, warm_up)
    return work(item)


@contextlib.contextmanager
def worker_threads(count: int = 1) -> Iterator[None]:
    """Set :data:`THREAD_VARIABLES` to ``count`` while the block runs (worker processes spawned inside it start
    with that many BLAS threads), then restore them."""
    saved = {k: os.environ.get(k) for k in THREAD_VARIABLES}
    os.environ.update({k: str(count) for k in THREAD_VARIABLES})
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def run_batch(work: Callable[[_Item], _Result], items: Iterable[_Item], *, jobs: int = 1,
              executor: cf.Executor | None = None, warm_up: Iterable[str] = (),
              on_done: Callable[[int, _Item, _Result], None] | None = None) -> list[_Result]:
    """``[work(item) for item in items]``, in this process, in ``jobs`` worker processes, or on ``executor``.

    Args:
        work: the function run on each item (module level when it runs in other processes).
        items: the items.
        jobs: worker processes when no executor is given (1: in this process).
        executor: an executor to submit to instead (not shut down).
        warm_up: names of codecs whose ``warm_up()`` runs before the first item (once per worker process).
        on_done: called as ``on_done(index, item, result)`` when an item finishes, in completion order.

    Returns:
        The results, in item order.

    Raises:
        Whatever ``work`` raises (pending items are cancelled first).
    """
    items = list(items)
    warm = tuple(dict.fromkeys(warm_up))
    results: dict[int, Any] = {}

    def done(index: int, result: Any) -> None:
        results[index] = result
        if on_done is not None:
            on_done(index, items[index], result)

    if executor is None and (jobs <= 1 or len(items) <= 1):
        if warm:
            from .plugins import get_codec

            for name in warm:
                get_codec(name).warm_up()
        for index, item in enumerate(items):
            done(index, work(item))
        return [results[i] for i in range(len(items))]
    with contextlib.ExitStack() as stack:
        if executor is None:
            import multiprocessing

            stack.enter_context(worker_threads(1))
            executor = stack.enter_context(cf.ProcessPoolExecutor(
                max_workers=min(jobs, len(items)), mp_context=multiprocessing.get_context("spawn")))
        parent = os.getpid()
        futures = {executor.submit(_call, work, item, parent, warm): i for i, item in enumerate(items)}
        try:
            for future in cf.as_completed(futures):
                done(futures[future], future.result())
        except BaseException:
            for future in futures:
                future.cancel()
            raise
    return [results[i] for i in range(len(items))]


# ---------------------------------------------------------------------------------------------------------------
# reading clips in workers
# ---------------------------------------------------------------------------------------------------------------
_LAST: dict[str, Any] = {"key": None, "motion": None}


def read_clip(ref: ClipRef) -> Motion:
    """Read ``ref``.  A worker process keeps the last clip it read (a worker given several runs of one clip in a
    row reads it once); the parent process, whose files may change between runs, always reads."""
    if _WORKER["pid"] != os.getpid():
        return ref.read()
    key = (ref.path, ref.clip)
    if _LAST["key"] != key:
        _LAST.update(key=None, motion=None)
        _LAST.update(key=key, motion=ref.read())
    return _LAST["motion"]


# ---------------------------------------------------------------------------------------------------------------
# compress many clips
# ---------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ClipOutcome:
    """What compressing one clip of a batch gave.

    Attributes:
        name: the clip's name.
        data: the ``.mrc`` bytes, or None when it failed.
        summary: ``CompressResult.as_dict()``, or ``{"error": message, "type": exception class name}``.
    """

    name: str
    data: bytes | None
    summary: dict[str, Any]

    @property
    def failed(self) -> bool:
        return self.data is None


def _compress_one(job: tuple[ClipRef, Any]) -> ClipOutcome:
    ref, pipeline = job
    try:
        result = pipeline.compress(read_clip(ref), source_bytes=ref.source_bytes)
    except MotionrepError as exc:
        return ClipOutcome(ref.name, None, {"error": str(exc), "type": type(exc).__name__})
    return ClipOutcome(ref.name, result.data, result.as_dict())


def compress_clips(refs: Sequence[ClipRef], pipeline: Any, *, jobs: int = 1, executor: cf.Executor | None = None,
                   on_done: Callable[[ClipOutcome], None] | None = None) -> list[ClipOutcome]:
    """Compress every clip with ``pipeline`` (a :class:`motionrep.compress.Pipeline`); a clip that fails (bound
    not met, unreadable) gives a failed :class:`ClipOutcome` and the others go on.

    Returns:
        One outcome per clip, in ``refs`` order; ``on_done(outcome)`` is called as each finishes.
    """
    return run_batch(_compress_one, [(ref, pipeline) for ref in refs], jobs=jobs, executor=executor,
                     warm_up=[pipeline.codec.name],
                     on_done=None if on_done is None else (lambda i, item, outcome: on_done(outcome)))


# ---------------------------------------------------------------------------------------------------------------
# evaluate two sources clip by clip
# ---------------------------------------------------------------------------------------------------------------
def pair_clips(reference: Source, candidate: Source, clip: str | None = None) -> list[tuple[str, str, str]]:
    """The clips to compare between two sources, as ``(name, reference clip, candidate clip)``.

    A file of one clip is compared with the other file's only clip (or with its clip ``clip``); two databases or
    archives are compared clip by clip, by name (only ``clip`` when given).

    Raises:
        FormatError: when ``clip`` is not in a database or archive given, or two databases hold different clips.
        ParameterError: when one file holds several clips and the other one, and no ``clip`` says which.
    """
    def names(src: Source) -> list[str]:
        if src.kind in ("database", "archive") and clip is not None:
            return [src.resolve(clip)]
        return src.names

    ref_names, cand_names = names(reference), names(candidate)
    if len(ref_names) == 1 and len(cand_names) == 1:
        return [(ref_names[0], ref_names[0], cand_names[0])]
    if len(ref_names) > 1 and len(cand_names) > 1:
        missing = [n for n in ref_names if n not in cand_names]
        extra = [n for n in cand_names if n not in ref_names]
        if missing or extra:
            where = "; ".join(part for part in (
                f"only in {reference.path}: {listing(missing)}" if missing else "",
                f"only in {candidate.path}: {listing(extra)}" if extra else "") if part)
            raise FormatError(f"the two files hold different clips ({where}); use --clip NAME to compare one",
                              candidate.path)
        return [(n, n, n) for n in ref_names]
    many, found = (reference, ref_names) if len(ref_names) > 1 else (candidate, cand_names)
    raise ParameterError(f"{many.path} holds {len(found)} clips ({listing(found)}) and the other file one; "
                         "use --clip NAME")


def evaluate_clips(reference: Source, candidate: Source, pairs: Sequence[tuple[str, str, str]],
                   on_done: Callable[[str, Any], None] | None = None) -> list[tuple[str, Any]]:
    """The shared error of every pair ``(name, reference clip, candidate clip)``, read from the two open sources
    (each file opened once), in this process.

    Returns:
        ``[(name, ErrorReport)]`` in ``pairs`` order.
    """
    from .evaluate import max_joint_error

    def work(pair: tuple[str, str, str]) -> tuple[str, Any]:
        name, ref_clip, cand_clip = pair
        return name, max_joint_error(reference.read(ref_clip), candidate.read(cand_clip))

    return run_batch(work, pairs,
                     on_done=None if on_done is None else (lambda i, pair, result: on_done(*result)))
