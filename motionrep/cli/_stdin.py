"""``-`` as an input: standard input kept in a private temporary file, its format told by its first bytes.

Every reader of motionrep reads a path (the HDF5 reader in its own watchdog process, which a pipe cannot be
handed to), so standard input is copied once, in 1 MiB pieces, to ``stdin<suffix>`` in a new directory
``motionrep-stdin-<pid>-*`` of the temporary directory (``TMPDIR``): the directory is ``0700``, the file
``0600``, both removed when the command ends, also on Ctrl-C, SIGTERM and SIGHUP (:mod:`motionrep._signals`);
directories that a killed command left (``SIGKILL`` cannot be caught) are removed by the next one.  Memory stays
at one piece, the disk at what was piped; more than ``max_stdin_bytes`` (``MOTIONREP_MAX_STDIN_BYTES``, 16 GiB,
``specs/limits.md``) is refused, and so is a full disk, each in one line naming ``<stdin>``.  Once copied, the
file is read like any file of its format, with every limit of ``specs/limits.md``; messages name it ``<stdin>``.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Any, Iterable, Iterator, Sequence

import click

from ..formats import FORMATS, STDIN, STDIN_MOTION

__all__ = ["STDIO", "STDIN_NAME", "STDIN_FORMATS", "MOTION_FORMATS", "is_stdio", "display_name", "stdin_inputs",
           "sniff"]

#: A path given as ``-``: standard input (an input) or standard output (an output).
STDIO = "-"
#: How messages name standard input.
STDIN_NAME = "<stdin>"
#: What standard input may hold (the suffix it is read as) and how messages say it (:data:`motionrep.formats.STDIN`).
STDIN_FORMATS = STDIN
#: Formats of motions (what convert and compress read).
MOTION_FORMATS = STDIN_MOTION

_STDIN_SUFFIX = {f.name: f.stdin[0] for f in FORMATS if f.stdin is not None}
_HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
_HDF5_OFFSETS = (0, 512, 1024, 2048)  # the superblock follows a user block of 0, 512, 1024, 2048... bytes
_ZIP_MAGICS = (b"PK\x03\x04", b"PK\x05\x06")
_GLB_MAGIC = b"glTF"
_HEAD = 4096
_PIECE = 1 << 20
_PREFIX = "motionrep-stdin-"
# temporary files standing for standard input, and how messages should name them
_DISPLAY: dict[str, str] = {}


def is_stdio(path: Any) -> bool:
    """True for ``-`` (standard input or output)."""
    return str(path) == STDIO


def display_name(text: str) -> str:
    """``text`` with the temporary files standing for standard input named ``<stdin>``."""
    for tmp, shown in _DISPLAY.items():
        text = text.replace(tmp, shown)
    return text


def sniff(head: bytes) -> str | None:
    """The suffix of what a file starting with ``head`` holds (keys of :data:`STDIN_FORMATS`), or None."""
    return None if (name := _sniff_format(head)) is None else _STDIN_SUFFIX[name]


def _sniff_format(head: bytes) -> str | None:
    from ..io.container import MAGIC

    if head.startswith(MAGIC):
        return "mrc"
    if any(head[o:o + len(_HDF5_MAGIC)] == _HDF5_MAGIC for o in _HDF5_OFFSETS):
        return "hdf5"
    if head.startswith(_ZIP_MAGICS):
        return "npz"
    if head.startswith(_GLB_MAGIC):
        return "gltf"
    text = head[:64].lstrip(b"\xef\xbb\xbf \t\r\n")
    if text[:9].upper() == b"HIERARCHY":
        return "bvh"
    return None


def _read_head(stream: Any) -> bytes:
    """The first :data:`_HEAD` bytes of ``stream`` (fewer at its end): a pipe gives them in several reads."""
    head = b""
    while len(head) < _HEAD:
        piece = stream.read(_HEAD - len(head))
        if not piece:
            break
        head += piece
    return head


def _remove_stale(parent: Path) -> None:
    """Remove the spool directories of commands that were killed (their process id in the name, that process
    gone)."""
    from ..io._atomic import remove_stale_folders

    remove_stale_folders(parent, _PREFIX)


def _spool(stream: Any, head: bytes, target: Path) -> None:
    """Write ``head`` and the rest of ``stream`` to the new file ``target`` (mode 0600), within the limit.

    Raises:
        FormatError: naming ``<stdin>``, beyond ``max_stdin_bytes`` or when the disk is full.
    """
    from .. import limits
    from ..errors import FormatError

    cap = limits.current().max_stdin_bytes
    written = 0
    fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600)
    with os.fdopen(fd, "wb") as out:
        piece = head
        while piece:
            written += len(piece)
            if written > cap:
                raise FormatError(f"more than {limits.size_text(cap)} piped, the limit for standard input (raise "
                                  f"{limits.ENVIRONMENT['max_stdin_bytes']} to read it, or give the file's path)",
                                  STDIN_NAME)
            try:
                out.write(piece)
            except OSError as exc:
                if exc.errno not in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
                    raise
                raise FormatError(f"no room to keep standard input in {target.parent.parent} after "
                                  f"{limits.size_text(written - len(piece))} ({exc.strerror}); set TMPDIR to a "
                                  "directory with room, or give the file's path", STDIN_NAME) from None
            piece = stream.read(_PIECE)


@contextlib.contextmanager
def stdin_inputs(paths: Sequence[Any], allowed: Iterable[str] = tuple(STDIN_FORMATS)) -> Iterator[list[Any]]:
    """``paths`` with ``-`` replaced by a temporary file holding standard input (see the module documentation),
    its format told by its first bytes; messages name it ``<stdin>``.  At most one ``-``.

    Args:
        paths: the inputs as given.
        allowed: the suffixes (keys of :data:`STDIN_FORMATS`) the command reads from ``-``.

    Raises:
        click.UsageError: for two ``-``, or nothing piped (a terminal).
        FormatError: naming ``<stdin>``, for standard input that is empty or not one of the ``allowed`` formats,
            beyond ``max_stdin_bytes``, or that the temporary directory has no room for.
    """
    from .._signals import block, unblock
    from ..errors import FormatError

    dashes = [i for i, p in enumerate(paths) if is_stdio(p)]
    if not dashes:
        yield list(paths)
        return
    if len(dashes) > 1:
        raise click.UsageError("standard input ('-') can be read only once")
    allowed = tuple(allowed)
    if sys.stdin is None or sys.stdin.isatty():
        raise click.UsageError("'-' reads standard input, but nothing is piped into it")
    stream = sys.stdin.buffer
    head = _read_head(stream)
    suffix = sniff(head)
    if suffix not in allowed:
        what = ", ".join(STDIN_FORMATS[a] for a in allowed[:-1]) + (" or " if len(allowed) > 1 else "") \
            + STDIN_FORMATS[allowed[-1]]
        if not head:
            raise FormatError(f"is empty; this command reads {what} from '-'", STDIN_NAME)
        if suffix is None:
            raise FormatError(f"is not {what} (told by its first bytes)", STDIN_NAME)
        raise FormatError(f"is {STDIN_FORMATS[suffix]}; this command reads {what} from '-'", STDIN_NAME)
    parent = Path(tempfile.gettempdir())
    _remove_stale(parent)
    block()  # an interrupt between creating the directory and the try below would leave it behind
    try:
        folder = Path(tempfile.mkdtemp(prefix=f"{_PREFIX}{os.getpid()}-"))  # mode 0700
    except BaseException:
        unblock()
        raise
    try:
        unblock()
        tmp = folder / f"stdin{suffix}"
        _DISPLAY[str(tmp)] = STDIN_NAME
        _spool(stream, head, tmp)
        out = list(paths)
        out[dashes[0]] = tmp
        yield out
    finally:  # the name stays known: the error being raised, if any, is printed after this
        shutil.rmtree(folder, ignore_errors=True)
