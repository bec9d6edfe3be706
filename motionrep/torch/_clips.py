"""The clips behind a :class:`~motionrep.torch.MotionDataset`: which there are, how many frames each has, and a
per-process cache of their prepared arrays.

Indexing reads as little as it can: a database's clip summaries (attributes and shapes only), an archive's
container headers; only a file of one clip (BVH, NPZ, glTF, ``.mrc``) is read whole, one at a time, to count its
frames.  No file stays open afterwards.  Each process that reads windows (the main one, or each ``DataLoader``
worker) opens the files it needs itself, on first use, and notices when it is a fork of the process that opened
them (an HDF5 handle must not cross a fork); the prepared arrays of the most recently used clips are kept up to
``cache_bytes`` per process (least recently used first out).  Clips prepared before the workers fork
(``MotionDataset.preload``) are inherited by them, copy-on-write: prepared once, not once per worker.
"""

from __future__ import annotations

import os
from collections import OrderedDict
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..model._pose import Motion
from ..errors import FormatError, ValidationError
from ..model.ops import resampled_count
from ..pipeline.sources import SOURCE_SUFFIXES, ClipRef, Source, collect_clips, open_source

__all__ = ["ClipInfo", "index_clips", "ClipCache"]


@dataclass(frozen=True)
class ClipInfo:
    """One clip of a dataset.

    Attributes:
        name: its name (the naming rules of ``motionrep.pipeline.sources``: a database's clip names, a directory's relative
            paths with ``__`` for ``/``).
        path: its file.
        clip: its name in that file (None for a file of one clip).
        source_frames: frames as stored.
        source_fps: frame rate as stored.
        frames: frames after resampling to the dataset's rate (``motionrep.model.ops.resampled_count``).
        layout: the clip's feature columns, when indexing was asked to find them (else None).
    """

    name: str
    path: str
    clip: str | None
    source_frames: int
    source_fps: float
    frames: int
    layout: tuple[str, ...] | None = None


def _counts(src: Source, refs: list[ClipRef], columns: Callable[[Motion], tuple[str, ...]] | None
            ) -> list[tuple[int, float, tuple[str, ...] | None]]:
    if columns is None and src.kind == "database" and hasattr(src, "summaries"):
        table = {s["name"]: (int(s["frames"]), float(s["fps"]), None) for s in src.summaries()}
        return [table[r.clip] for r in refs]
    if columns is None and src.kind == "archive":
        out = []
        for r in refs:
            c = src.container(r.clip)
            out.append((int(c.num_frames), float(c.fps), None))
        return out
    out = []
    for r in refs:
        m = src.read(r.clip)
        out.append((m.num_frames, float(m.fps), None if columns is None else columns(m)))
    return out


def index_clips(source: str | os.PathLike[str] | Sequence[str | os.PathLike[str]], fps: float | None,
                clips: Iterable[str] | None = None,
                columns: Callable[[Motion], tuple[str, ...]] | None = None) -> list[ClipInfo]:
    """The clips of ``source`` (a directory, a motion file, an ``.h5`` database, an ``.mrc`` archive, or a list of
    them), restricted to the names in ``clips`` when given, in the sources' order.  With ``columns``, every clip
    is read (one at a time) and ``columns(motion)`` stored as its ``layout``.

    Raises:
        FormatError: naming the file, for a missing or unreadable input.
        ValidationError: for a name in ``clips`` that no input holds.
    """
    inputs = [source] if isinstance(source, (str, os.PathLike)) else list(source)
    refs = collect_clips(inputs, scan=SOURCE_SUFFIXES)
    if clips is not None:
        wanted = list(clips)
        have = {r.name for r in refs}
        missing = [n for n in wanted if n not in have]
        if missing:
            raise ValidationError(f"clips not in the dataset's source: {missing[:5]}"
                                  + (f" ({len(missing) - 5} more)" if len(missing) > 5 else ""))
        keep = set(wanted)
        refs = [r for r in refs if r.name in keep]
    out: list[ClipInfo] = []
    i = 0
    while i < len(refs):
        j = i
        while j < len(refs) and refs[j].path == refs[i].path:
            j += 1
        group = refs[i:j]
        with open_source(group[0].path) as src:
            counts = _counts(src, group, columns)
        for r, (frames, rate, layout) in zip(group, counts):
            n = frames if fps is None else resampled_count(frames, rate, fps)
            out.append(ClipInfo(r.name, r.path, r.clip, frames, rate, n, layout))
        i = j
    return out


class ClipCache:
    """Prepared arrays per clip, made by ``prepare(motion)`` on first use in each process and kept up to
    ``max_bytes`` (least recently used out; the clip just prepared is always kept)."""

    def __init__(self, infos: Sequence[ClipInfo], prepare: Callable[[Motion], dict[str, np.ndarray]],
                 max_bytes: int):
        self.infos = list(infos)
        self.prepare = prepare
        self.max_bytes = int(max_bytes)
        self._reset()

    def _reset(self) -> None:
        self._pid = os.getpid()
        self._sources: dict[str, Source] = {}
        self._entries: OrderedDict[int, dict[str, np.ndarray]] = OrderedDict()
        self._bytes = 0
        self.prepared = 0  # clips prepared by this process (a measure of the cache's hit rate)

    def __getstate__(self) -> dict[str, Any]:  # sent to spawned workers without open files or arrays
        state = self.__dict__.copy()
        for k in ("_sources", "_entries", "_bytes", "_pid", "prepared"):
            state.pop(k)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._reset()

    def _forked(self) -> None:
        """In a forked worker: the parent's file handles are not ours (forgotten, never closed here); its prepared
        arrays are plain memory, shared copy-on-write, and kept."""
        if self._pid != os.getpid():
            self._pid = os.getpid()
            self._sources = {}

    def _source(self, path: str) -> Source:
        self._forked()
        src = self._sources.get(path)
        if src is None:
            src = self._sources[path] = open_source(path)
        return src

    def read(self, i: int) -> Motion:
        """Clip ``i`` as stored (its file opened by this process)."""
        info = self.infos[i]
        try:
            return self._source(info.path).read(info.clip)
        except FormatError:
            raise
        except (OSError, ValueError) as exc:
            raise FormatError(f"cannot read clip {info.name!r}: {exc}", Path(info.path)) from None

    def get(self, i: int) -> dict[str, np.ndarray]:
        """The prepared arrays of clip ``i``."""
        self._forked()
        entry = self._entries.get(i)
        if entry is not None:
            self._entries.move_to_end(i)
            return entry
        entry = self.prepare(self.read(i))
        self.prepared += 1
        size = sum(a.nbytes for a in entry.values() if isinstance(a, np.ndarray))
        self._entries[i] = entry
        self._bytes += size
        while self._bytes > self.max_bytes and len(self._entries) > 1:
            _, old = self._entries.popitem(last=False)
            self._bytes -= sum(a.nbytes for a in old.values() if isinstance(a, np.ndarray))
        return entry

    def close(self) -> None:
        """Close this process's files and drop its arrays."""
        if self._pid == os.getpid():
            for src in self._sources.values():
                src.close()
        self._reset()
