"""Reading HDF5 files under a watchdog: every h5py call of a read runs in a worker process that is killed when a
call takes longer than the ``read_timeout`` limit (:mod:`motionrep.limits`, default 60 s).

A damaged HDF5 file can make the HDF5 library spin inside one C call (holding the interpreter, so no signal or
thread can stop it) or crash the process.  Run in a worker, such a call ends in an error naming the file after
``read_timeout`` seconds -- and a crash in an error rather than the death of the caller -- while the caller goes
on (a batch run reports the file and continues; the next read starts a fresh worker).  The worker
(:mod:`motionrep.io._h5worker`) also refuses links, external storage, virtual datasets and unknown filters.

One worker serves a process (started on first use, about the cost of importing numpy and h5py; calls from
several threads take turns).  With ``read_timeout = 0``, or where the platform cannot wait on a pipe (Windows),
the same requests run in this process, without the watchdog.
"""

from __future__ import annotations

import os
import pickle
import queue
import select
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from ..limits import ENVIRONMENT, current
from ._h5worker import Refused, Session

__all__ = ["H5Reader", "H5Error", "shutdown_worker"]

_HEAD_SIZE = 8
_STARTUP_TIMEOUT = 120.0  # seconds for the worker to import numpy and h5py (a loaded machine can be slow)
_WORKER = str(Path(__file__).with_name("_h5worker.py"))
_BOOT = "import runpy, sys; sys.path.pop(0); runpy.run_path(sys.argv[1], run_name='__main__')"


class H5Error(Exception):
    """A request failed; the message says why (without the file name, which the caller adds)."""


class _Timeout(H5Error):
    pass


class _Local:
    """The requests run in this process (no watchdog)."""

    def __init__(self) -> None:
        self.session: Session | None = None
        self.lock = threading.Lock()
        self.generation = 0

    def call(self, method: str, args: tuple, timeout: float, generation: int | None) -> tuple[int, Any]:
        with self.lock:
            if self.session is None:
                self.session = Session()
            return self.generation, _unwrap(_run(self.session, method, args))


def _run(session: Session, method: str, args: tuple) -> tuple:
    try:
        return ("ok", getattr(session, method)(*args))
    except Refused as exc:
        return ("refused", str(exc))
    except MemoryError:
        return ("error", "MemoryError", "not enough memory")
    except Exception as exc:  # h5py raises many kinds on damaged files
        return ("error", type(exc).__name__, str(exc))


def _unwrap(reply: tuple) -> Any:
    if reply[0] == "ok":
        return reply[1]
    if reply[0] == "refused":
        raise H5Error(reply[1])
    name, message = reply[1], reply[2]
    if "filter returned failure" in message:  # Fletcher-32 or inflating failed
        raise H5Error("the data fails its checksum or does not decompress: the file is damaged or was altered")
    raise H5Error(f"{message} ({name})" if name not in ("OSError", "KeyError") else message.strip("'\""))


class _Launcher:
    """Starts worker processes from one thread that lives as long as this process.

    On Linux the worker asks to be killed when its parent dies (so that a spinning HDF5 call cannot outlive a
    killed caller); the kernel does this when the *thread* that started it ends, so workers must not be started
    from a caller's short-lived thread (a thread pool's, for instance).
    """

    def __init__(self) -> None:
        self.requests: queue.Queue = queue.Queue()
        self.thread: threading.Thread | None = None
        self.pid = os.getpid()
        self.lock = threading.Lock()

    def _serve(self) -> None:
        while True:
            args, reply = self.requests.get()
            try:
                reply.put(subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                           stderr=subprocess.DEVNULL, bufsize=0))
            except BaseException as exc:  # reported to the caller
                reply.put(exc)

    def popen(self, args: list[str]) -> subprocess.Popen:
        with self.lock:
            if self.thread is None or self.pid != os.getpid() or not self.thread.is_alive():
                self.requests, self.pid = queue.Queue(), os.getpid()
                self.thread = threading.Thread(target=self._serve, name="motionrep-hdf5-launcher", daemon=True)
                self.thread.start()
        reply: queue.Queue = queue.Queue()
        self.requests.put((args, reply))
        result = reply.get()
        if isinstance(result, BaseException):
            raise H5Error(f"cannot start the HDF5 reader process: {result}")
        return result


_launcher = _Launcher()


class _Worker:
    """A worker process running :func:`motionrep.io._h5worker.serve`, restarted after a timeout or a crash."""

    def __init__(self) -> None:
        self.proc: subprocess.Popen | None = None
        self.pid = os.getpid()
        self.lock = threading.Lock()
        self.generation = 0  # bumped at every (re)start: handles of an earlier worker are void

    def _start(self) -> subprocess.Popen:
        """Start a worker and wait for its greeting; the started process (its ``stdin`` and ``stdout`` are pipes,
        :meth:`_Launcher.popen`)."""
        proc = self.proc = _launcher.popen([sys.executable, "-c", _BOOT, _WORKER])
        self.pid = os.getpid()
        self.generation += 1
        try:
            self._receive(proc, _STARTUP_TIMEOUT)
        except H5Error as exc:
            self.stop()
            raise H5Error(f"cannot start the HDF5 reader process: {exc}") from None
        return proc

    def stop(self) -> None:
        proc, self.proc = self.proc, None
        if proc is not None and self.pid == os.getpid():
            try:
                proc.kill()
                proc.wait(timeout=10)
            except Exception:  # pragma: no cover
                pass
            for stream in (proc.stdin, proc.stdout):
                try:
                    stream.close()
                except Exception:  # pragma: no cover
                    pass

    def _receive(self, proc: subprocess.Popen, timeout: float) -> bytes:
        """One reply of ``proc`` (its length prefix first), or H5Error after ``timeout`` seconds or at end of
        file."""
        fd = proc.stdout.fileno()
        deadline = time.monotonic() + timeout
        head = self._read(fd, _HEAD_SIZE, deadline, timeout)
        size = int.from_bytes(head, "little")
        return self._read(fd, size, deadline, timeout) if size else b""

    @staticmethod
    def _read(fd: int, n: int, deadline: float, timeout: float) -> bytes:
        chunks = []
        while n:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([fd], [], [], left)[0]:
                raise _Timeout(f"the HDF5 library did not finish within {timeout:g} s: a damaged file can make it "
                               f"spin (if the file is only slow to read, raise {ENVIRONMENT['read_timeout']})")
            b = os.read(fd, min(n, 1 << 22))
            if not b:
                raise H5Error("the HDF5 library crashed reading it (a damaged file?)")
            chunks.append(b)
            n -= len(b)
        return b"".join(chunks)

    def call(self, method: str, args: tuple, timeout: float, generation: int | None) -> tuple[int, Any]:
        """Run ``method(*args)`` in the worker: ``(worker generation, result)``.  ``generation`` (None for a new
        file) is that of the worker that opened the file the call is about."""
        with self.lock:
            if self.pid != os.getpid():  # a forked child: the parent's worker is not ours
                self.proc, self.pid = None, os.getpid()
            if method == "close" and (self.proc is None or generation != self.generation):
                return self.generation, None  # its worker is gone, and the file with it
            proc = self.proc
            if proc is None or proc.poll() is not None:
                self.stop()
                proc = self._start()
            if generation is not None and generation != self.generation:
                raise H5Error("the file was closed after an earlier failure")
            data = pickle.dumps((method, args), protocol=pickle.HIGHEST_PROTOCOL)
            try:
                proc.stdin.write(len(data).to_bytes(_HEAD_SIZE, "little") + data)
                body = self._receive(proc, timeout)
            except BaseException as exc:  # a timeout, a crash, Ctrl-C: the worker's state is unknown
                self.stop()
                if isinstance(exc, (BrokenPipeError, ConnectionError)):
                    raise H5Error("the HDF5 library crashed reading it (a damaged file?)") from None
                raise
            return self.generation, _unwrap(pickle.loads(body))


_local = _Local()
_worker = _Worker()


def _backend() -> tuple[_Local | _Worker, float]:
    timeout = current().read_timeout
    if timeout <= 0 or sys.platform == "win32":
        return _local, 0.0
    return _worker, timeout


def shutdown_worker() -> None:
    """Stop this process's HDF5 reader process, if any (it is started again when needed)."""
    with _worker.lock:
        _worker.stop()


class H5Reader:
    """One HDF5 file open for reading through the watchdog (see the module documentation).

    Paths are relative to the file's root (``""`` is the root group) and are followed through hard links only.
    Every method raises :class:`H5Error` with a message that does not name the file.
    """

    def __init__(self, path: str | os.PathLike[str]):
        self.path = path
        self.backend, self.timeout = _backend()
        self.fid: int | None = None
        self.generation, self.fid = self.backend.call("open", (os.path.abspath(os.fspath(path)),), self.timeout, None)

    def _call(self, method: str, *args: Any) -> Any:
        if self.fid is None:
            raise H5Error("the file is closed")
        return self.backend.call(method, (self.fid, *args), self.timeout, self.generation)[1]

    def members(self, group: str) -> list[tuple[str, str]]:
        """``(name, kind)`` per member of ``group``: ``"group"``, ``"dataset"``, ``"soft link"``,
        ``"external link"`` or ``"other"``."""
        return self._call("members", group)

    def attrs(self, path: str) -> dict[str, Any]:
        """The attributes of the object at ``path`` (``Ellipsis`` for one of an unsupported type)."""
        return self._call("attrs", path)

    def describe(self, path: str) -> dict[str, Any]:
        """``shape``, ``dtype`` (``"string"`` for strings), ``itemsize`` and ``filters`` of a dataset."""
        return self._call("describe", path)

    def read(self, path: str, max_bytes: int) -> Any:
        """A dataset's data (a list of str for strings); refused if it declares more than ``max_bytes``."""
        return self._call("read", path, int(max_bytes))

    def close(self) -> None:
        if self.fid is not None and self.backend.generation == self.generation:
            try:
                self._call("close")
            except H5Error:
                pass
        self.fid = None

    def __enter__(self) -> "H5Reader":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
