"""Clip-bearing files, opened once, and the clips of many inputs gathered with one naming rule.

:func:`open_source` opens any file that holds motion clips and gives one interface to all of them:

=================  ==============  =============================================================
suffix             ``kind``        clips
=================  ==============  =============================================================
``.bvh``, ``.npz``  ``"motion"``    one, named after the file's stem (an NPZ may hold features)
``.h5``/``.hdf5``  ``"database"``  the clips of a motionrep HDF5 file (motions or features)
``.h5``/``.hdf5``  ``"archive"``   the compressed clips of an archive of ``.mrc`` containers
``.gltf``/``.glb`` ``"database"``  the animations of a glTF file, by name
``.mrc``           ``"compressed"``  one compressed clip, named after the file's stem
=================  ==============  =============================================================

A :class:`Source` has ``.names`` and ``.read(name) -> Motion`` (compressed clips are decoded at their own frame
rate), ``.read_stored(name)`` (features as stored), ``.container(name)`` (compressed kinds) and ``.size(name)``.
An HDF5 file is opened once, however many clips are read from it; use a source as a context manager.

:func:`collect_clips` turns command-line inputs (files, directories, databases, archives) into
:class:`ClipRef` s, with the same rules for every command:

* **suffixes**: a directory is searched recursively for :data:`SCAN_SUFFIXES` files (hidden files and
  directories skipped), in sorted order; a file given by name may be any :data:`SOURCE_SUFFIXES` file;
* **names**: a file given by name is named after its stem; a file found in a directory after its path relative
  to that directory, without suffix, with ``/`` replaced by :data:`NAME_SEPARATOR` (``a/b.bvh`` -> ``a__b``);
  the clips of a database or archive keep their own names when it is the only file, and otherwise are named
  ``<file name>__<clip>`` (a one-clip database: just the file name);
* **collisions**: names that two files would share keep their suffix (``walk.bvh``, ``walk.npz``); a name still
  shared, or a file given twice, is an error naming both.

Size: one concern, every kind of clip-bearing file behind one interface and the one naming rule for many
inputs; the kinds are small classes side by side (BVH/NPZ, HDF5 database, glTF, ``.mrc``, archive), which
splitting would scatter.
"""

from __future__ import annotations

import os
from abc import ABC, abstractmethod
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Iterator

from .. import formats
from ..model._pose import Motion
from ..errors import FormatError, ValidationError, naming

__all__ = [
    "SOURCE_SUFFIXES",
    "scan_files",
    "SCAN_SUFFIXES",
    "CLIP_SUFFIXES",
    "NAME_SEPARATOR",
    "Source",
    "open_source",
    "ClipRef",
    "collect_clips",
    "read_refs",
    "listing",
]

#: Suffixes :func:`open_source` opens (from :data:`motionrep.formats.FORMATS`, as the two below).
SOURCE_SUFFIXES: tuple[str, ...] = formats.SOURCE_SUFFIXES
#: Suffixes picked up when a directory is searched (compressed ``.mrc`` files are not: they are outputs).
SCAN_SUFFIXES: tuple[str, ...] = formats.MOTION_SUFFIXES
#: Suffixes of files that may hold several named clips (``--clip NAME`` chooses one).
CLIP_SUFFIXES: tuple[str, ...] = formats.MANY_CLIP_SUFFIXES
#: Replaces ``/`` when a path relative to a directory becomes a clip name.
NAME_SEPARATOR = "__"
_MAX_LISTED = 10


def listing(names: list[str], most: int = _MAX_LISTED) -> str:
    """``a, b, c, ... (N more)``: names for a one-line message."""
    shown = ", ".join(names[:most])
    return shown + (f", ... ({len(names) - most} more)" if len(names) > most else "")


class Source(ABC):
    """A clip-bearing file, open for reading (see the module docstring for the kinds).

    Attributes:
        path: the file.
        kind: ``"motion"``, ``"database"``, ``"compressed"`` or ``"archive"``.
    """

    kind: str

    def __init__(self, path: str | os.PathLike[str]):
        self.path = Path(path)

    @property
    @abstractmethod
    def names(self) -> list[str]:
        """The clips' names."""

    @abstractmethod
    def read_stored(self, name: str | None = None) -> tuple[str, Any]:
        """``(name, clip)``: a :class:`~motionrep.Motion`, or a :class:`~motionrep.io.FeatureClip` as stored."""

    def read(self, name: str | None = None) -> Motion:
        """Clip ``name`` as a motion (``name`` may be omitted when the file holds one clip).

        Raises:
            FormatError: naming the file (and clip) when it cannot be read.
        """
        return self.read_stored(name)[1]

    def container(self, name: str | None = None) -> Any:
        """The :class:`~motionrep.io.container.Container` of a compressed clip.

        Raises:
            FormatError: for a source that does not hold compressed clips.
        """
        raise FormatError("holds motions, not compressed clips", self.path)

    def size(self, name: str | None = None) -> int | None:
        """Bytes clip ``name`` takes in the file: the file's size for a file of one clip, the container's size
        for a clip of an archive, None for a clip of a database of several."""
        return self.path.stat().st_size if len(self.names) == 1 else None

    def resolve(self, name: str | None) -> str:
        """The clip ``name`` names: itself if the file holds it, the only clip when ``name`` is None.

        Raises:
            FormatError: naming the file and listing its clips, when ``name`` is not one of them, or is None and
                the file holds several.
        """
        names = self.names
        if name is None:
            if len(names) != 1:
                raise naming(FormatError(f"holds {len(names)} clips; choose one with clip=NAME: {listing(names)}",
                                         self.path), "clip=NAME")
            return names[0]
        if name not in names:
            raise FormatError(f"no clip named {name!r}; clips in this file: {listing(names)}", self.path)
        return name

    def close(self) -> None:
        """Release the file."""

    def __enter__(self) -> "Source":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.kind} {str(self.path)!r}>"


class _MotionFile(Source):
    """A BVH or NPZ file: one clip, read when asked for."""

    kind = "motion"

    @property
    def names(self) -> list[str]:
        return [self.path.stem]

    def read_stored(self, name: str | None = None) -> tuple[str, Any]:
        from ..io import read_stored

        self.resolve(name)
        return read_stored(self.path)

    def read(self, name: str | None = None) -> Motion:
        from ..io import read

        self.resolve(name)
        return read(self.path)

    def size(self, name: str | None = None) -> int | None:
        return self.path.stat().st_size


class _Database(Source):
    """A motionrep HDF5 file of motion or feature clips."""

    kind = "database"

    def __init__(self, path: str | os.PathLike[str], database: Any):
        super().__init__(path)
        self.database = database

    @property
    def names(self) -> list[str]:
        return self.database.names

    def read_stored(self, name: str | None = None) -> tuple[str, Any]:
        return self.database.read_stored(name)

    def read(self, name: str | None = None) -> Motion:
        return self.database.read(name)

    def summaries(self) -> list[dict[str, Any]]:
        """Per clip: name, kind, frames, fps, duration, joints (no frame data read)."""
        return self.database.summaries()

    def close(self) -> None:
        self.database.close()


class _GLTF(_Database):
    """A glTF file: its animations are named clips, like a database's (parsed once, each read when asked for)."""

    def __init__(self, path: str | os.PathLike[str]):
        from ..io._gltf import GLTFFile

        super().__init__(path, GLTFFile(path))

    def read_stored(self, name: str | None = None) -> tuple[str, Any]:
        return self.database.read_clip(name)


class _FBX(_GLTF):
    """An FBX file: its anim stacks are named clips (loaded once, each read when asked for)."""

    def __init__(self, path: str | os.PathLike[str]):
        from ..io._fbx import FBXFile

        _Database.__init__(self, path, FBXFile(path))


class _Compressed(Source):
    """One ``.mrc`` file, verified when first used; decoded at its own frame rate."""

    kind = "compressed"

    def __init__(self, path: str | os.PathLike[str]):
        super().__init__(path)
        self._container: Any = None

    @property
    def names(self) -> list[str]:
        return [self.path.stem]

    def container(self, name: str | None = None) -> Any:
        from ..io.container import read_container

        self.resolve(name)
        if self._container is None:
            self._container = read_container(self.path)
        return self._container

    def read_stored(self, name: str | None = None) -> tuple[str, Any]:
        from .decode import decompress

        container = self.container(name)
        return self.path.stem, decompress(container, path=self.path)

    def size(self, name: str | None = None) -> int | None:
        return self.path.stat().st_size


class _Archive(Source):
    """An HDF5 archive of ``.mrc`` containers."""

    kind = "archive"

    def __init__(self, path: str | os.PathLike[str], archive: Any):
        super().__init__(path)
        self.archive = archive

    @property
    def names(self) -> list[str]:
        return self.archive.names

    def container(self, name: str | None = None) -> Any:
        name = self.resolve(name)
        return self.archive.container(name)

    def read_stored(self, name: str | None = None) -> tuple[str, Any]:
        from .decode import decompress

        name = self.resolve(name)
        return name, decompress(self.archive.container(name), path=f"{self.path}[{name}]")

    def size(self, name: str | None = None) -> int | None:
        return self.archive.size(self.resolve(name))

    def close(self) -> None:
        self.archive.close()


def open_source(path: str | os.PathLike[str]) -> Source:
    """Open a clip-bearing file (format from its suffix; an HDF5 file is a database or an archive by its
    content).  Use it as a context manager, or call ``close()``.

    Raises:
        FormatError: naming the file, for an unknown suffix, a missing file, or an HDF5 file that is neither a
            motionrep database nor an archive.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in SOURCE_SUFFIXES:
        raise FormatError(f"unknown file type {suffix or '(no suffix)'!r}; use one of " + ", ".join(SOURCE_SUFFIXES),
                          p)
    if not p.exists():
        raise FormatError("no such file or directory", p)
    if p.is_dir():
        raise FormatError("is a directory, not a file", p)
    fmt = formats.BY_SUFFIX[suffix].name
    if fmt == "mrc":
        return _Compressed(p)
    if fmt == "gltf":
        return _GLTF(p)
    if fmt == "fbx":
        return _FBX(p)
    if fmt != "hdf5":
        return _MotionFile(p)
    from ..io.archive import ARCHIVE_FORMAT, Archive
    from ..io._hdf5 import HDF5Database, open_hdf5_file, root_format

    f = open_hdf5_file(p)
    try:
        if root_format(f) == ARCHIVE_FORMAT:
            return _Archive(p, Archive(p, f))
        return _Database(p, HDF5Database(p, f))
    except BaseException:
        f.close()
        raise


# ---------------------------------------------------------------------------------------------------------------
# many inputs
# ---------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ClipRef:
    """One clip of the inputs of a many-clip command.

    Attributes:
        name: its unique name in the outputs (see the module docstring).
        path: the file holding it.
        clip: its name inside a database or archive, else None.
        source_bytes: bytes it takes in its file (see :meth:`Source.size`), for the compression figures.
    """

    name: str
    path: str
    clip: str | None = None
    source_bytes: int | None = None

    @property
    def source(self) -> str:
        """``path`` or ``path[clip]``."""
        return self.path if self.clip is None else f"{self.path}[{self.clip}]"

    def open(self) -> Source:
        """Its file, opened."""
        return open_source(self.path)

    def read(self) -> Motion:
        """Read it (opening its file for this one clip)."""
        with self.open() as src:
            return src.read(self.clip)

    def read_with_checksum(self) -> tuple[Motion, str]:
        """The clip and its :func:`motionrep.pipeline.checksum.clip_checksum`, its file opened once."""
        from .checksum import clip_checksum

        with self.open() as src:
            return src.read(self.clip), clip_checksum(src, self.clip)

    def checksum(self) -> str:
        """:func:`motionrep.pipeline.checksum.clip_checksum` of the clip."""
        from .checksum import clip_checksum

        with self.open() as src:
            return clip_checksum(src, self.clip)


def read_refs(refs: Iterable[ClipRef], stored: bool = False,
              reader: Any = None) -> Iterator[tuple[ClipRef, Any]]:
    """``(ref, clip)`` for every ref, in order, each file opened once for a run of its clips: the clip is a
    :class:`~motionrep.Motion`, or with ``stored`` as stored (see :meth:`Source.read_stored`), or what
    ``reader(source, ref)`` returns."""
    source: Source | None = None
    try:
        for ref in refs:
            if source is None or str(source.path) != ref.path:
                if source is not None:
                    source.close()
                source = None
                source = open_source(ref.path)
            if reader is not None:
                yield ref, reader(source, ref)
            else:
                yield ref, (source.read_stored(ref.clip)[1] if stored else source.read(ref.clip))
    finally:
        if source is not None:
            source.close()


def _hidden(rel: Path) -> bool:
    return any(part.startswith(".") for part in rel.parts)


def _inside(path: Path, excluded: list[Path]) -> bool:
    r = path.resolve()
    return any(r == e or e in r.parents for e in excluded)


def _scan(directory: Path, excluded: list[Path], suffixes: tuple[str, ...]) -> list[tuple[Path, str]]:
    found = []
    for p in sorted(directory.rglob("*")):
        rel = p.relative_to(directory)
        if _hidden(rel) or p.suffix.lower() not in suffixes or not p.is_file() or _inside(p, excluded):
            continue
        found.append((p, NAME_SEPARATOR.join(rel.with_suffix("").parts)))
    if not found:
        raise FormatError("no " + ", ".join(suffixes) + " files in this directory", directory)
    return found


def scan_files(directory: str | os.PathLike[str], suffixes: tuple[str, ...] = SOURCE_SUFFIXES) -> list[Path]:
    """The files of ``directory`` (recursively, sorted, hidden ones skipped) with one of ``suffixes``: what
    ``motionrep info DIR`` describes, one row each.

    Raises:
        FormatError: naming the directory when it holds none.
    """
    return [p for p, _ in _scan(Path(directory), [], suffixes)]


def collect_clips(inputs: Iterable[str | os.PathLike[str]], *, clip: str | None = None,
                  exclude: Iterable[str | os.PathLike[str]] = (),
                  scan: Iterable[str] = SCAN_SUFFIXES) -> list[ClipRef]:
    """The clips of files, directories, databases and archives, named by the rules of the module docstring.

    Args:
        inputs: paths as given on the command line.
        clip: take only this clip out of each database or archive (an error where one lacks it).
        exclude: paths never read back in (a command's own output, and everything below it).
        scan: the suffixes a directory is searched for (default :data:`SCAN_SUFFIXES`; commands that read
            compressed clips add ``.mrc``).

    Raises:
        ValidationError: for a file given twice, or of an unknown type (a problem with the inputs as given).
        FormatError: naming the file, for a missing file, an unreadable database or archive, a clip name two
            inputs share, or no clips at all.
    """
    excluded = [Path(e).resolve() for e in exclude]
    files: list[tuple[Path, str]] = []
    for raw in inputs:
        p = Path(raw)
        if p.is_dir():
            files.extend(_scan(p, excluded, tuple(scan)))
        elif not p.exists():
            raise FormatError("no such file or directory", p)
        else:
            if p.suffix.lower() not in SOURCE_SUFFIXES:
                raise ValidationError(f"input {p}: unknown file type {p.suffix or '(no suffix)'!r}; use one of "
                                      + ", ".join(SOURCE_SUFFIXES))
            files.append((p, p.stem))
    first: dict[Path, Path] = {}
    for p, _ in files:
        r = p.resolve()
        if r in first:
            also = f" (also as {first[r]})" if first[r] != p else ""
            raise ValidationError(f"input {p} is given twice{also}")
        first[r] = p
    count: dict[str, int] = {}
    for _, name in files:
        count[name] = count.get(name, 0) + 1
    files = [(p, name + p.suffix if count[name] > 1 else name) for p, name in files]
    alone = len(files) == 1
    refs: list[ClipRef] = []
    for p, name in files:
        with open_source(p) as src:
            names = src.names
            if src.kind in ("database", "archive"):
                if clip is not None:
                    src.resolve(clip)
                    names = [clip]
                if alone or clip is not None:
                    refs.extend(ClipRef(c, str(p), c, src.size(c)) for c in names)
                elif len(names) == 1:
                    refs.append(ClipRef(name, str(p), names[0], src.size(names[0])))
                else:
                    refs.extend(ClipRef(f"{name}{NAME_SEPARATOR}{c}", str(p), c, None) for c in names)
            else:
                refs.append(ClipRef(name, str(p), None, src.size()))
    if not refs:
        raise FormatError("no motion clips found", ", ".join(str(i) for i in inputs))
    seen: dict[str, ClipRef] = {}
    for r in refs:
        if r.name in seen:
            raise FormatError(f"two inputs would both be clip {r.name!r} ({seen[r.name].source} and {r.source}); "
                              "rename one", r.path)
        seen[r.name] = r
    return refs
