"""Interrupts (SIGINT, SIGTERM, SIGHUP) as one exception, and what the library needs to never complete a write
that was interrupted.

The command line (:func:`motionrep.cli._common.handling_signals`) installs :func:`handler` for the three signals:
each raises :class:`Interrupted` (a ``KeyboardInterrupt``) in the main thread, so every ``with atomic_path(...)``
block on the way out removes its temporary file.

Two things make that reliable:

- A library can swallow an exception raised inside its own callbacks, or turn it into another one (h5py does
  both for Ctrl-C during an HDF5 write: "Exception ignored", or a ``TypeError`` from a type converter, and the
  command went on to exit 0).  The signal is therefore also remembered: :func:`check` raises it again, and
  ``atomic_path`` calls it before it renames a finished temporary file over the target and when it cleans up
  after another exception; the command line treats any exception that ends a command after a signal as that
  signal.  Python's report of the swallowed exception is not printed.
- Between creating a temporary file and being ready to remove it there are a few steps where an exception would
  leave the file behind: :func:`block` and :func:`unblock` hold an interrupt back (remembered, raised at
  ``unblock``) for those steps.  Masking the signals would not do: another thread of the process (BLAS's,
  numba's) may receive them, and Python then runs the handler in the main thread anyway.
"""

from __future__ import annotations

import contextlib
import signal
import sys
from collections.abc import Iterator

from .errors import Interrupted

__all__ = ["Interrupted", "SIGNALS", "handler", "check", "pending", "reset", "block", "unblock",
           "quiet_unraisable"]

#: The signals that interrupt a command.
SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))

_pending: int | None = None
_deferred = 0  # > 0 while block() holds interrupts back


def handler(signum: int, frame: object) -> None:
    """The signal handler: remember the signal and raise :class:`Interrupted` (unless :func:`block` holds it)."""
    global _pending
    _pending = int(signum)
    if not _deferred:
        raise Interrupted(signum)


def pending() -> int | None:
    """The signal that arrived since :func:`reset`, if any."""
    return _pending


def reset() -> None:
    """Forget a signal that arrived (a new command starts)."""
    global _pending
    _pending = None


def check() -> None:
    """Raise :class:`Interrupted` if a signal arrived, even if its exception was swallowed on the way."""
    if _pending is not None:
        raise Interrupted(_pending)


def block() -> None:
    """Hold interrupts back until :func:`unblock`: one that arrives meanwhile is remembered, not raised."""
    global _deferred
    _deferred += 1


def unblock() -> None:
    """End a :func:`block`; an interrupt that arrived meanwhile is raised now."""
    global _deferred
    _deferred -= 1
    if not _deferred:
        check()


@contextlib.contextmanager
def quiet_unraisable() -> Iterator[None]:
    """Do not print Python's "Exception ignored" report of an :class:`Interrupted` that a library swallowed (the
    signal is remembered and acted on)."""
    hook = sys.unraisablehook

    def quiet(unraisable) -> None:
        if not isinstance(unraisable.exc_value, Interrupted):
            hook(unraisable)

    sys.unraisablehook = quiet
    try:
        yield
    finally:
        sys.unraisablehook = hook
