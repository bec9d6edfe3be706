"""Where a batch of compressed clips goes: a directory of ``.mrc`` files or one HDF5 archive, each clip committed
durably as it finishes, and what an earlier run left there, for ``--resume``.

:func:`open_store` gives a :class:`ClipStore` for an output path (``.h5``/``.hdf5``: an archive; anything else:
a directory).  The client of a batch (the only process that writes) calls :meth:`ClipStore.commit` as each clip
finishes and :meth:`ClipStore.close` at the end, however the run ends (finished, failed, interrupted):

* **directory**: ``commit`` writes ``OUT/<name>.mrc`` atomically (a temporary file renamed), so a clip is either
  whole or absent, whatever happens to the process;
* **archive**: HDF5 files cannot be updated safely in place (a process killed in the middle of a write can leave
  the whole file unreadable), so ``commit`` writes the clip's container atomically into a *journal*, the hidden
  directory ``.OUT.h5.parts/`` beside the archive; ``close`` writes the archive atomically (the clips an earlier
  archive held, unless ``--force``, then the journal's) and removes the journal.  A process that is killed
  (SIGKILL, out of memory, power loss before the page cache is written aside) leaves the journal; ``--resume``
  reads it, ``--force`` discards it.

Resume: every container ``motionrep compress`` writes records the SHA-256 of the clip's source
(``extra.source_sha256``, see :func:`motionrep.pipeline.checksum.clip_checksum`) and the SHA-256 of its setting
(``extra.setting_sha256``, :meth:`motionrep.pipeline.compress.Pipeline.digest`: codec, version and parameters,
representation and version, bound, seed).  :func:`resume_key` gives the stored source checksum of a container
written with the same setting digest as a pipeline (None otherwise); a worker skips the clip when its source still
has that checksum.  A container written before the digest was stored gets it from the setting it states
(:func:`stored_digest`), so older outputs keep resuming; :func:`setting_changes` names what differs.
"""

from __future__ import annotations

import json
import os
import shutil
from abc import ABC, abstractmethod
from pathlib import Path
from typing import Any, Iterator

from .. import _signals
from ..io.container import SUFFIX, Container
from ..errors import ContainerError, FormatError, OutputExistsError, naming

__all__ = ["ClipStore", "DirectoryStore", "ArchiveStore", "open_store", "journal_path", "resume_key",
           "setting_changes", "stored_spec", "pipeline_spec", "stored_digest", "SOURCE_CHECKSUM_KEY",
           "SETTING_DIGEST_KEY"]

from ..pipeline.checksum import SOURCE_CHECKSUM_KEY  # noqa: E402 - named here too, as before


#: Key of ``Container.extra`` holding the SHA-256 (hex) of the setting a clip was compressed with
#: (:meth:`motionrep.pipeline.compress.Pipeline.digest`); containers written before it derive it
#: (:func:`stored_digest`).
SETTING_DIGEST_KEY = "setting_sha256"


def _plain(value: Any) -> Any:
    """``value`` as JSON would give it back (tuples as lists, numpy scalars as numbers)."""
    return json.loads(json.dumps(value, default=lambda v: v.item() if hasattr(v, "item") else str(v)))


def stored_spec(container: Container) -> dict[str, Any]:
    """The setting ``container`` was written with, as :meth:`motionrep.pipeline.compress.Pipeline.setting` states
    one (``Pipeline.spec()`` with the payload and representation versions)."""
    bound = container.bound
    return {"codec": container.codec, "codec_version": container.codec_version,
            "representation": container.representation, "representation_version": container.representation_version,
            "params": _plain(dict(container.params)),
            "max_error": None if bound is None or bound.asked is None else str(bound.asked),
            "seed": container.extra.get("seed")}


def pipeline_spec(pipeline: Any) -> dict[str, Any]:
    """``pipeline.setting()`` in the plain form of :func:`stored_spec`."""
    spec = dict(pipeline.setting())
    spec["params"] = _plain(spec["params"])
    return spec


def stored_digest(container: Container) -> str:
    """The digest of the setting ``container`` was written with: the one it stores (``extra.setting_sha256``), or,
    for a container written before motionrep stored it, the digest of the setting it states (:func:`stored_spec`;
    the same digest when the setting is the same)."""
    from ..pipeline.compress import setting_digest

    stored = container.extra.get(SETTING_DIGEST_KEY)
    return stored if isinstance(stored, str) else setting_digest(stored_spec(container))


def setting_changes(container: Container, pipeline: Any) -> list[str]:
    """What differs between the setting ``container`` was written with and ``pipeline``'s, one phrase each
    (``"max_error '1%' stored, '2%' now"``); empty when the two settings have the same digest
    (:meth:`motionrep.pipeline.compress.Pipeline.digest`)."""
    if stored_digest(container) == pipeline.digest():
        return []
    stored, now = stored_spec(container), pipeline_spec(pipeline)
    if stored["codec"] != now["codec"]:  # another codec: its versions and parameters differ too, say only that
        return [f"codec {stored['codec']!r} stored, {now['codec']!r} now"]
    out = []
    for key in ("codec_version", "representation", "representation_version", "max_error", "seed"):
        if stored[key] != now[key]:
            out.append(f"{key} {stored[key]!r} stored, {now[key]!r} now")
    if stored["params"] != now["params"]:
        a, b = stored["params"], now["params"]
        diff = [f"{k}={a.get(k)!r} stored, {b.get(k)!r} now" for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]
        out.append("parameters " + "; ".join(diff))
    if not out:  # the same fields under another digest: a digest this motionrep does not make
        out.append(f"setting digest {stored_digest(container)[:12]}... stored, {pipeline.digest()[:12]}... now")
    return out


def resume_key(container: Container, pipeline: Any) -> str | None:
    """The source checksum ``container`` records when it was written with ``pipeline``'s setting (the same
    :func:`stored_digest` as ``pipeline.digest()``), else None (it must be redone)."""
    key = container.extra.get(SOURCE_CHECKSUM_KEY)
    return key if isinstance(key, str) and stored_digest(container) == pipeline.digest() else None


def journal_path(archive: str | os.PathLike[str]) -> Path:
    """The journal directory of an archive: ``.NAME.parts`` beside it (hidden, so no directory scan reads it)."""
    p = Path(archive)
    return p.parent / f".{p.name}.parts"


class ClipStore(ABC):
    """The output of a batch, written by one process (see the module docstring).

    Attributes:
        path: the output.
        force: overwrite what is there.
    """

    kind: str

    def __init__(self, path: str | os.PathLike[str], force: bool = False):
        self.path = Path(path)
        self.force = force
        self.committed: list[str] = []
        #: bytes of each clip :meth:`existing` found
        self.sizes: dict[str, int] = {}

    @abstractmethod
    def existing(self) -> dict[str, Container | None]:
        """What the output already holds, by clip name: the container, or None for one that cannot be read
        (damaged: it will be redone)."""

    @abstractmethod
    def existing_bytes(self, name: str) -> bytes:
        """The stored bytes of clip ``name`` (one of :meth:`existing`)."""

    @abstractmethod
    def commit(self, name: str, data: bytes) -> None:
        """Store clip ``name`` durably and atomically (whole or not at all)."""

    def close(self) -> None:
        """Finish the output (however the run ended); idempotent."""

    def conflicts(self, names: list[str]) -> list[str]:
        """Of ``names``, those the output already holds (what ``--force`` or ``--resume`` is needed for)."""
        have = set(self.existing())
        return [n for n in names if n in have]


class DirectoryStore(ClipStore):
    """A directory of ``<name>.mrc`` files (created when the first clip is committed)."""

    kind = "directory"

    def _file(self, name: str) -> Path:
        return self.path / f"{name}{SUFFIX}"

    def existing(self) -> dict[str, Container | None]:
        from ..io.container import read_container

        if not self.path.is_dir():
            return {}
        found: dict[str, Container | None] = {}
        for p in sorted(self.path.glob(f"*{SUFFIX}")):
            if p.name.startswith("."):
                continue
            self.sizes[p.stem] = p.stat().st_size
            try:
                found[p.stem] = read_container(p)
            except ContainerError:
                found[p.stem] = None
        return found

    def existing_bytes(self, name: str) -> bytes:
        return self._file(name).read_bytes()

    def conflicts(self, names: list[str]) -> list[str]:
        return [n for n in names if os.path.lexists(self._file(n))]

    def commit(self, name: str, data: bytes) -> None:
        from ..io.container import write_container

        self.path.mkdir(parents=True, exist_ok=True)
        write_container(data, self._file(name))
        self.committed.append(name)


class ArchiveStore(ClipStore):
    """One HDF5 archive, with a journal of committed clips until :meth:`close` (see the module docstring)."""

    kind = "archive"

    def __init__(self, path: str | os.PathLike[str], force: bool = False):
        super().__init__(path, force)
        self.journal = journal_path(self.path)
        self._closed = False
        if force and self.journal.exists():
            shutil.rmtree(self.journal)

    def _journal_files(self) -> dict[str, Path]:
        if not self.journal.is_dir():
            return {}
        return {p.stem: p for p in sorted(self.journal.glob(f"*{SUFFIX}")) if not p.name.startswith(".")}

    def existing(self) -> dict[str, Container | None]:
        from ..io.archive import Archive
        from ..io.container import unpack

        found: dict[str, Container | None] = {}
        if self.path.exists() and not self.force:
            with Archive(self.path) as a:
                for name in a.names:
                    self.sizes[name] = a.size(name)
                    try:
                        found[name] = a.container(name)
                    except ContainerError:
                        found[name] = None
        for name, p in self._journal_files().items():
            self.sizes[name] = p.stat().st_size
            try:
                found[name] = unpack(p.read_bytes(), p)
            except (ContainerError, OSError):
                found[name] = None
        return found

    def existing_bytes(self, name: str) -> bytes:
        from ..io.archive import Archive

        journal = self._journal_files()
        if name in journal:
            return journal[name].read_bytes()
        with Archive(self.path) as a:
            return a.read_bytes(name)

    def pending(self) -> int:
        """Clips in the journal (committed, not yet in the archive)."""
        return len(self._journal_files())

    def commit(self, name: str, data: bytes) -> None:
        from ..io.container import write_container

        if not name or "/" in name or name in (".", ".."):
            raise FormatError(f"invalid clip name {name!r} for an archive", self.path)
        self.journal.mkdir(parents=True, exist_ok=True)
        write_container(data, self.journal / f"{name}{SUFFIX}")
        self.committed.append(name)

    def _clips(self) -> Iterator[tuple[str, bytes]]:
        """Every clip of the new archive, in name order: the journal's, and the old archive's others."""
        from ..io.archive import Archive

        journal = self._journal_files()
        old = Archive(self.path) if self.path.exists() and not self.force else None
        try:
            names = set(journal) | set(old.names if old is not None else ())
            for name in sorted(names):
                if name in journal:
                    yield name, journal[name].read_bytes()
                else:
                    yield name, old.read_bytes(name)
        finally:
            if old is not None:
                old.close()

    def close(self) -> None:
        """Write the archive (atomically) when the journal holds clips, then remove the journal."""
        import signal
        import threading

        from ..io.archive import write_archive

        if self._closed:
            return
        self._closed = True
        if not self._journal_files():
            if self.journal.exists():
                shutil.rmtree(self.journal, ignore_errors=True)
            return
        # a second Ctrl-C (or SIGTERM, SIGHUP) must not stop the archive half written (atomic_path would keep the
        # old archive and the journal the clips, but the user asked to stop, not for a journal to resume): hold
        # them meanwhile; SIGKILL still stops it, the journal kept
        main = threading.current_thread() is threading.main_thread()
        signals = [getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n)] if main else []
        held = {s: signal.signal(s, signal.SIG_IGN) for s in signals}
        _signals.reset()  # an interrupt that stopped the run is handled: the archive of the finished clips is written
        try:
            write_archive(self._clips(), self.path)
            shutil.rmtree(self.journal, ignore_errors=True)
        finally:
            for s, handler in held.items():
                signal.signal(s, handler)


def open_store(path: str | os.PathLike[str], *, force: bool = False, resume: bool = False) -> ClipStore:
    """The store for output ``path``: an archive for ``.h5``/``.hdf5``, else a directory.

    Without ``force`` or ``resume``, an archive that exists, or a journal an interrupted run left, is an error
    (a directory's clips are checked against the names of a run with :meth:`ClipStore.conflicts`).

    Raises:
        OutputExistsError: naming the output, as above.
        FormatError: when ``path`` exists and is not what its suffix says (a file for a directory, ...).
    """
    from ..formats import is_archive_path
    from ..io._atomic import remove_stale_files

    p = Path(path)
    # what a killed run left (temporary files of an archive, a journal's clips or a directory's clips)
    remove_stale_files(p.parent if str(p.parent) else ".")
    remove_stale_files(journal_path(p) if is_archive_path(p) else p)
    if is_archive_path(p):
        if p.exists() and p.is_dir():
            raise FormatError("is a directory, not an archive", p)
        journal = journal_path(p)
        if not (force or resume):
            if journal.is_dir() and any(journal.glob(f"*{SUFFIX}")):
                n = len(list(journal.glob(f"*{SUFFIX}")))
                raise naming(OutputExistsError(f"an interrupted run left {n} finished clip{'s' if n != 1 else ''} in "
                                               f"{journal.name}; use resume=True to keep them and add the rest, or "
                                               "force=True to start over", p), "resume=True", "force=True")
            if p.exists():
                raise naming(OutputExistsError("exists; use force=True to overwrite it or resume=True to keep what it "
                                               "holds and add the rest", p), "force=True", "resume=True")
        return ArchiveStore(p, force=force)
    if p.exists() and not p.is_dir():
        raise FormatError("exists and is not a directory", p)
    return DirectoryStore(p, force=force)
