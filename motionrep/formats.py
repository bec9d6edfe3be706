"""Every file format motionrep reads or writes, in one table: the suffixes that select it, whether motionrep
reads and writes motions in it, whether a file holds several clips, what it holds when it comes on standard
input.  Every list of suffixes in the library and the command line is derived from :data:`FORMATS`
(``tests/test_layout.py`` checks that no other module spells a clip suffix).

==========  =====================  =====  ======  ==========  ===============================================
format      suffixes               reads  writes  clips       notes
==========  =====================  =====  ======  ==========  ===============================================
``bvh``     ``.bvh``               yes    yes     one         text; standard input: BVH text
``npz``     ``.npz``               yes    yes     one         motions or features; AMASS clips (read only)
``hdf5``    ``.h5``, ``.hdf5``     yes    yes     many        a database of clips, or an archive of ``.mrc``
``gltf``    ``.gltf``, ``.glb``    yes    yes     many        ``.glb`` the binary variant (and on stdin)
``fbx``     ``.fbx``               yes    no      many        read through ``ufbx`` (the ``fbx`` extra)
``mrc``     ``.mrc``               --     --      one         a compressed clip (:mod:`motionrep.io.container`)
==========  =====================  =====  ======  ==========  ===============================================

This module is standard library only (it sits outside :mod:`motionrep.io`, whose package imports numpy) so that
the command modules can build their options from it without paying for the library.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Format", "FORMATS", "BY_NAME", "BY_SUFFIX", "format_named", "suffix_format", "is_archive_path",
           "MOTION_SUFFIXES", "WRITE_SUFFIXES", "MANY_CLIP_SUFFIXES", "SOURCE_SUFFIXES", "COMPRESSED_SUFFIXES",
           "CONTAINER_SUFFIX", "STDIN", "STDIN_MOTION", "STDIN_COMPRESSED", "OUT_FORMATS"]


@dataclass(frozen=True)
class Format:
    """One file format.

    Attributes:
        name: the format's name (``"bvh"``, ``"hdf5"``...): what :func:`motionrep.io.format_of` returns and
            ``info`` shows.
        suffixes: the suffixes that select it, lower case, the usual one first; each is also a ``--format`` name
            of a written format (without the dot).
        aliases: further suffixes for the same bytes (``.hdf5`` beside ``.h5``), never a ``--format`` name.
        motion: :mod:`motionrep.io` reads motions from it (``.mrc`` is decoded, not read, so False).
        writes: :mod:`motionrep.io` writes motions to it.
        many: a file may hold several named clips (``--clip`` picks one).
        archive: a file may be an archive of compressed clips (:mod:`motionrep.io.archive`).
        stdin: the suffix a file read from standard input is given when its first bytes are this format, and
            how messages name it (``(".h5", "an HDF5 file")``); None when standard input cannot hold it.
        binary: the suffix of the binary variant, when the format has a text and a binary one (glTF's ``.glb``).
    """

    name: str
    suffixes: tuple[str, ...]
    aliases: tuple[str, ...] = ()
    motion: bool = True
    writes: bool = True
    many: bool = False
    archive: bool = False
    stdin: tuple[str, str] | None = None
    binary: str | None = None

    @property
    def all_suffixes(self) -> tuple[str, ...]:
        """The suffixes and their aliases, in that order."""
        return self.suffixes + self.aliases


#: The formats, in the order every list of suffixes (and every "use one of ..." message) gives them.
FORMATS: tuple[Format, ...] = (
    Format("bvh", (".bvh",), stdin=(".bvh", "BVH text")),
    Format("npz", (".npz",), stdin=(".npz", "an NPZ file")),
    Format("hdf5", (".h5",), aliases=(".hdf5",), many=True, archive=True, stdin=(".h5", "an HDF5 file")),
    Format("gltf", (".gltf", ".glb"), many=True, stdin=(".glb", "a .glb file"), binary=".glb"),
    Format("fbx", (".fbx",), writes=False, many=True),
    Format("mrc", (".mrc",), motion=False, writes=False, stdin=(".mrc", "a .mrc file")),
)

#: Each format by name.
BY_NAME: dict[str, Format] = {f.name: f for f in FORMATS}
#: Each suffix (aliases included) and the format it selects.
BY_SUFFIX: dict[str, Format] = {s: f for f in FORMATS for s in f.all_suffixes}


def format_named(path: str | os.PathLike[str]) -> Format | None:
    """The format ``path``'s suffix selects (case-insensitive), or None for an unknown suffix."""
    return BY_SUFFIX.get(Path(path).suffix.lower())


def suffix_format(path: str | os.PathLike[str]) -> str | None:
    """The name of the format ``path``'s suffix selects, or None."""
    found = format_named(path)
    return None if found is None else found.name


def is_archive_path(path: str | os.PathLike[str]) -> bool:
    """Whether ``path``'s suffix names a format that may be an archive of compressed clips (``.h5``)."""
    found = format_named(path)
    return found is not None and found.archive


def _suffixes(formats: Iterable[Format]) -> tuple[str, ...]:
    return tuple(s for f in formats for s in f.all_suffixes)


#: The suffix of a compressed clip, the container's.
CONTAINER_SUFFIX: str = BY_NAME["mrc"].suffixes[0]
#: Files :mod:`motionrep.io` reads motions from.
MOTION_SUFFIXES: tuple[str, ...] = _suffixes(f for f in FORMATS if f.motion)
#: Files :mod:`motionrep.io` writes motions to.
WRITE_SUFFIXES: tuple[str, ...] = _suffixes(f for f in FORMATS if f.writes)
#: Files that may hold several named clips (``--clip``).
MANY_CLIP_SUFFIXES: tuple[str, ...] = _suffixes(f for f in FORMATS if f.many)
#: Every clip-bearing file: motions and compressed clips (:func:`motionrep.pipeline.sources.open_source`).
SOURCE_SUFFIXES: tuple[str, ...] = _suffixes(FORMATS)
#: Files of compressed clips: the container first, then archives of them.
COMPRESSED_SUFFIXES: tuple[str, ...] = (CONTAINER_SUFFIX,) + _suffixes(f for f in FORMATS if f.archive)
#: What standard input may hold: the suffix it is read as, and how messages name it.
STDIN: dict[str, str] = dict(f.stdin for f in FORMATS if f.stdin is not None)
#: The standard-input suffixes of motions (what ``convert`` and ``compress`` read from ``-``).
STDIN_MOTION: tuple[str, ...] = tuple(f.stdin[0] for f in FORMATS if f.stdin is not None and f.motion)
#: The standard-input suffixes of compressed clips (what ``decompress`` reads from ``-``): the container first.
STDIN_COMPRESSED: tuple[str, ...] = tuple(f.stdin[0] for f in (BY_NAME["mrc"], *(f for f in FORMATS if f.archive))
                                          if f.stdin is not None)
#: ``--format`` of a command writing motions to standard output or a directory: each name and its suffix.
OUT_FORMATS: dict[str, str] = {s[1:]: s for f in FORMATS if f.writes for s in f.suffixes}
