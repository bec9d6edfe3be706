"""Reading and writing motion files; the format is chosen by the file suffix.

=================  ==========================================================================
suffix             format
=================  ==========================================================================
``.bvh``           Biovision hierarchy (text), one clip          -- ``specs/formats/bvh.md``
``.npz``           numpy archive, one clip                       -- ``specs/formats/npz.md``
``.h5``/``.hdf5``  HDF5, one clip or a database of named clips   -- ``specs/formats/hdf5.md``
=================  ==========================================================================

Every write is atomic: the file is written under a temporary name in the same directory and renamed at the
end, so a failure never leaves a partial file behind.
"""

from __future__ import annotations

import os
from pathlib import Path

from .._model import Motion
from ..errors import FormatError
from ._atomic import atomic_path
from ._bvh import parse_bvh, read_bvh, write_bvh, format_bvh

__all__ = [
    "read",
    "write",
    "format_of",
    "SUFFIXES",
    "read_bvh",
    "write_bvh",
    "parse_bvh",
    "format_bvh",
    "atomic_path",
]

#: Known suffixes and the format each selects.
SUFFIXES: dict[str, str] = {".bvh": "bvh", ".npz": "npz", ".h5": "hdf5", ".hdf5": "hdf5"}


def format_of(path: str | os.PathLike[str]) -> str:
    """The format (``"bvh"``, ``"npz"`` or ``"hdf5"``) selected by ``path``'s suffix.

    Raises:
        FormatError: for an unknown suffix.
    """
    suffix = Path(path).suffix.lower()
    try:
        return SUFFIXES[suffix]
    except KeyError:
        raise FormatError(f"unknown file type {suffix or '(no suffix)'!r}; use one of "
                          + ", ".join(SUFFIXES), path) from None


def read(path: str | os.PathLike[str], clip: str | None = None) -> Motion:
    """Read one motion from ``path`` (format from the suffix).

    Args:
        path: a ``.bvh``, ``.npz``, ``.h5`` or ``.hdf5`` file.
        clip: for an HDF5 database, the name of the clip to read (only that clip is read); may be omitted
            when the file holds exactly one clip.

    Raises:
        FormatError: (a subclass naming the file, and the line for BVH) if the file is missing or malformed.
    """
    fmt = format_of(path)
    if fmt == "bvh":
        if clip is not None:
            raise FormatError("a BVH file holds one clip; --clip applies to HDF5 databases", path)
        return read_bvh(path)
    raise FormatError(f"{fmt} files are not supported yet", path)


def write(motion: Motion, path: str | os.PathLike[str], **options) -> None:
    """Write ``motion`` to ``path`` atomically (format from the suffix).

    Args:
        motion: the clip.
        path: target file; an existing file is replaced only once the new one is complete.
        **options: format options (BVH: ``decimals``).
    """
    fmt = format_of(path)
    if fmt == "bvh":
        write_bvh(motion, path, **options)
        return
    raise FormatError(f"{fmt} files are not supported yet", path)
