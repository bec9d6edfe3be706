"""The batch engine: the one way many clips are worked on (``compress`` of many clips, ``bench``, ``evaluate`` of
two databases), with one worker pool and one thread policy.

:func:`run_batch` runs ``work(item)`` for every item and returns the results in item order:

* ``jobs=1`` (and no executor): in this process, one item after the other;
* ``jobs=N``: in ``N`` worker processes (a ``pebble.ProcessPool`` with the ``spawn`` start method, the same on
  every platform, its workers started with Ctrl-C ignored and stopped at once when the run is interrupted; an item
  over its time limit has its worker killed and replaced);
* ``executor=``: on any :class:`concurrent.futures.Executor` the caller owns (a Dask cluster's
  ``Client.get_executor()``, :func:`motionrep.batch.executors.dask_executor`; a pool shared by several runs); it is
  not shut down.

Results come back to the calling process, in completion order, through ``on_done``: the one writer of a batch's
output (:mod:`motionrep.batch.store`) lives there.  ``work`` and the items must pickle when they run in other
processes (``work`` a module-level function).

Thread policy, the same for every command: the parent process keeps its threads; every *worker process* (of
the pool, or of any executor whose workers are other processes) runs with one BLAS thread (``threadpoolctl``
and the ``OPENBLAS/OMP/MKL_NUM_THREADS`` variables its spawned children inherit) and warms up the codecs named
in ``warm_up`` (``Codec.warm_up``: imports that would otherwise be counted in the first clip's time) once,
before its first item.  ``jobs`` workers of one thread each use ``jobs`` cores, and a result never depends on
how many threads computed it.

:func:`compress_clips` (with ``--resume`` checksums and ``--timeout``) and :func:`evaluate_clips` /
:func:`evaluate_refs` are the batch jobs of ``motionrep compress`` and ``motionrep evaluate``; ``motionrep
bench`` runs :func:`motionrep.present.bench.run_bench` on the same engine.

A batch survives its worst clip: with ``on_error`` (``compress_clips`` passes one), whatever one item raises,
in this process or a worker, is that item's result, and a worker process that dies breaks only its item (pebble
starts another worker; should the whole pool break, it is started again and the items that were running are run
again one at a time to find the one).  The per-clip result of :func:`compress_clips` is typed, a
:class:`ClipOutcome` carrying the :class:`~motionrep.pipeline.compress.CompressResult`.

Size: one concern, running many clips' work; the pool supervision (failures, a broken pool, interrupts, the
progress relay) and the batch jobs built on it stay together because each job's failure outcome is what the
supervision returns; the pairing of two collections' clips (``evaluate`` of two databases, ``--common``) shares
the clip naming and the one way results come back.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
from concurrent.futures.process import BrokenProcessPool
import os
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable, Collection, Iterable, Iterator, Sequence, TypeVar

from ..model._pose import Motion
from ..errors import FormatError, MotionrepError, ParameterError, naming
from .executors import (THREAD_VARIABLES, WorkerProgress, _ignore_interrupts, _process_pool, _stop_pool, dask_executor,
                        progress_relay, time_limit, time_limit_error, worker_threads)
from ..pipeline.sources import ClipRef, Source, listing

if TYPE_CHECKING:
    from ..pipeline.compress import CompressResult

__all__ = ["run_batch", "worker_threads", "read_clip", "ClipOutcome", "ClipFailure", "ClipJob", "compress_clips", "pair_clips",
           "pair_refs", "clip_sets", "evaluate_clips", "evaluate_refs",
           "THREAD_VARIABLES", "dask_executor", "time_limit"]


_Item = TypeVar("_Item")
_Result = TypeVar("_Result")

_WORKER: dict[str, Any] = {"pid": None, "warmed": set(), "limits": None}


def _prepare_worker(parent: int, warm_up: tuple[str, ...]) -> None:
    """The thread policy and warm-up, once per worker process (nothing in the parent process)."""
    pid = os.getpid()
    if pid == parent:
        return
    if _WORKER["pid"] != pid:
        _WORKER.update(pid=pid, warmed=set(), limits=None)
        _ignore_interrupts()
        try:
            from threadpoolctl import threadpool_limits

            _WORKER["limits"] = threadpool_limits(limits=1)  # kept: the limit holds for the process's life
        except ImportError:  # pragma: no cover - threadpoolctl is a dependency; the variables still apply
            pass
    todo = [name for name in warm_up if name not in _WORKER["warmed"]]
    if todo:
        from ..plugin.registry import get_codec

        for name in todo:
            get_codec(name).warm_up()
            _WORKER["warmed"].add(name)


def _call(work: Callable[[Any], Any], item: Any, parent: int, warm_up: tuple[str, ...],
          timeout: float | None = None) -> Any:
    """Worker entry point (module level, so it pickles); ``timeout``: the item's limit, raised in this thread
    (:func:`~motionrep.batch.executors.time_limit`; on an executor whose workers cannot be killed for it)."""
    _prepare_worker(parent, warm_up)
    with time_limit(timeout):
        return work(item)


class _WorkerDied(Exception):
    """A pool worker died while running an item (``pebble.ProcessExpired``); reported as a ``BrokenProcessPool``,
    the one exception a batch gives for a dead worker, for that item only."""


def _worker_died(exc: BaseException) -> _WorkerDied:
    code = getattr(exc, "exitcode", None)
    return _WorkerDied(f"its worker process died{'' if code is None else f' (exit code {code})'}")


def run_batch(work: Callable[[_Item], _Result], items: Iterable[_Item], *, jobs: int = 1,
              executor: cf.Executor | None = None, warm_up: Iterable[str] = (),
              on_done: Callable[[int, _Item, _Result], None] | None = None,
              window: int | None = None, relay: Any = None,
              on_error: Callable[[_Item, Exception], _Result] | None = None,
              timeout: float | None = None) -> list[_Result]:
    """``[work(item) for item in items]``, in this process, in ``jobs`` worker processes, or on ``executor``.

    Args:
        work: the function run on each item (module level when it runs in other processes).
        items: the items (an iterator is consumed as the work goes, see ``window``).
        jobs: worker processes when no executor is given (1: in this process).
        executor: an executor to submit to instead (not shut down).
        warm_up: names of codecs whose ``warm_up()`` runs before the first item (once per worker process).
        on_done: called as ``on_done(index, item, result)`` when an item finishes, in completion order, in this
            process.
        window: at most this many items submitted and not finished at once (None: all at once); items are taken
            from ``items`` only as they are submitted, so large items (clip bytes) are not all in memory.
        relay: the queue of :func:`motionrep.batch.executors.progress_relay` the pool's workers report progress on.
        on_error: with it, an item whose work raises (any ``Exception``, in this process or a worker) or whose
            worker process dies gives ``on_error(item, exception)`` as its result and the others go on (a dead
            worker's exception is a ``BrokenProcessPool``).  When the whole pool breaks, it is started again and
            the items that were running are run again one at a time, so that only the one that breaks it fails.
        timeout: seconds each item may take, raising :class:`~motionrep.errors.TimeLimitError` (its ``on_error``
            result) when over: in worker processes the item's worker is killed (and another started); in this
            process and on an executor, the limit is raised in the thread doing the work
            (:func:`~motionrep.batch.executors.time_limit`).

    Returns:
        The results, in item order.

    Raises:
        Whatever ``work`` raises, and KeyboardInterrupt: pending items are cancelled first, and the worker
        processes of the embedded pool are stopped at once.
    """
    warm = tuple(dict.fromkeys(warm_up))
    results: dict[int, Any] = {}
    workers = jobs
    if window is None:
        listed = list(items)
        workers = min(jobs, len(listed))
        source: Iterator[Any] = iter(listed)
    else:
        source = iter(items)

    if executor is None and workers <= 1:
        if warm:
            from ..plugin.registry import get_codec

            for name in warm:
                get_codec(name).warm_up()
        for index, item in enumerate(source):
            try:
                with time_limit(timeout):
                    results[index] = result = work(item)
            except Exception as exc:
                if on_error is None:
                    raise
                results[index] = result = on_error(item, exc)
            if on_done is not None:
                on_done(index, item, result)
        return [results[i] for i in range(len(results))]
    from pebble import ProcessExpired

    parent = os.getpid()
    with contextlib.ExitStack() as stack:
        pool = None
        if executor is None:
            stack.enter_context(worker_threads(1))
            pools = stack.enter_context(contextlib.ExitStack())
            pool = pools.enter_context(_process_pool(workers, relay, _prepare_worker, (parent, warm)))
        pending: dict[cf.Future, tuple[int, Any]] = {}
        suspects: list[tuple[int, Any]] = []  # items running when the pool broke: run again one at a time
        next_index = 0

        alone = False  # the one item pending is a suspect running alone

        def submit(item: Any) -> cf.Future:
            if pool is not None:  # the pool kills a worker over its limit
                return pool.schedule(_call, (work, item, parent, warm), timeout=timeout)
            return executor.submit(_call, work, item, parent, warm, timeout)

        def submit_more() -> None:
            nonlocal next_index, alone
            if suspects:
                if not pending:
                    index, item = suspects.pop(0)
                    pending[submit(item)] = (index, item)
                    alone = True
                return
            alone = False
            while window is None or len(pending) < window:
                try:
                    item = next(source)
                except StopIteration:
                    return
                pending[submit(item)] = (next_index, item)
                next_index += 1

        def restart() -> None:
            nonlocal pool, pools
            pools.close()  # the broken pool: its surviving workers are stopped
            pools = stack.enter_context(contextlib.ExitStack())
            pool = pools.enter_context(_process_pool(workers, relay, _prepare_worker, (parent, warm)))

        try:
            submit_more()
            while pending:
                finished, _ = cf.wait(list(pending), return_when=cf.FIRST_COMPLETED)
                broken = False
                for future in finished:
                    index, item = pending.pop(future)
                    try:
                        try:
                            result = future.result()
                        except ProcessExpired as exc:  # its worker died: this item's failure only
                            raise _worker_died(exc) from None
                        except TimeoutError:  # the pool killed its worker, over the limit
                            if pool is None or not timeout:
                                raise
                            raise time_limit_error(timeout) from None
                    except _WorkerDied as exc:
                        if on_error is None:
                            raise BrokenProcessPool(str(exc)) from None
                        result = on_error(item, BrokenProcessPool(str(exc)))
                    except BrokenProcessPool as exc:  # the whole pool broke
                        if on_error is None or pool is None:
                            raise
                        broken = True
                        if not alone:  # several ran: find the one that breaks it, running them alone
                            suspects.append((index, item))
                            continue
                        result = on_error(item, exc)  # it ran alone: it is the one
                    except Exception as exc:
                        if on_error is None:
                            raise
                        result = on_error(item, exc)
                    results[index] = result
                    if on_done is not None:
                        on_done(index, item, result)
                if broken:
                    suspects.extend(pending.values())
                    suspects.sort(key=lambda pair: pair[0])
                    pending.clear()
                    restart()
                submit_more()
        except BaseException:
            for future in pending:
                future.cancel()
            if pool is not None:
                _stop_pool(pool)
            raise
    return [results[i] for i in range(len(results))]


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
class ClipFailure:
    """Why one clip of a batch failed.

    Attributes:
        message: one line naming the clip's source and what happened (a library error names parameters, not
            flags: ``parameters`` lists its mentions, which the command line rewrites).
        type: the exception's class name (``"BoundNotMetError"``, ``"BrokenProcessPool"`` for a dead worker).
        parameters: the parameter mentions the message holds (:attr:`motionrep.errors.MotionrepError.parameters`).
    """

    message: str
    type: str
    parameters: tuple[str, ...] = ()


@dataclass(frozen=True)
class ClipOutcome:
    """What compressing one clip of a batch gave: what crosses the process boundary back to the client, typed.

    Attributes:
        name: the clip's name.
        source: where it was read (``path`` or ``path[clip]``).
        status: ``"done"``, ``"failed"`` or ``"skipped"`` (``--resume``: the output already holds this clip,
            compressed from the same source with the same setting).
        result: the :class:`~motionrep.pipeline.compress.CompressResult` (``"done"`` only).
        failure: why it failed (``"failed"`` only).
        source_sha256: the checksum of its source, when read.
        cpu_seconds: the processor time the clip took in its worker.
    """

    name: str
    source: str | None
    status: str = "done"
    result: CompressResult | None = field(default=None, repr=False)
    failure: ClipFailure | None = None
    source_sha256: str | None = None
    cpu_seconds: float = 0.0

    @property
    def failed(self) -> bool:
        return self.status == "failed"

    @property
    def skipped(self) -> bool:
        return self.status == "skipped"

    @property
    def data(self) -> bytes | None:
        """The ``.mrc`` bytes (``"done"`` only)."""
        return None if self.result is None else self.result.data

    @property
    def summary(self) -> dict[str, Any]:
        """The outcome as JSON data, what ``compress --json`` prints per clip (the one place it is spelled out):
        ``CompressResult.as_dict()`` plus ``source``, ``source_sha256`` and ``cpu_seconds``; for a failure
        ``{"error", "type", "source", "cpu_seconds"}`` (and ``"parameters"`` when the message names some); for a
        skipped clip ``{"skipped": True, "source"}``."""
        if self.failure is not None:
            return {"error": self.failure.message, "type": self.failure.type, "source": self.source,
                    "cpu_seconds": self.cpu_seconds,
                    **({"parameters": list(self.failure.parameters)} if self.failure.parameters else {})}
        if self.result is None:
            return {"skipped": True, "source": self.source}
        return dict(self.result.as_dict(), source=self.source, source_sha256=self.source_sha256,
                    cpu_seconds=self.cpu_seconds)


@dataclass(frozen=True)
class ClipJob:
    """One clip to compress, as sent to a worker.

    Attributes:
        ref: the clip.
        pipeline: the :class:`motionrep.pipeline.compress.Pipeline` (it travels with its ``MaxError``).
        expect: with ``--resume``, the source checksum of the copy the output holds: the worker skips the clip
            when its source still has it.
        data: the bytes of the clip's file, sent by the client to workers that cannot read its path (None: the
            worker reads ``ref.path``).
        read: for a clip of a database or archive sent that way, ``(motion, source checksum)`` as the client read
            them, or the error reading it gave (raised in the worker: the clip fails, the others go on).
        progress: ``progress(name, stage, fields)``, the codec's progress in the clip (work in this process only).
    """

    ref: ClipRef
    pipeline: Any
    expect: str | None = None
    data: bytes | None = field(default=None, repr=False)
    read: tuple[Motion, str] | MotionrepError | None = field(default=None, repr=False)
    progress: Callable[[str, str, Any], None] | None = field(default=None, repr=False, compare=False)


#: Prefix of a worker's folder for a clip's bytes sent by the client, before the worker's process id.
_CLIP_PREFIX = "motionrep-clip-"


def _read_job(job: ClipJob) -> tuple[Motion, str]:
    """The clip and its source checksum, from its path or from what the client sent."""
    if isinstance(job.read, MotionrepError):
        raise job.read
    if job.read is not None:
        return job.read
    if job.data is None:
        return job.ref.read_with_checksum()
    import tempfile
    from pathlib import Path

    suffix = Path(job.ref.path).suffix
    with tempfile.TemporaryDirectory(prefix=f"{_CLIP_PREFIX}{os.getpid()}-") as tmp:
        local = Path(tmp) / f"clip{suffix}"
        local.write_bytes(job.data)
        try:
            motion, checksum = ClipRef(job.ref.name, str(local), job.ref.clip,
                                       job.ref.source_bytes).read_with_checksum()
        except FormatError as exc:  # name the user's file, not the worker's copy
            try:
                named = type(exc)(exc.message, job.ref.source, exc.line)
            except TypeError:  # a subclass made otherwise
                named = FormatError(exc.message, job.ref.source, exc.line)
            raise naming(named, *exc.parameters) from None
    return motion, checksum


def _compress_one(job: ClipJob | tuple[ClipRef, Any]) -> ClipOutcome:
    """A worker's job: read the clip, skip it when ``--resume`` keeps it, else compress it
    (:func:`motionrep.pipeline.compress.compress_clip`, the one path); whatever fails is this clip's outcome."""
    from ..pipeline.compress import compress_clip

    if isinstance(job, tuple):
        job = ClipJob(*job)
    ref = job.ref
    cpu = time.process_time()
    try:
        motion, checksum = _read_job(job)
        if job.expect is not None and checksum == job.expect:
            return ClipOutcome(ref.name, ref.source, "skipped")
        on = job.progress
        result = compress_clip(job.pipeline, ref, read=(motion, checksum),
                               progress=on and (lambda stage, fields: on(ref.name, stage, fields)))
    except Exception as exc:  # a bug or a resource (MemoryError, RecursionError) too: this clip's failure only
        return _failed(ref, exc, time.process_time() - cpu)
    return ClipOutcome(ref.name, ref.source, result=result, source_sha256=checksum,
                       cpu_seconds=time.process_time() - cpu)


def _failed(ref: ClipRef, exc: BaseException, cpu_seconds: float = 0.0) -> ClipOutcome:
    """The failed outcome of a clip: a motionrep error's message (and the parameters it names), or for anything
    else (a bug, a resource, a worker process that died) one line naming the clip's source and what happened."""
    if isinstance(exc, MotionrepError):
        failure = ClipFailure(str(exc), type(exc).__name__, tuple(exc.parameters))
        return ClipOutcome(ref.name, ref.source, "failed", failure=failure, cpu_seconds=cpu_seconds)
    if isinstance(exc, MemoryError):
        what = "not enough memory to compress it"
    elif isinstance(exc, RecursionError):
        what = "nested too deeply to compress (RecursionError)"
    elif type(exc).__name__ == "BrokenProcessPool":
        what = "its worker process died while compressing it (a crash, or killed for memory)"
    else:
        what = f"internal error {type(exc).__name__}: {exc}"
    message = " ".join(f"{ref.source}: {what}".split())[:500]
    return ClipOutcome(ref.name, ref.source, "failed", failure=ClipFailure(message, type(exc).__name__),
                       cpu_seconds=cpu_seconds)


def compress_clips(refs: Sequence[ClipRef], pipeline: Any, *, jobs: int = 1, executor: cf.Executor | None = None,
                   on_done: Callable[[ClipOutcome], None] | None = None, expect: dict[str, str] | None = None,
                   timeout: float | None = None, send_data: bool | Collection[str] = False,
                   progress: Callable[[str, str, Any], None] | None = None) -> list[ClipOutcome]:
    """Compress every clip with ``pipeline`` (a :class:`motionrep.pipeline.compress.Pipeline`); a clip that fails (bound
    not met, unreadable, over its time limit) gives a failed :class:`ClipOutcome` and the others go on.

    Args:
        refs: the clips.
        pipeline: the setting.
        jobs, executor: where the work runs (:func:`run_batch`); ``progress`` only with ``jobs=1`` and no executor.
        on_done: called as ``on_done(outcome)`` in this process as each clip finishes (to commit it).
        expect: ``{name: source checksum}`` of clips the output already holds with this setting: such a clip is
            skipped when its source is unchanged (``--resume``).
        timeout: seconds each clip may take (:func:`run_batch`: in worker processes the clip's worker is killed).
        send_data: read clips here and send them to the workers (workers that do not share this file system):
            True for every clip, or the paths (``ref.path``) of the files whose clips are sent; a file of one clip
            is sent as its bytes, a clip of a database or archive as the clip read here and its source checksum.
            By default workers read the clips by path.
        progress: called as ``progress(clip name, stage, fields)`` with the codec's progress inside each clip.

    Returns:
        One outcome per clip, in ``refs`` order.
    """
    expect = expect or {}
    if send_data:  # the folders of local workers that were killed with a clip's bytes in them
        import tempfile
        from pathlib import Path

        from ..io._atomic import remove_stale_folders

        remove_stale_folders(Path(tempfile.gettempdir()), _CLIP_PREFIX)

    sent = None if isinstance(send_data, bool) else frozenset(str(p) for p in send_data)
    pooled = progress is not None and executor is None and jobs > 1  # the pool's workers relay it (a queue)
    here = WorkerProgress() if pooled else None if executor else progress

    def jobs_of() -> Iterator[ClipJob]:
        for ref in refs:
            data = read = None
            if send_data is True or (sent is not None and ref.path in sent):
                try:
                    if ref.clip is None:
                        with open(ref.path, "rb") as f:
                            data = f.read()
                    else:
                        read = ref.read_with_checksum()
                except MotionrepError as exc:
                    read = exc
                except (OSError, MemoryError) as exc:  # this clip's failure; the others go on
                    read = FormatError(f"cannot read it: {type(exc).__name__}: {exc}", ref.path)
            yield ClipJob(ref, pipeline, expect.get(ref.name), data, read, here)

    window = None if not send_data else (64 if executor is not None else 4 * jobs)
    with progress_relay(progress) if pooled else contextlib.nullcontext() as relay:
        return run_batch(_compress_one, jobs_of(), jobs=jobs, executor=executor, warm_up=[pipeline.codec.name],
                         on_done=None if on_done is None else (lambda i, item, outcome: on_done(outcome)),
                         window=window, relay=relay, on_error=lambda job, exc: _failed(job.ref, exc),
                         timeout=timeout)


# ---------------------------------------------------------------------------------------------------------------
# evaluate two sources clip by clip
# ---------------------------------------------------------------------------------------------------------------
def pair_clips(reference: Source, candidate: Source, clip: str | None = None, common: bool = False
               ) -> list[tuple[str, str, str]]:
    """The clips to compare between two sources, as ``(name, reference clip, candidate clip)``.

    A file of one clip is compared with the other file's only clip (or with its clip ``clip``); two databases or
    archives are compared clip by clip, by name (only ``clip`` when given); with ``common``, only the clips both
    hold (:func:`clip_sets` lists the others).

    Raises:
        FormatError: when ``clip`` is not in a database or archive given, or two databases hold different clips
            (without ``common``) or none in common.
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
        if common:
            return [(n, n, n) for n in _common_names(ref_names, cand_names, candidate.path)]
        _same_names(ref_names, cand_names, str(reference.path), str(candidate.path), "files", candidate.path)
        return [(n, n, n) for n in ref_names]
    many, found = (reference, ref_names) if len(ref_names) > 1 else (candidate, cand_names)
    raise naming(ParameterError(f"{many.path} holds {len(found)} clips ({listing(found)}) and the other file "
                                "one; use clip=NAME"), "clip=NAME")


def pair_refs(reference: list[ClipRef], candidate: list[ClipRef], common: bool = False
              ) -> list[tuple[str, ClipRef, ClipRef]]:
    """The clips to compare between two collections of clips (:func:`~motionrep.pipeline.sources.collect_clips` of each
    side: files, directories, archives), as ``(name, reference clip, candidate clip)``: one clip with the other
    side's one clip, else clip by clip, by name (with ``common``: only the clips both sides hold).

    Raises:
        FormatError: when the two sides hold different clips (naming those only on one side; without
            ``common``), or none in common.
    """
    if len(reference) == 1 and len(candidate) == 1:
        return [(reference[0].name, reference[0], candidate[0])]
    ref, cand = {r.name: r for r in reference}, {r.name: r for r in candidate}
    if common:
        return [(n, ref[n], cand[n]) for n in sorted(_common_names(list(ref), list(cand), candidate[0].path))]
    extra = [n for n in cand if n not in ref]
    _same_names(list(ref), list(cand), "the reference", "the candidate", "sides",
                candidate[0].path if extra else reference[0].path)
    return [(n, ref[n], cand[n]) for n in sorted(ref)]


def clip_sets(reference: Sequence[str], candidate: Sequence[str]) -> tuple[list[str], list[str]]:
    """The clip names only the reference holds and only the candidate holds, in their orders."""
    ref, cand = set(reference), set(candidate)
    return [n for n in reference if n not in cand], [n for n in candidate if n not in ref]


def _common_names(ref: list[str], cand: list[str], path: Any) -> list[str]:
    """The names both lists hold (in ``ref`` order); a FormatError when there are none."""
    shared = set(cand)
    names = [n for n in ref if n in shared]
    if not names:
        raise FormatError(f"the two sides hold no clip in common (reference: {listing(ref)}; candidate: "
                          f"{listing(cand)})", path)
    return names


def _same_names(ref: list[str], cand: list[str], ref_label: str, cand_label: str, what: str, path: Any) -> None:
    """A FormatError naming the clips only one side holds, if any."""
    missing = [n for n in ref if n not in cand]
    extra = [n for n in cand if n not in ref]
    if missing or extra:
        where = "; ".join(part for part in (
            f"only in {ref_label}: {listing(missing)}" if missing else "",
            f"only in {cand_label}: {listing(extra)}" if extra else "") if part)
        raise naming(FormatError(f"the two {what} hold different clips ({where}); use clip=NAME to compare one, "
                                 "or common=True to compare the clips both hold", path), "clip=NAME", "common=True")


def evaluate_clips(reference: Source, candidate: Source, pairs: Sequence[tuple[str, str, str]],
                   on_done: Callable[[str, Any], None] | None = None, options: Any = None) -> list[tuple[str, Any]]:
    """The shared error of every pair ``(name, reference clip, candidate clip)``, read from the two open sources
    (each file opened once), in this process; ``options``: a :class:`motionrep.pipeline.pairing.MatchOptions` (default
    strict).

    Returns:
        ``[(name, ErrorReport)]`` in ``pairs`` order.
    """
    from ..errors import ValidationError
    from ..pipeline.evaluate import max_joint_error

    def work(pair: tuple[str, str, str]) -> tuple[str, Any]:
        name, ref_clip, cand_clip = pair
        try:
            return name, max_joint_error(reference.read(ref_clip), candidate.read(cand_clip), options)
        except ValidationError as exc:  # which files, then what differs
            raise naming(ValidationError(f"{reference.path} vs {candidate.path}: {exc}"), *exc.parameters) from None

    return run_batch(work, pairs,
                     on_done=None if on_done is None else (lambda i, pair, result: on_done(*result)))


def evaluate_refs(pairs: Sequence[tuple[str, ClipRef, ClipRef]],
                  on_done: Callable[[str, Any], None] | None = None, options: Any = None) -> list[tuple[str, Any]]:
    """The shared error of every pair ``(name, reference clip, candidate clip)`` of clips gathered from files,
    directories and archives (each file opened once for a run of its clips), in this process; ``options`` as
    :func:`evaluate_clips`.

    Returns:
        ``[(name, ErrorReport)]`` in ``pairs`` order.
    """
    from ..pipeline.evaluate import max_joint_error
    from ..pipeline.sources import read_refs

    out = []
    references = read_refs([a for _, a, _ in pairs])
    candidates = read_refs([b for _, _, b in pairs])
    for (name, _, _), (_, ref), (_, cand) in zip(pairs, references, candidates):
        report = max_joint_error(ref, cand, options)
        out.append((name, report))
        if on_done is not None:
            on_done(name, report)
    return out
