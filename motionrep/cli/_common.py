"""What the command modules share: ``-p`` parsing, progress on stderr (:mod:`motionrep.cli._progress`, re-exported
here), JSON output, file-type checks, the one overwrite policy (``--force``), the one way a run ends on a signal
(:class:`Interrupted`), ``-`` for standard output (standard input: :mod:`motionrep.cli._stdin`, re-exported here),
glob patterns in inputs, and how ``--max-error`` was read.

Overwrite policy, the same for every command: an output that exists is an error (exit 1, naming it and saying
``--force``) unless ``--force`` is given; a command that can go on with what an interrupted run left
(``compress --resume``) says so in the same message.  Use :func:`force_option` and :func:`check_overwrite`.

Signals: SIGINT (Ctrl-C), SIGTERM and SIGHUP end a command the same way (:func:`handling_signals`, installed
around every command by the group): the exception :class:`Interrupted` (a ``KeyboardInterrupt``) unwinds the
command, so every ``atomic_path`` removes its temporary file and a batch keeps its finished clips; the group then
prints one line and exits with ``128 + the signal's number`` (130 for Ctrl-C, 143 for SIGTERM, 129 for SIGHUP).
"""

from __future__ import annotations

import contextlib
import glob
import json
import os
import shutil
import signal
import sys
import tempfile
import threading
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Sequence

import click

from ..errors import Interrupted
from .. import formats
from ._flags import FLAGS, flag_text, flagged
from ._progress import BatchProgress, CodecProgress
from ._stdin import MOTION_FORMATS, STDIN_NAME, STDIO, display_name, is_stdio, stdin_inputs
from ._crosstool import (body_model_option, check_gltf_units, comparison_options, gltf_unit_options, gltf_write_options,
                         match_options)

__all__ = ["parse_params", "collect", "echo_json", "CodecProgress", "BatchProgress", "usage_suffix",
           "quiet_compile_notice", "MOTION_OUT_SUFFIXES", "force_option", "body_model_option",
           "check_overwrite", "check_outputs", "Interrupted",
           "handling_signals", "interrupt_line", "STDIO", "is_stdio", "stdin_inputs", "stdout_output",
           "expand_globs", "display_name", "STDIN_NAME", "MOTION_FORMATS", "STDOUT_NAME", "bound_for", "OUT_FORMATS",
           "match_options", "comparison_options", "gltf_unit_options", "gltf_write_options",
           "check_gltf_units", "FLAGS", "flagged", "flag_text"]

#: How messages name standard output.
STDOUT_NAME = "<stdout>"

#: Suffixes of the motion files commands write (the format from the suffix; :mod:`motionrep.formats`).
MOTION_OUT_SUFFIXES = formats.WRITE_SUFFIXES
#: ``--format`` of a command writing motions to standard output or a directory: the suffix each name stands for.
OUT_FORMATS = formats.OUT_FORMATS


# ---- several outputs --------------------------------------------------------------------------------------------
def check_outputs(paths: Iterable[Any], force: bool) -> None:
    """:func:`check_overwrite` for each of ``paths`` (standard output, ``-``, is never refused)."""
    for p in paths:
        if p is not None and not is_stdio(p):
            check_overwrite(p, force)


# ---- standard input and output -----------------------------------------------------------------------------------
#: Prefix of the folder holding what a command writes to standard output, before its process id.
_STDOUT_PREFIX = "motionrep-stdout-"


@contextlib.contextmanager
def stdout_output(path: Any, suffix: str) -> Iterator[Path]:
    """The file to write: ``path`` itself, or for ``-`` a temporary ``stdout<suffix>`` file that is copied to
    standard output once the command has written it completely (a failure writes nothing there)."""
    if not is_stdio(path):
        yield Path(path)
        return
    from ..io._atomic import remove_stale_folders

    remove_stale_folders(Path(tempfile.gettempdir()), _STDOUT_PREFIX)  # what a killed command left
    folder = tempfile.mkdtemp(prefix=f"{_STDOUT_PREFIX}{os.getpid()}-")
    tmp = Path(folder) / f"stdout{suffix}"
    try:
        yield tmp
        with open(tmp, "rb") as fh:
            shutil.copyfileobj(fh, sys.stdout.buffer)
        sys.stdout.buffer.flush()
    finally:
        shutil.rmtree(folder, ignore_errors=True)


# ---- several inputs ---------------------------------------------------------------------------------------------
def expand_globs(inputs: Iterable[Any]) -> list[Any]:
    """Inputs with glob patterns (``clips/*.bvh``, ``**`` for any depth) expanded in sorted order, for shells that
    do not expand them (and quoted patterns); a path that exists is taken as it is.

    Raises:
        click.UsageError: for a pattern that matches nothing.
    """
    out: list[Any] = []
    for raw in inputs:
        text = str(raw)
        if is_stdio(text) or Path(text).exists() or not glob.has_magic(text):
            out.append(raw)
            continue
        found = sorted(glob.glob(text, recursive=True))
        if not found:
            raise click.UsageError(f"no file matches {text!r}")
        out.extend(Path(f) for f in found)
    return out


# ---- the bound, and how it was read (motionrep.model.bound.MaxError.read_as) ------------------------------------
def bound_for(max_error: str | None, reference: Any, candidates: Sequence[Any], clip: str | None
              ) -> tuple[float | None, str | None]:
    """The bound to draw (file units) and how it was read: ``--max-error`` when given, else the bound the first
    ``.mrc`` candidate (or archive clip) was compressed within, if it says
    (:func:`motionrep.pipeline.bounds.bound_to_draw`).

    Raises:
        click.BadParameter: for a ``--max-error`` that does not parse.
    """
    from ..model.bound import parse_max_error
    from ..errors import ParameterError
    from ..pipeline.bounds import bound_to_draw

    try:
        parsed = None if max_error is None else parse_max_error(max_error)
    except ParameterError as exc:
        raise click.BadParameter(flagged(exc), param_hint="--max-error") from None
    drawn = bound_to_draw(reference, candidates, clip, max_error=parsed, asked=max_error is not None)
    if drawn is None:
        return None, None
    if drawn.source is None:
        return drawn.distance, f"--max-error {drawn.read_as}"
    return drawn.distance, f"{drawn.read_as}, as {display_name(str(drawn.source))} was compressed"


def parse_params(pairs: Iterable[str]) -> dict[str, str]:
    """``-p KEY=VALUE`` options as a dict (values as given); a pair without ``=`` is a usage error."""
    out: dict[str, str] = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep or not key.strip():
            raise click.BadParameter(f"expected KEY=VALUE, got {pair!r}", param_hint="-p/--param")
        out[key.strip()] = value.strip()
    return out


def collect(inputs: Iterable[Any], **options: Any) -> list[Any]:
    """:func:`motionrep.pipeline.sources.collect_clips`, with a problem in how the inputs were given (a file given twice,
    an unknown suffix) as a usage error (exit 2)."""
    from ..errors import ValidationError
    from ..pipeline.sources import collect_clips

    try:
        return collect_clips(expand_globs(inputs), **options)
    except ValidationError as exc:
        raise click.UsageError(flagged(exc)) from None


def echo_json(obj: Any) -> None:
    """Print ``obj`` as indented JSON on stdout."""
    click.echo(json.dumps(obj, indent=2, default=str))


def usage_suffix(path: Path, allowed: Iterable[str], what: str) -> str:
    """``path``'s suffix (lower case) when it is one of ``allowed``; otherwise a usage error (exit 2)."""
    allowed = tuple(allowed)
    suffix = path.suffix.lower()
    if suffix not in allowed:
        raise click.UsageError(f"{what} {path}: unknown file type {suffix or '(no suffix)'!r}; use one of "
                               + ", ".join(allowed))
    return suffix


def force_option(command: Callable) -> Callable:
    """The ``-f`` / ``--force`` flag of every command that writes an output (:func:`check_overwrite`)."""
    return click.option("-f", "--force", is_flag=True,
                        help="Overwrite an existing output (without it, an existing output is an error).")(command)


def quiet_compile_notice(ctx: Any, param: Any, value: bool) -> bool:
    """Click callback of every ``--quiet``: no compile notice (``motionrep.jit.NOTICE_ENV``), workers included."""
    if value:
        os.environ["MOTIONREP_COMPILE_NOTICE"] = "0"  # not imported from motionrep.jit: it imports numpy
    return value


def quiet_option(command: Callable) -> Callable:
    """The ``-q`` / ``--quiet`` flag of every command that writes: nothing printed on success (no progress, no
    report, no ``wrote ...`` line, no first-run compile notice); errors are still one line on stderr."""
    return click.option("-q", "--quiet", is_flag=True, callback=quiet_compile_notice,
                        help="Print nothing on success (no progress, no 'wrote ...' line).")(command)


def check_overwrite(path: str | os.PathLike[str], force: bool, *, resume: bool = False) -> None:
    """The one overwrite policy: ``path`` may exist only with ``force``.

    Args:
        path: an output file (or one file of an output directory).
        force: ``--force`` was given.
        resume: the command has ``--resume``, which the message then mentions.

    Raises:
        OutputExistsError: naming ``path``, when it exists and ``force`` is False.
    """
    from ..errors import OutputExistsError

    if force or not os.path.lexists(path):
        return
    how = "--force to overwrite it" + (" or --resume to keep what it holds and add the rest" if resume else "")
    raise OutputExistsError(f"exists; use {how}", path)


@contextlib.contextmanager
def handling_signals() -> Iterator[None]:
    """SIGINT, SIGTERM and SIGHUP raise :class:`Interrupted` (a ``KeyboardInterrupt``) while the block runs, and
    are remembered even when a library swallows that exception (:mod:`motionrep._signals`); the previous
    handlers are restored afterwards.  Outside the main thread nothing is installed."""
    import threading

    from .._signals import SIGNALS, handler, quiet_unraisable, reset

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    reset()
    saved = {s: signal.signal(s, handler) for s in SIGNALS}
    try:
        with quiet_unraisable():
            yield
    finally:
        for s, previous in saved.items():
            signal.signal(s, previous)


def interrupt_line(exc: BaseException) -> tuple[str, int]:
    """The one line printed for an interrupted command and its exit code (``128 + signal``)."""
    signum = exc.signum if isinstance(exc, Interrupted) else int(signal.SIGINT)
    name = {int(signal.SIGINT): "Ctrl-C"}.get(signum) or signal.Signals(signum).name
    note = exc.note if isinstance(exc, Interrupted) else ""
    return f"Interrupted ({name})" + (f": {note}" if note else ""), 128 + signum


