"""HDF5 archives of ``.mrc`` containers: many compressed clips in one file (layout in ``specs/container.md``).

An archive holds one complete ``.mrc`` container per clip (so every clip keeps its own checksum and metadata),
written by ``motionrep compress DIR|DATABASE.h5 -o OUT.h5``::

    /                attribute format = "motionrep-mrc-archive", attribute format_version = 2
    /clips/<name>    uint8 dataset: the bytes of the clip's .mrc container (Fletcher-32 checksum since version 2)

:class:`Archive` is an archive open for reading (names, sizes and containers on demand, the file opened once);
:func:`read_archive` and :func:`archive_sizes` are one-call shortcuts.  Every container read is verified like a
``.mrc`` file (:func:`motionrep.io.container.unpack`); problems raise :class:`~motionrep.errors.ContainerError`
naming the file and the clip.  Archives are read like HDF5 databases, through the watchdog of
:mod:`motionrep.io._h5read`: links, external storage and unknown filters are refused, and a container larger
than the ``max_clip_bytes`` limit is refused before it is read (``specs/limits.md``).
"""

from __future__ import annotations

import os
from typing import Any, Iterable, Mapping

import numpy as np

from .container import Container, unpack
from ..errors import ContainerError, FormatError

__all__ = ["ARCHIVE_FORMAT", "ARCHIVE_VERSION", "Archive", "write_archive", "is_archive", "read_archive",
           "archive_sizes"]

#: Value of the root ``format`` attribute of an archive.
ARCHIVE_FORMAT = "motionrep-mrc-archive"
#: Archive layout version written by this motionrep (never reused).  Version 2: a Fletcher-32 checksum on every
#: container and the HDF5 1.10 object formats (checksummed metadata).
ARCHIVE_VERSION = 2
#: Versions this motionrep reads.
READABLE_ARCHIVE_VERSIONS = (1, 2)


def write_archive(clips: Mapping[str, bytes] | Iterable[tuple[str, bytes]], path: str | os.PathLike[str]) -> None:
    """Write ``{name: .mrc bytes}`` (or ``(name, bytes)`` pairs) to one HDF5 archive, atomically.

    Raises:
        FormatError: for a clip name that cannot be an HDF5 dataset name (empty, ``/``, ``.`` or ``..``).
    """
    import h5py

    from . import atomic_path

    from ._hdf5 import LIBVER

    items = clips.items() if isinstance(clips, Mapping) else clips
    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w", libver=LIBVER) as f:
            f.attrs["format"] = ARCHIVE_FORMAT
            f.attrs["format_version"] = np.int64(ARCHIVE_VERSION)
            group = f.create_group("clips")
            for name, data in items:
                if not name or "/" in name or name in (".", ".."):
                    raise FormatError(f"invalid clip name {name!r} for an archive", path)
                group.create_dataset(name, data=np.frombuffer(data, dtype=np.uint8), fletcher32=bool(len(data)))


class Archive:
    """An archive open for reading (``with Archive(path) as a: ...``).

    Args:
        path: the file (named in errors).
        file: the file already open (:func:`motionrep.io._hdf5.open_hdf5_file`); it is then owned, and closed, by
            this object.

    Raises:
        ContainerError: naming the file if it cannot be opened, is not an archive or has another version.
    """

    def __init__(self, path: str | os.PathLike[str], file: Any = None):
        from ._hdf5 import open_hdf5_file

        self.path = path
        self._file = open_hdf5_file(path, ContainerError) if file is None else file
        try:
            self._clips = self._check()
        except BaseException:
            self._file.close()
            raise

    def _check(self) -> dict[str, str]:
        from ._h5read import H5Error
        from ._hdf5 import root_format

        f = self._file
        if root_format(f, ContainerError) != ARCHIVE_FORMAT:
            raise ContainerError("not a motionrep archive of .mrc containers", self.path)
        try:
            version = f.attrs("").get("format_version", -1)
            version = np.asarray(-1 if version is Ellipsis else version)
            kinds = dict(f.members(""))
            clips = dict(f.members("clips")) if kinds.get("clips") == "group" else None
        except H5Error as exc:
            raise ContainerError(f"cannot read archive: {exc}", self.path) from None
        shown = int(version) if version.ndim == 0 and version.dtype.kind in "iu" else "(missing or invalid)"
        if shown not in READABLE_ARCHIVE_VERSIONS:
            raise ContainerError(f"unsupported archive version {shown} (this motionrep reads "
                                 f"{', '.join(map(str, READABLE_ARCHIVE_VERSIONS))})", self.path)
        if clips is None:
            raise ContainerError("invalid archive: no group '/clips'", self.path)
        for name, kind in clips.items():
            if kind != "dataset":
                raise ContainerError(f"invalid archive: clip {name!r} is not a dataset but a {kind}"
                                     + ("; motionrep follows no links in a file" if "link" in kind else ""), self.path)
        return clips

    @property
    def names(self) -> list[str]:
        """The clip names, sorted."""
        return sorted(self._clips)

    def _dataset(self, name: str) -> dict[str, Any]:
        from ._h5read import H5Error

        if name not in self._clips:
            raise ContainerError(f"no clip {name!r} in archive; clips: {', '.join(self.names)}", self.path)
        try:
            desc = self._file.describe(f"clips/{name}")
        except H5Error as exc:
            raise ContainerError(f"cannot read clip {name!r}: {exc}", self.path) from None
        if desc["shape"] is None or len(desc["shape"]) != 1 or desc["dtype"] != np.uint8:
            raise ContainerError(f"invalid archive: clip {name!r} is not a 1-D uint8 dataset", self.path)
        return desc

    def size(self, name: str) -> int:
        """Bytes of clip ``name``'s container (not read)."""
        return int(self._dataset(name)["shape"][0])

    def read_bytes(self, name: str) -> bytes:
        """The ``.mrc`` bytes of clip ``name``, unverified.

        Raises:
            ContainerError: naming the file and clip if it cannot be read, fails its checksum, or is larger than
                the ``max_clip_bytes`` limit (checked before reading).
        """
        from ..limits import ENVIRONMENT, current
        from ._h5read import H5Error

        size = self.size(name)
        lim = current().max_clip_bytes
        if size > lim:
            raise ContainerError(f"clip {name!r}: a {size}-byte container, more than the limit of {lim} bytes "
                                 f"(raise {ENVIRONMENT['max_clip_bytes']} to read it)", self.path)
        try:
            return self._file.read(f"clips/{name}", lim).tobytes()
        except H5Error as exc:
            raise ContainerError(f"cannot read clip {name!r}: {exc}", self.path) from None

    def container(self, name: str) -> Container:
        """The container of clip ``name``, verified like a ``.mrc`` file.

        Raises:
            ContainerError: naming the file and clip when it is missing or fails its checks.
        """
        return unpack(self.read_bytes(name), f"{self.path}[{name}]")

    def close(self) -> None:
        """Close the file."""
        self._file.close()

    def __enter__(self) -> "Archive":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def is_archive(path: str | os.PathLike[str]) -> bool:
    """True if ``path`` is an HDF5 archive of ``.mrc`` containers."""
    from ._hdf5 import open_hdf5_file, root_format

    try:
        with open_hdf5_file(path, ContainerError) as f:
            return root_format(f, ContainerError) == ARCHIVE_FORMAT
    except ContainerError:
        return False


def archive_sizes(path: str | os.PathLike[str]) -> dict[str, int]:
    """``{clip name: bytes of its .mrc container}`` of an archive, in name order, without reading them.

    Raises:
        ContainerError: naming the file if it is not an archive.
    """
    with Archive(path) as archive:
        return {name: archive.size(name) for name in archive.names}


def read_archive(path: str | os.PathLike[str], clip: str | None = None) -> dict[str, Container]:
    """The containers of an archive (all, in name order, or only ``clip``), each verified like a ``.mrc`` file.

    Raises:
        ContainerError: naming the file and clip when one is missing or fails its checks.
    """
    with Archive(path) as archive:
        return {name: archive.container(name) for name in ([clip] if clip is not None else archive.names)}
