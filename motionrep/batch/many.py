"""Many clips compressed into one output (``motionrep compress`` of many clips): the output's store, the clips it
already holds (a clash without ``force`` / ``resume``; with ``resume``, the clips kept by their setting's digest and
source checksum, a changed setting refused unless ``recompress_changed``), where the work runs (this process,
``jobs`` worker processes, or a Dask cluster), each clip committed as it finishes, and the totals.

The command line only parses options, shows progress and prints; :func:`compress_into` is the library's one
entry point for it (``specs/databases.md``).
"""

from __future__ import annotations

import contextlib
import os
import time
from dataclasses import dataclass
from typing import Any, Callable, Collection, Sequence

from ..errors import BatchInterrupted, OutputExistsError, SettingChangedError, naming
from ..pipeline.sources import ClipRef, listing
from .engine import ClipOutcome, compress_clips
from .executors import dask_executor
from .store import open_store, resume_key, setting_changes
from .totals import BatchTotals, StoredClip, container_summary

__all__ = ["BatchRun", "compress_into", "kept_clips"]


@dataclass(frozen=True)
class BatchRun:
    """What :func:`compress_into` did.

    Attributes:
        outcomes: one :class:`~motionrep.batch.engine.ClipOutcome` per clip, in the order of the clips given.
        kept: the stored clips kept by ``resume`` (:class:`~motionrep.batch.totals.StoredClip`), by name.
        wall_seconds, client_cpu_seconds: the run's elapsed time and this process's processor time.
    """

    outcomes: list[ClipOutcome]
    kept: dict[str, StoredClip]
    wall_seconds: float
    client_cpu_seconds: float

    @property
    def failed(self) -> list[ClipOutcome]:
        return [o for o in self.outcomes if o.failed]

    def totals(self, reason: Callable[[Any], str] | None = None) -> BatchTotals:
        """:meth:`~motionrep.batch.totals.BatchTotals.of` this run (``reason`` words a failure)."""
        return BatchTotals.of(self.outcomes, self.kept, wall_seconds=self.wall_seconds,
                              client_cpu_seconds=self.client_cpu_seconds, reason=reason)


def kept_clips(store: Any, refs: Sequence[ClipRef], pipeline: Any, recompress_changed: bool = False
               ) -> tuple[dict[str, str], dict[str, StoredClip]]:
    """What ``resume`` keeps of what ``store`` holds: ``({name: source checksum}, {name: StoredClip})`` of the clips
    stored with ``pipeline``'s setting (the same digest, :func:`~motionrep.batch.store.resume_key`); a worker keeps
    such a clip when its source still has that checksum.

    Raises:
        SettingChangedError: when clips were stored with another setting and not ``recompress_changed``, naming
            the first and what changed.
    """
    existing = store.existing()
    changed = {ref.name: setting_changes(existing[ref.name], pipeline) for ref in refs
               if existing.get(ref.name) is not None}
    changed = {k: v for k, v in changed.items() if v}
    if changed and not recompress_changed:
        first = next(iter(changed))
        raise naming(SettingChangedError(
            f"resume=True: {len(changed)} clip(s) in {store.path} were compressed with another setting ({first}: "
            f"{'; '.join(changed[first])}); give the same setting to keep them, or add recompress_changed=True to "
            "recompress and replace them", changed), "resume=True", "recompress_changed=True")
    expect: dict[str, str] = {}
    kept: dict[str, StoredClip] = {}
    for ref in refs:
        container = existing.get(ref.name)
        key = None if container is None else resume_key(container, pipeline)
        if key is not None:
            expect[ref.name] = key
            kept[ref.name] = container_summary(container, store.sizes[ref.name], ref.source, ref.source_bytes)
    return expect, kept


def compress_into(refs: Sequence[ClipRef], output: str | os.PathLike[str], pipeline: Any, *, jobs: int = 1,
                  scheduler: Any = None, send_clips: bool | Collection[str] = False, resume: bool = False,
                  force: bool = False, recompress_changed: bool = False, timeout: float | None = None,
                  on_done: Callable[[ClipOutcome], None] | None = None,
                  progress: Callable[[str, str, Any], None] | None = None) -> BatchRun:
    """Compress ``refs`` with ``pipeline`` into ``output`` (an archive ``.h5``/``.hdf5`` or a directory), each clip
    committed as it finishes (:mod:`motionrep.batch.store`); a clip that fails is its outcome, the others go on.

    Args:
        refs: the clips (:func:`motionrep.pipeline.sources.collect_clips`).
        output: the archive or directory.
        pipeline: the setting (:class:`motionrep.pipeline.compress.Pipeline`).
        jobs: worker processes (1: this process).
        scheduler: a Dask scheduler's address (or cluster) to run on instead (:func:`dask_executor`).
        send_clips: with ``scheduler``, read clips here and send them (True, or the paths whose clips are sent).
        resume: keep the clips the output holds from the same source with the same setting, compress the others.
        force: overwrite what the output holds.
        recompress_changed: with ``resume``, recompress (and replace) clips stored with another setting.
        timeout: seconds each clip may take.
        on_done: called with each outcome as its clip finishes (after it is committed), in this process.
        progress: ``progress(clip name, stage, fields)``, the codec's progress inside each clip (not on Dask).

    Returns:
        The outcomes (in ``refs`` order), the kept clips and the times.

    Raises:
        OutputExistsError: the output holds some of these clips and neither ``force`` nor ``resume`` was given
            (or an archive exists; :func:`~motionrep.batch.store.open_store`).
        SettingChangedError: ``resume`` over clips stored with another setting (:func:`kept_clips`).
        BatchInterrupted: on a signal (Ctrl-C, SIGTERM, SIGHUP): every finished clip is kept in the output.
    """
    start, cpu = time.monotonic(), time.process_time()
    store = open_store(output, force=force, resume=resume)
    names = [r.name for r in refs]
    outcomes: list[ClipOutcome] = []
    expect: dict[str, str] = {}
    kept: dict[str, StoredClip] = {}
    try:
        if not (force or resume):
            clash = store.conflicts(names)
            if clash:
                raise naming(OutputExistsError(f"already holds {len(clash)} of these clips ({listing(clash)}); use "
                                               "force=True to overwrite them or resume=True to keep them and add the "
                                               "rest", output), "force=True", "resume=True")
        if resume:
            expect, kept = kept_clips(store, refs, pipeline, recompress_changed)
        with contextlib.ExitStack() as stack:
            executor = stack.enter_context(dask_executor(scheduler)) if scheduler else None

            def done(outcome: ClipOutcome) -> None:
                if outcome.status == "done":
                    store.commit(outcome.name, outcome.data)
                outcomes.append(outcome)
                if on_done is not None:
                    on_done(outcome)

            compress_clips(refs, pipeline, jobs=jobs, executor=executor, on_done=done, expect=expect,
                           timeout=timeout, send_data=send_clips if scheduler else False,
                           progress=None if scheduler else progress)
    except KeyboardInterrupt as exc:
        store.close()
        finished = sum(1 for o in outcomes if not o.failed)
        signum = getattr(exc, "signum", 2)
        note = (f"{finished} of {len(refs)} clips finished and kept in {output}" if finished else
                f"no clip had finished; nothing was written to {output}")
        raise BatchInterrupted(signum, note, finished, len(refs), str(output)) from None
    finally:
        store.close()
    order = {n: i for i, n in enumerate(names)}
    outcomes.sort(key=lambda o: order[o.name])
    return BatchRun(outcomes, kept, time.monotonic() - start, time.process_time() - cpu)
