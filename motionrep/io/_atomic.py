"""Atomic file writes: write to a temporary file beside the target, then rename over it."""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import stat
import tempfile
from pathlib import Path
from typing import Iterator

from .._signals import block, unblock
from .._signals import check as _check_interrupts

__all__ = ["atomic_path", "pid_alive", "remove_stale_files", "remove_stale_folders"]


def pid_alive(pid: int) -> bool:
    """True while process ``pid`` exists (ours or another user's): whether a temporary file it left is stale."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # it exists, and belongs to someone else
        return True
    return True


def _remove_stale(directory: Path, target: Path) -> None:
    """Remove temporary files that a killed writer of ``target`` left (``SIGKILL`` and power cuts cannot be
    caught): their name holds the writer's process id, and that process is gone."""
    prefix = f".{target.name}."
    try:
        names = [n for n in os.listdir(directory) if n.startswith(prefix) and n.endswith(f".tmp{target.suffix}")]
    except OSError:
        return
    for name in names:
        pid = name[len(prefix):].split(".", 1)[0]
        if pid.isdigit() and int(pid) != os.getpid() and not pid_alive(int(pid)):
            with contextlib.suppress(OSError):
                (directory / name).unlink()


#: A temporary name of :func:`atomic_path`: ``.<name>.<pid>.<8 random characters of mkstemp>.tmp<suffix>``.
_TEMPORARY = re.compile(r"\A\.(?P<name>.+)\.(?P<pid>[0-9]+)\.[a-z0-9_]{8}\.tmp(?P<suffix>\.[^./]*)?\Z")


def remove_stale_files(directory: str | os.PathLike[str]) -> int:
    """Remove every temporary file of :func:`atomic_path` in ``directory`` whose writer was killed (its process
    id in the name, that process gone), whatever its target; return how many were removed.  The commands that
    write (``convert``, ``compress``, ``merge``) call it for their output's directory when they start, so what a
    SIGKILL left is removed by the next run, as the standard-input spool is.  Only names of exactly that form,
    ending in ``.tmp`` and the target's suffix, are touched."""
    directory = Path(directory)
    removed = 0
    try:
        names = os.listdir(directory)
    except OSError:
        return 0
    for name in names:
        m = _TEMPORARY.match(name)
        if m is None or m.group("suffix") != Path(m.group("name")).suffix or not m.group("suffix"):
            continue
        pid = int(m.group("pid"))
        if pid != os.getpid() and not pid_alive(pid):
            with contextlib.suppress(OSError):
                (directory / name).unlink()
                removed += 1
    return removed


def remove_stale_folders(parent: str | os.PathLike[str], prefix: str) -> None:
    """Remove the directories ``<prefix><pid>-*`` in ``parent`` of processes that were killed (that process gone):
    the standard-input spool, standard output's staging folder, a worker's copy of a clip sent to it."""
    with contextlib.suppress(OSError):
        for name in os.listdir(parent):
            pid = name[len(prefix):].split("-", 1)[0] if name.startswith(prefix) else ""
            if pid.isdigit() and int(pid) != os.getpid() and not pid_alive(int(pid)):
                shutil.rmtree(Path(parent) / name, ignore_errors=True)


@contextlib.contextmanager
def atomic_path(target: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path in the target's directory; on success rename it to ``target``.

    If the body raises (or the process is interrupted: Ctrl-C, SIGTERM, SIGHUP, see :mod:`motionrep._signals`),
    the temporary file is removed and ``target`` is left untouched (it does not appear if it did not exist).  The
    temporary name (``.<name>.<pid>.<random>.tmp<suffix>``) keeps the target's suffix, so libraries that look at
    suffixes work; temporary files of the same target left by a writer that was killed are removed.  A replaced
    file keeps its permission bits; a new one gets those ``open()`` would give it.  An ``OSError`` (a read-only
    directory, a full disk) names ``target``, never the temporary file.
    """
    target = Path(target)
    directory = target.parent if str(target.parent) else Path(".")
    _remove_stale(directory, target)
    block()  # an interrupt between creating the file and the try below would leave it behind
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.{os.getpid()}.", suffix=f".tmp{target.suffix}",
                                   dir=directory)
    except BaseException as exc:
        unblock()
        if isinstance(exc, OSError):
            raise OSError(exc.errno, exc.strerror, str(target)) from None
        raise
    tmp_path = Path(tmp)
    try:  # from here on, whatever happens (an interrupt included) removes the temporary file
        unblock()
        os.close(fd)
        try:
            mode = stat.S_IMODE(os.stat(target).st_mode)  # replacing a file: keep its permissions
        except OSError:
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o666 & ~umask  # mkstemp makes 0600; give the file the permissions open() would
        os.chmod(tmp_path, mode)
        yield tmp_path
        _check_interrupts()  # an interrupt a library swallowed while writing: do not complete the file
        try:
            os.replace(tmp_path, target)
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror, str(target)) from None
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()
        _check_interrupts()  # a library turned the interrupt into another exception: report the interrupt
        if isinstance(exc, OSError) and exc.filename == str(tmp_path):
            raise OSError(exc.errno, exc.strerror, str(target)) from None
        raise
