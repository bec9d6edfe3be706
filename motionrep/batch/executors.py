"""Where batch work runs, and for how long: the embedded local process pool, a Dask distributed cluster, and a
time limit for one item (:mod:`motionrep.batch.engine` runs its work through these).

* :func:`_process_pool`: ``jobs`` spawned worker processes (a ``pebble.ProcessPool``) that start with Ctrl-C
  ignored (the parent stops them, :func:`_stop_pool`, so no worker prints a traceback); a task over its time
  limit (``--timeout``) has its worker killed, whatever it is doing (compiled code included), and another started;
* :func:`dask_executor`: a ``concurrent.futures`` executor on a Dask cluster (``Client.get_executor``), for
  ``--scheduler ADDRESS`` or ``MOTIONREP_SCHEDULER``; ``dask[distributed]`` is the optional extra ``dask``;
* :func:`time_limit`: ``--timeout`` where no worker process can be killed for it: in this process (``--jobs 1``:
  the process is the run) and in a Dask worker's task threads (Dask has no per-task limit, and its worker
  processes, daemonic, cannot start a child to kill); raised in the thread doing the work;
* :func:`progress_relay` and :class:`WorkerProgress`: a codec's progress inside a clip, from the pool's
  workers to a callback in the parent (a queue the workers get when they start, drained by a thread);
* :func:`worker_threads`: the BLAS thread count spawned workers start with.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import os
import signal
import sys
import threading
import time
from typing import Any, Callable, Iterator

from ..errors import ParameterError, TimeLimitError, naming

__all__ = ["dask_executor", "time_limit", "time_limit_error", "die_with_parent", "SCHEDULER_VARIABLE", "CONNECT_TIMEOUT",
           "THREAD_VARIABLES", "worker_threads", "progress_relay", "WorkerProgress"]

#: Environment variables that set the thread count of the BLAS libraries numpy and scipy may use.
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
#: The progress queue of this worker process (set by :func:`_start_worker`; None in the parent).
_RELAY: dict[str, Any] = {"queue": None}

#: Environment variable naming a Dask scheduler (``tcp://host:8786``) when ``--scheduler`` is not given.
SCHEDULER_VARIABLE = "MOTIONREP_SCHEDULER"
#: How long the client tries to reach a Dask scheduler.
CONNECT_TIMEOUT = "20s"


def _ignore_interrupts() -> None:
    """Worker processes leave Ctrl-C to the parent (which stops them): no worker prints a traceback."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def die_with_parent(parent: int | None = None) -> None:
    """Make this (worker) process die with its parent: on Linux ``prctl(PR_SET_PDEATHSIG, SIGKILL)``, so a client
    killed with SIGKILL leaves no worker running; then, if ``parent`` (the pid the worker was started by) is no
    longer the parent, the parent died before the request took effect and the process exits now.  Elsewhere
    nothing (the workers there end when they next read their closed task queue).  Call it first in a worker
    process's initializer; the shipped pools do (``motionrep compress --jobs``, the Fourier codecs' ``jobs``)."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
        except Exception:  # pragma: no cover - no libc prctl: the queue's end still stops the worker
            pass
    if parent is not None and os.getppid() != parent:
        os._exit(1)


def _start_worker(parent: int, queue: Any = None, initializer: Callable[..., None] | None = None,
                  initargs: tuple = ()) -> None:
    """Initializer of the embedded pool's workers: die with the client, leave Ctrl-C to it, report progress on
    ``queue`` (:func:`progress_relay`; None: no progress), then ``initializer(*initargs)`` (the engine's thread
    policy and codec warm-up; an error there is left for the first task to meet again, named, not a dead worker)."""
    die_with_parent(parent)
    _ignore_interrupts()
    if queue is not None:
        queue.cancel_join_thread()  # a worker killed for its time limit must not wait to flush its progress
    _RELAY["queue"] = queue
    if initializer is not None:
        try:
            initializer(*initargs)
        except Exception:  # noqa: BLE001 - the task meets it again, and fails with it
            pass


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


class WorkerProgress:
    """A progress callback that travels to pool workers (it pickles): ``(name, stage, fields)`` goes on the
    worker's relay queue, at most once every ``every`` seconds per clip and stage (plain fields only)."""

    def __init__(self, every: float = 0.5):
        self.every = every
        self._last: dict[tuple[str, str], float] = {}

    def __call__(self, name: str, stage: str, fields: Any) -> None:
        queue = _RELAY["queue"]
        now = time.monotonic()
        if queue is None or now - self._last.get((name, stage), -float("inf")) < self.every:
            return
        self._last[(name, stage)] = now
        queue.put((name, stage, {k: v for k, v in dict(fields).items()
                                 if v is None or isinstance(v, (bool, int, float, str))}))


@contextlib.contextmanager
def progress_relay(callback: Callable[[str, str, Any], None]) -> Iterator[Any]:
    """A queue for :func:`_process_pool`'s workers (:class:`WorkerProgress`), whose messages a daemon thread
    passes to ``callback(name, stage, fields)`` here until the block ends."""
    import multiprocessing

    # a Queue, not a SimpleQueue: a worker writes through a feeder thread, so a worker killed for its time limit
    # while it held the queue's lock cannot block the others' work (only their progress)
    queue = multiprocessing.get_context("spawn").Queue()

    def drain() -> None:
        while (message := queue.get()) is not None:
            try:
                callback(*message)
            except Exception:  # noqa: BLE001 - progress must never stop the work
                pass

    thread = threading.Thread(target=drain, name="motionrep-progress-relay", daemon=True)
    thread.start()
    try:
        yield queue
    finally:
        queue.put(None)
        thread.join(timeout=5)


@contextlib.contextmanager
def _process_pool(workers: int, relay: Any = None, initializer: Callable[..., None] | None = None,
                  initargs: tuple = ()) -> Iterator[Any]:
    """A ``pebble.ProcessPool`` of ``workers`` spawned processes, all started at once with Ctrl-C ignored (a signal
    disposition set to 'ignore' is inherited by the spawned interpreters, so not even their start-up prints a
    traceback), each dying with this process (:func:`die_with_parent`: a SIGKILL of the client leaves no orphan),
    reporting progress on ``relay`` (:func:`progress_relay`), then running ``initializer(*initargs)``.

    Submit with ``pool.schedule(function, args, timeout=seconds)``: a task over its time limit has its worker
    killed (pebble starts another) and its future raises ``concurrent.futures.TimeoutError``; a worker that dies
    fails only the task it ran (``pebble.ProcessExpired``).  :func:`_stop_pool` stops the workers at once."""
    import multiprocessing

    from pebble import ProcessPool

    pool = ProcessPool(max_workers=workers, context=multiprocessing.get_context("spawn"),
                       initializer=_start_worker, initargs=(os.getpid(), relay, initializer, tuple(initargs)))
    try:
        main = threading.current_thread() is threading.main_thread()
        saved = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
        try:
            pool.schedule(os.getpid)  # the first submission starts every worker, here, with signals ignored
        finally:
            if main:
                signal.signal(signal.SIGINT, saved)
        yield pool
    except BaseException:
        _stop_pool(pool)
        raise
    else:
        pool.close()
        pool.join()


def _stop_pool(pool: Any) -> None:
    """Stop a pool's workers now (an interrupted run must not wait for the clips in progress)."""
    with contextlib.suppress(Exception):
        pool.stop()
    with contextlib.suppress(Exception):
        pool.join(timeout=10)


@contextlib.contextmanager
def dask_executor(scheduler: Any) -> Iterator[cf.Executor]:
    """A ``concurrent.futures`` executor on a Dask distributed cluster (``Client.get_executor``), closed at the end.

    Args:
        scheduler: the scheduler's address (``tcp://host:8786``), or a ``distributed`` cluster object (such as
            a ``LocalCluster``).

    Raises:
        ParameterError: when ``dask[distributed]`` is not installed, or the scheduler cannot be reached.
    """
    try:
        from distributed import Client
    except ImportError:
        raise ParameterError("a Dask scheduler needs dask[distributed]: pip install 'motionrep[dask]'") from None
    try:
        client = Client(scheduler, timeout=CONNECT_TIMEOUT, set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise ParameterError(f"cannot reach the Dask scheduler {scheduler}: {exc}") from None
    try:
        yield client.get_executor(pure=False)
    finally:
        with contextlib.suppress(Exception):
            client.close(timeout=10)


#: Seconds between two raises of the time limit's exception while the block has not ended (see :func:`time_limit`).
_REFIRE_SECONDS = 0.1


class _TimeUp(BaseException):
    """Raised asynchronously in the thread that exceeded its time limit (a BaseException, so that no codec's
    ``except Exception`` swallows it)."""


class _DropTimeUp:
    """An ``unraisablehook`` that drops Python's "Exception ignored" report of a :class:`_TimeUp` that landed in a
    garbage collector's callback (the limit is raised again, so nothing is lost) and passes every other report on."""

    def __init__(self, hook) -> None:
        self.hook = hook

    def __call__(self, unraisable) -> None:
        if not isinstance(unraisable.exc_value, _TimeUp):
            self.hook(unraisable)


def _drop_time_up_reports() -> None:
    """Install :class:`_DropTimeUp` in this process, once: a user sees no traceback of a dropped time limit."""
    if not isinstance(sys.unraisablehook, _DropTimeUp):
        sys.unraisablehook = _DropTimeUp(sys.unraisablehook)


@contextlib.contextmanager
def time_limit(seconds: float | None, what: str = "clip") -> Iterator[None]:
    """Raise :class:`~motionrep.errors.TimeLimitError` in this thread when the block runs longer than ``seconds``.

    The exception is raised asynchronously in the running thread (``PyThreadState_SetAsyncExc``), so it works in
    a worker process's main thread and in a Dask worker's task threads alike; like a signal, it is seen at the
    next Python instruction (a long call into BLAS ends first).  It is raised again every
    :data:`_REFIRE_SECONDS` until the block ends: one that lands in a callback of the garbage collector (a
    weakref's) is dropped by Python, not raised, and its report is not printed (:class:`_DropTimeUp`).
    """
    if not seconds:
        yield
        return
    import ctypes  # no maintained library stops a thread; a pool kills its worker instead (_process_pool)

    _drop_time_up_reports()

    lock = threading.Lock()
    state = {"done": False}
    stop = threading.Event()
    target = threading.get_ident()

    def fire() -> None:
        wait = seconds
        while not stop.wait(wait):
            with lock:
                if state["done"]:
                    return
                ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(target), ctypes.py_object(_TimeUp))
            wait = _REFIRE_SECONDS

    timer = threading.Thread(target=fire, daemon=True, name="motionrep-time-limit")
    try:
        try:
            timer.start()
            yield
        finally:
            with lock:
                state["done"] = True
            stop.set()
    except _TimeUp:
        raise time_limit_error(seconds, what) from None


def time_limit_error(seconds: float, what: str = "clip") -> TimeLimitError:
    """The error of work over its time limit, however it was stopped (:func:`time_limit`, a killed worker)."""
    return naming(TimeLimitError(f"{what} took longer than the time limit of {seconds:g} s (timeout=)", seconds),
                  "timeout=")
