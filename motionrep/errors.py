"""Exceptions raised by motionrep.

Every error motionrep raises on purpose is a :class:`MotionrepError`.  The command line turns these into a
one-line message and exit code 1 in a single place (``motionrep.cli``); anything else is a bug and shows a
traceback.

Hierarchy::

    MotionrepError
    ├── ValidationError          (also a ValueError) a Skeleton, Motion or array did not validate
    ├── FormatError              a file could not be read or written; names the file (and line)
    │   ├── BVHFormatError
    │   ├── NPZFormatError
    │   ├── HDF5FormatError
    │   ├── GLTFFormatError
    │   ├── FBXFormatError
    │   ├── AMASSFormatError     an AMASS file, or the body model given with it, is malformed or does not fit
    │   ├── ContainerError       a .mrc file is truncated, altered or of an unknown version
    │   ├── OutputExistsError    an output exists and --force (or --resume) was not given
    │   └── PluginVersionError   (also a PluginError) a file was written by a version of a representation or
    │                            codec that the installed plugin cannot read
    ├── PluginError              plugin loading or registration went wrong
    │   ├── DuplicateNameError   two plugins registered the same name
    │   └── UnknownPluginError   no plugin provides the representation or codec asked for
    └── CodecError               a codec failed
        ├── ParameterError       (also a ValueError) a codec parameter is invalid
        │   └── SettingChangedError  resume=True over clips compressed with another setting
        ├── PayloadError         (also a ValueError) a codec payload is damaged or inconsistent
        ├── BoundNotMetError     the requested error bound could not be reached
        └── TimeLimitError       a clip took longer than its time limit (``--timeout``)

    KeyboardInterrupt
    └── Interrupted              a command was stopped by SIGINT (Ctrl-C), SIGTERM or SIGHUP (``motionrep._signals``)
        └── BatchInterrupted     ... while a batch ran; says how many clips were finished and kept
"""

from __future__ import annotations

import signal
from os import PathLike

__all__ = [
    "MotionrepError",
    "naming",
    "Note",
    "UncodableClipError",
    "ValidationError",
    "FormatError",
    "BVHFormatError",
    "NPZFormatError",
    "HDF5FormatError",
    "GLTFFormatError",
    "FBXFormatError",
    "AMASSFormatError",
    "ContainerError",
    "OutputExistsError",
    "PluginError",
    "DuplicateNameError",
    "UnknownPluginError",
    "PluginVersionError",
    "CodecError",
    "ParameterError",
    "BoundNotMetError",
    "TimeLimitError",
    "PayloadError",
    "Interrupted",
    "SettingChangedError",
    "BatchInterrupted",
]


class MotionrepError(Exception):
    """Base class of every error motionrep raises on purpose.

    A message speaks to a Python caller: it names a setting by its parameter (``max_error``, ``clip=NAME``), never
    by a command-line flag.  :attr:`parameters` lists those mentions, exactly as the message writes them; the
    command line rewrites each into its flag (one table, ``motionrep.cli._flags.FLAGS``), so its users read
    ``--max-error`` / ``--clip NAME`` instead.  Set it with :func:`naming`.
    """

    parameters: tuple[str, ...] = ()


def naming(exc: MotionrepError, *parameters: str) -> MotionrepError:
    """Record on ``exc`` the parameter mentions its message holds (``"max_error"``, ``"clip=NAME"``, ``"fps="``)
    and return it: ``raise naming(ParameterError(f"max_error must be > 0, got {v!r}"), "max_error")``."""
    exc.parameters = tuple(parameters)
    return exc


class Note(str):
    """A note for the user (what a report left out, what was assumed) that names parameters as an error does:
    the text speaks to a Python caller (``"... (max_frames=150)"``) and :attr:`parameters` lists the mentions,
    which the command line rewrites into flags.  ``Note(text, "max_frames=")``; otherwise a plain ``str``."""

    parameters: tuple[str, ...]

    def __new__(cls, text: str, *parameters: str) -> "Note":
        note = super().__new__(cls, text)
        note.parameters = tuple(parameters)
        return note

    def __reduce__(self):  # notes cross process boundaries with their mentions
        return (Note, (str(self), *self.parameters))


class ValidationError(MotionrepError, ValueError):
    """A Skeleton, Motion, feature array or setting did not validate; the message quotes what was wrong."""


class FormatError(MotionrepError):
    """A file could not be read or written.

    Args:
        message: what is wrong, without the file name.
        path: the file concerned (None when reading from memory).
        line: 1-based line number for text formats, when known.

    ``str(err)`` is ``"<path>:<line>: <message>"`` (or ``"<path>: <message>"`` without a line), on one line.
    """

    def __init__(self, message: str, path: str | PathLike[str] | None = None, line: int | None = None):
        self.message = " ".join(str(message).split())  # always a single line
        self.path = None if path is None else str(path)
        self.line = line
        super().__init__(self._format())

    def _format(self) -> str:
        where = self.path if self.path is not None else "<memory>"
        if self.line is not None:
            where = f"{where}:{self.line}"
        return f"{where}: {self.message}"

    def __reduce__(self):  # keep the attributes (and the parameter mentions) when pickled across worker processes
        return (type(self), (self.message, self.path, self.line), self.__dict__)


class BVHFormatError(FormatError):
    """A BVH file is malformed; the message names the file and the line."""


class NPZFormatError(FormatError):
    """An NPZ motion file is malformed or of an unsupported format version."""


class HDF5FormatError(FormatError):
    """An HDF5 motion file or database is malformed, of an unsupported version, or lacks the clip asked for."""


class GLTFFormatError(FormatError):
    """A glTF (``.gltf`` / ``.glb``) file is malformed, unsafe, or animates what motionrep's pose model cannot hold."""


class FBXFormatError(FormatError):
    """An FBX file is missing, malformed or truncated, holds no skeleton, or animates what motionrep's pose model
    cannot hold; also raised when the ``ufbx`` package (``pip install 'motionrep[fbx]'``) is not installed."""


class AMASSFormatError(FormatError):
    """An AMASS ``.npz`` file or its SMPL-H body model (``--body-model``) is malformed, or they do not fit each
    other; names the file concerned."""


class ContainerError(FormatError):
    """A ``.mrc`` compressed-motion container is truncated, altered, or of an unknown version."""


class OutputExistsError(FormatError):
    """An output file (or a file of an output directory) exists and the command was not told to overwrite it
    (``--force``) or to go on with it (``--resume``)."""


class PluginError(MotionrepError):
    """Loading or registering a plugin went wrong."""


class DuplicateNameError(PluginError):
    """Two plugins registered a representation or codec under the same name."""


class UnknownPluginError(PluginError, KeyError):
    """No loaded plugin provides the representation or codec asked for."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class PluginVersionError(FormatError, PluginError):
    """A file holds a payload or features written by a version of a codec or representation that the installed
    plugin cannot read; names the file."""


class CodecError(MotionrepError):
    """A codec could not encode or decode."""


class ParameterError(CodecError, ValueError):
    """A codec or representation parameter is invalid; raised before any work is done."""


class UncodableClipError(CodecError):
    """A clip the codec cannot code at all (fewer frames than its ``min_frames``); raised before any work, naming
    the codecs that can."""


class PayloadError(CodecError, ValueError):
    """A codec payload is damaged or inconsistent (a length, count or value out of range); never a wrong motion."""


class BoundNotMetError(CodecError):
    """The codec could not meet the requested error bound.

    Attributes:
        best_error: the smallest L-infinity error reached, in file units (None if nothing was tried).
        bound: the requested bound, in file units.
    """

    def __init__(self, message: str, best_error: float | None = None, bound: float | None = None):
        self.best_error = best_error
        self.bound = bound
        super().__init__(message)

    def __reduce__(self):
        return (type(self), (self.args[0] if self.args else "", self.best_error, self.bound), self.__dict__)


class TimeLimitError(CodecError):
    """Compressing one clip took longer than its time limit (``--timeout``); the other clips of a batch go on.

    Attributes:
        seconds: the limit.
    """

    def __init__(self, message: str, seconds: float | None = None):
        self.seconds = seconds
        super().__init__(message)

    def __reduce__(self):
        return (type(self), (self.args[0] if self.args else "", self.seconds), self.__dict__)


class Interrupted(KeyboardInterrupt):
    """A command was stopped by a signal (SIGINT, SIGTERM or SIGHUP); see :mod:`motionrep._signals`.

    Attributes:
        signum: the signal's number.
        note: what was kept, for the one line the command line prints (set by the code that cleaned up).
    """

    def __init__(self, signum: int = signal.SIGINT, note: str = ""):
        super().__init__(signum, note)
        self.signum, self.note = int(signum), note

    @property
    def exit_code(self) -> int:
        return 128 + self.signum


class SettingChangedError(ParameterError):
    """``resume=True`` over an output holding clips compressed with another setting (without
    ``recompress_changed=True``); nothing was touched.

    Attributes:
        changed: ``{clip name: [what differs, one phrase each]}``.
    """

    def __init__(self, message: str, changed: dict[str, list[str]] | None = None):
        self.changed = dict(changed or {})
        super().__init__(message)

    def __reduce__(self):
        return (type(self), (self.args[0] if self.args else "", self.changed), self.__dict__)


class BatchInterrupted(Interrupted):
    """A batch was stopped by a signal; every finished clip is kept in its output.

    Attributes:
        finished: clips finished (and kept) before the signal.
        total: clips of the run.
        output: the output they are kept in.
    """

    def __init__(self, signum: int = signal.SIGINT, note: str = "", finished: int = 0, total: int = 0,
                 output: str = ""):
        super().__init__(signum, note)
        self.finished, self.total, self.output = int(finished), int(total), str(output)
