"""Coding windows side by side in forked worker processes (numpy only; training is imported by the caller).

A :class:`Task` is one span of frames to code with at most ``max_k`` frequencies.  :class:`Runner` runs tasks
one at a time in this process, or ``jobs`` at a time in processes forked from it by a ``pebble.ProcessPool`` (the
job, with the features and the encode context, is shared with them by memory, so nothing is pickled but the spans
and the results; each worker dies with this process).  Each
task's outcome depends only on its frames, the parameters and the seed, so the results are the same for any
number of processes; they are yielded as tasks end, and the caller orders them.
"""

from __future__ import annotations

import dataclasses
import math
import multiprocessing
import os
import threading
from typing import TYPE_CHECKING, Any, Callable, Iterable, Iterator, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep.plugin.codec import EncodeContext, Payload
from motionrep.errors import BoundNotMetError

from ._network import network_forward
from ._packed import dequantized, unpack
from ._windows import local_times

if TYPE_CHECKING:
    from concurrent.futures import Future

__all__ = ["Task", "Outcome", "WindowJob", "Runner", "worker_count", "WindowContext"]


class Task(NamedTuple):
    """Frames ``first .. last`` of the clip, coded with at most ``max_k`` frequencies."""

    first: int
    last: int
    max_k: int


class Outcome(NamedTuple):
    """A task's payload, or the :class:`BoundNotMetError` it ended with; and the evaluations it made."""

    result: Payload | BoundNotMetError
    evaluations: int


def worker_count(jobs: int, tasks: int) -> int:
    """Processes to run ``tasks`` tasks with: ``jobs``, or for 0 the CPUs this process may use; never more than
    the tasks, and 1 where processes cannot be forked safely: no ``fork`` start method, or other Python threads
    running (a threaded scheduler: a forked child gets only this thread, and the locks of the others as they
    were); for 0 also inside a worker process (``motionrep compress --jobs`` already spreads the clips over the
    CPUs)."""
    if threading.active_count() > 1:
        return 1
    if jobs == 0:
        if multiprocessing.parent_process() is not None:
            return 1
        try:
            jobs = len(os.sched_getaffinity(0))
        except (AttributeError, OSError):  # pragma: no cover - not Linux
            jobs = os.cpu_count() or 1
    if "fork" not in multiprocessing.get_all_start_methods():  # pragma: no cover - Windows
        return 1
    return max(1, min(jobs, tasks))


class WindowContext:
    """The :class:`~motionrep.plugin.codec.EncodeContext` of one window: its frames' local times, its ``max_k``, and
    the shared evaluation of a candidate on the window's frames (``context.evaluate_frames``; frames are measured
    independently, so this is the error they have in the whole clip), or, from a context without it, on the
    whole clip with every other frame exact.  Progress goes to ``relay`` when given (a forked worker's, read by
    the parent), else to the context."""

    def __init__(self, context: EncodeContext, features: NDArray[np.float64], task: Task, relay: Any = None):
        self._context, self._features = context, features
        self._first, self._last = task.first, task.last
        self.params = context.params if context.params.max_k == task.max_k else \
            dataclasses.replace(context.params, max_k=task.max_k)
        self.bound, self.seed = context.bound, context.seed
        self.relay = relay
        self.evaluations = 0
        times = np.asarray(context.times, np.float64)[task.first:task.last + 1]
        self.times = local_times(times, features.shape[0], task.first, task.last)

    def evaluate(self, features: ArrayLike) -> Any:
        self.evaluations += 1
        measure = getattr(self._context, "evaluate_frames", None)
        if measure is not None:  # only this window's frames
            return measure(np.asarray(features, np.float64), self._first)
        full = self._features.copy()
        full[self._first:self._last + 1] = features
        return self._context.evaluate(full)

    def evaluate_payload(self, payload: Payload) -> Any:
        arrays = payload.arrays
        if "data" in arrays:  # one quantised network, as the decoder will have it
            _, scale, (network,) = unpack(arrays["data"])
            arrays = dequantized(network, scale)
        return self.evaluate(network_forward(arrays, self.times))

    def progress(self, stage: str, **fields: Any) -> None:
        fields = {"window": f"{self._first}-{self._last}", **fields}
        if self.relay is not None:
            self.relay.put((stage, fields))
        else:
            self._context.progress(stage, **fields)


class WindowJob:
    """What coding one window needs: everything but its task."""

    def __init__(self, name: str, schedule: str, features: NDArray[np.float64], weights: NDArray[np.float64],
                 context: EncodeContext, fit: Callable[..., Payload]):
        self.name, self.schedule, self.features, self.weights = name, schedule, features, weights
        self.context, self.fit = context, fit
        self.relay: Any = None  # set while worker processes run: where their progress goes

    def __call__(self, task: Task) -> Outcome:
        sub = WindowContext(self.context, self.features, task, relay=self.relay)
        try:
            result: Payload | BoundNotMetError = self.fit(
                self.features[task.first:task.last + 1], self.weights, sub, schedule=self.schedule,
                name=f"{self.name} (window of frames {task.first}-{task.last})")
        except BoundNotMetError as exc:
            result = exc
        return Outcome(result, sub.evaluations)


#: Seconds between two looks at the workers' progress.
PROGRESS_SECONDS = 0.1
#: The job of the forked worker processes (set in the parent just before they are forked).
_JOB: WindowJob | None = None


def _run_forked(task: Task) -> Outcome:
    if _JOB is None:  # pragma: no cover - set before the pool forks
        raise RuntimeError("window worker started without a job")
    return _JOB(task)


class Runner:
    """Runs tasks of one job, one at a time here or ``jobs`` at a time in forked processes.

    Calling it with tasks yields ``(task, outcome)`` as tasks end (those that end together in task order);
    tasks start in frame order.  :meth:`submit` adds tasks, :meth:`drop_from` starts no task that begins at or
    after a frame (running ones finish).  The workers' evaluations are added to the encode context's count where
    it keeps one (the core's does).
    """

    def __init__(self, job: WindowJob, jobs: int):
        self.job, self.jobs = job, jobs
        self.todo: list[Task] = []
        self.end = math.inf

    def submit(self, tasks: Iterable[Task]) -> None:
        self.todo = sorted([*self.todo, *tasks])

    def drop_from(self, first: int) -> None:
        self.end = min(self.end, first)

    def _next(self) -> Task | None:
        return self.todo.pop(0) if self.todo and self.todo[0].first < self.end else None

    def __call__(self, tasks: Iterable[Task]) -> Iterator[tuple[Task, Outcome]]:
        self.todo, self.end = sorted(tasks), math.inf
        if self.jobs <= 1:
            while (task := self._next()) is not None:
                yield task, self.job(task)  # the context counted this task's evaluations itself
            return
        # imported here: the pool (and multiprocessing's connections) cost start-up time that a process which only
        # describes or decodes a file (`motionrep info clip.mrc`) should not pay
        from concurrent.futures import FIRST_COMPLETED, wait

        from pebble import ProcessPool

        from motionrep.batch.executors import die_with_parent  # a killed encoder leaves no worker behind

        global _JOB
        fork = multiprocessing.get_context("fork")
        self.job.relay = relay = fork.SimpleQueue()  # the workers' progress, passed on here
        _JOB = self.job
        # forked workers (the job is shared with them by memory, set just above); a pool that ends early (an error,
        # the caller stops reading) stops its workers instead of waiting for their windows
        pool = ProcessPool(self.jobs, initializer=die_with_parent, initargs=(os.getpid(),), context=fork)
        running: dict[Future, Task] = {}
        finished_normally = False

        def pass_on() -> None:
            while not relay.empty():
                stage, fields = relay.get()
                self.job.context.progress(stage, **fields)

        try:
            while True:
                while len(running) < self.jobs and (task := self._next()) is not None:
                    running[pool.schedule(_run_forked, (task,))] = task
                if not running:
                    break
                finished, _ = wait(running, timeout=PROGRESS_SECONDS, return_when=FIRST_COMPLETED)
                pass_on()
                for future in sorted(finished, key=running.__getitem__):
                    task = running.pop(future)
                    outcome = future.result()
                    _count_evaluations(self.job.context, outcome.evaluations)
                    yield task, outcome
            finished_normally = True
        finally:
            _JOB = self.job.relay = None
            if finished_normally:
                pool.close()
            else:
                pool.stop()
            pool.join()
            relay.close()


def _count_evaluations(context: EncodeContext, evaluations: int) -> None:
    """Add a worker's evaluations to the context's count, where the context keeps one (the core's does, for
    ``CompressResult.evaluations``)."""
    count = getattr(context, "evaluations", None)
    if isinstance(count, int) and not isinstance(count, bool):
        context.evaluations = count + evaluations  # type: ignore[attr-defined]
