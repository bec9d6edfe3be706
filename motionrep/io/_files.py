"""Opening input files safely: only regular files, never blocking on a FIFO or reading a device forever."""

from __future__ import annotations

import os
import stat
from typing import BinaryIO

from ..errors import FormatError

__all__ = ["open_regular", "read_regular", "check_regular"]

_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def _kind(mode: int) -> str:
    return next((name for test, name in _KINDS if test(mode)), "not a regular file")


def open_regular(path: str | os.PathLike[str], error: type[FormatError]) -> BinaryIO:
    """Open ``path`` for reading in binary mode; refuse anything but a regular file (after symlinks).

    The file is opened without blocking (a FIFO with no writer would block ``open`` forever) and checked with
    ``fstat`` on the open descriptor, so what is checked is what is read.

    Raises:
        FormatError: (``error``) naming the file, if it cannot be opened or is a directory, FIFO, device or socket.
    """
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        raise error(f"cannot read file: {exc.strerror or exc}", path) from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise error(f"cannot read file: it is {_kind(mode)}, not a regular file", path)
        if flags & getattr(os, "O_NONBLOCK", 0) and hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def read_regular(path: str | os.PathLike[str], error: type[FormatError]) -> bytes:
    """The bytes of the regular file ``path`` (see :func:`open_regular`)."""
    with open_regular(path, error) as fh:
        try:
            return fh.read()
        except OSError as exc:
            raise error(f"cannot read file: {exc.strerror or exc}", path) from None
        except MemoryError:
            raise error("cannot read file: not enough memory for it", path) from None


def check_regular(path: str | os.PathLike[str], error: type[FormatError]) -> None:
    """Refuse ``path`` unless it is a regular file, for libraries that open files by name (h5py)."""
    open_regular(path, error).close()
