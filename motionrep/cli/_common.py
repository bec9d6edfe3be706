"""What the command modules share: ``-p`` parsing, progress on stderr, JSON output, file-type checks, the one
overwrite policy (``--force``), the one way a run ends on a signal (:class:`Interrupted`), ``-`` for
standard output (standard input: :mod:`motionrep.cli._stdin`, re-exported here), glob patterns in inputs, and
how ``--max-error`` was read.

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
import time
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Mapping, Sequence

import click

from ..errors import Interrupted
from .. import formats
from ._flags import FLAGS, flag_text, flagged
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


class CodecProgress:
    """A codec's progress on stderr, in the codec's words (``Codec.describe_progress``): the first report of
    every stage, then at most one line every ``every`` seconds.  A codec's internal diagnostics (reports with
    ``diagnostic=True``, such as the transform codec's ``bisect regions=...``) only when ``verbose``."""

    def __init__(self, codec: Any, every: float = 0.5, verbose: bool = False):
        self.codec, self.every, self.verbose = codec, every, verbose
        self.last = -float("inf")
        self.stage: str | None = None
        self.start: float | None = None
        self.done = 0.0

    def text(self, stage: str, fields: Mapping[str, Any]) -> str:
        """The codec's line, with an ETA when the codec says how much of its most work is ``done`` (an upper
        bound: a codec that meets the bound early stops sooner)."""
        now = time.monotonic()
        line = self.codec.describe_progress(stage, fields)
        done = fields.get("done")
        if not isinstance(done, (int, float)):
            return line
        if self.start is None or done < self.done:  # the first report, or a new fit (a window) began
            self.start = now
        self.done = float(done)
        if 0.05 <= done < 1 and now > self.start:  # below 5 %, too little measured to say
            line += f", ETA at most {_duration((now - self.start) * (1 - done) / done)}"
        return line

    def shows(self, fields: Mapping[str, Any]) -> bool:
        """Whether a report with these fields is shown (a diagnostic only when verbose)."""
        return self.verbose or not fields.get("diagnostic")

    def __call__(self, stage: str, fields: Mapping[str, Any]) -> None:
        if not self.shows(fields):
            return
        now = time.monotonic()
        line = self.text(stage, fields)
        if stage == self.stage and now - self.last < self.every:
            return
        self.last, self.stage = now, stage
        click.echo("  " + line, err=True)


class BatchProgress:
    """Progress of many items on stderr; nothing when ``quiet``.  Use as a context manager; call
    ``done(result, failed=...)`` as each item finishes (``skipped`` items, kept from an earlier run, are counted
    apart and left out of the rate).

    On a terminal: one line redrawn in place, ``label [####    ] 120/2534, 2 failed, 3.1/s, ETA 13m02s``.
    Otherwise: ``[120/2534] <describe(result)>; 2 failed, ETA 13m02s`` at most once every ``every`` seconds
    (and for the first and last item); a failed item is always named on its own line.

    Heartbeat: while no item finishes, a line every ``every`` seconds all the same (on a terminal the line is
    redrawn every second), ``[0/9] working, 1m02s elapsed, ETA ?; c0: train K=3 loss=2.1e-03``, with the
    latest :meth:`note` (a codec's progress inside the clip, when the work runs in this process), from a daemon
    thread started by ``__enter__`` and stopped by ``__exit__``.
    """

    def __init__(self, total: int, label: str, describe: Callable[[Any], str] | None = None, quiet: bool = False,
                 every: float | None = None, stream: Any = None):
        self.total, self.label, self.describe, self.quiet = total, label, describe, quiet
        self.count = self.failed = self.skipped = 0
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        if every is None:
            every = float(os.environ.get("MOTIONREP_PROGRESS_SECONDS", "0.2" if self.tty else "10"))
        self.every = every
        self.start = time.monotonic()
        self.last = -float("inf")
        self.activity: str | None = None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._beat: threading.Thread | None = None
        self._drawn = False

    def __enter__(self) -> "BatchProgress":
        if not self.quiet:
            self._beat = threading.Thread(target=self._heartbeat, name="motionrep-progress", daemon=True)
            self._beat.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        self._stop.set()
        if self._beat is not None:
            self._beat.join(timeout=5)
        if self.tty and not self.quiet and (self.count or self.activity is not None or self._drawn):
            self.stream.write("\n")
            self.stream.flush()

    def note(self, name: str, text: str) -> None:
        """The latest activity inside an item (``name: text``), shown by the heartbeat."""
        self.activity = f"{name}: {text}"

    def _heartbeat(self) -> None:
        while not self._stop.wait(0.25):
            now = time.monotonic()
            with self._lock:
                if self.count >= self.total:
                    return
                if self.tty:
                    if now - self.last >= 1.0:
                        self._draw(now)
                elif now - self.last >= self.every and now - self.start >= self.every:
                    parts = [f"working, {_duration(now - self.start)} elapsed"] + self._details()
                    line = ", ".join(parts) + (f"; {self.activity}" if self.activity else "")
                    self.stream.write(f"[{self.count}/{self.total}] {line}\n")
                    self.stream.flush()
                    self.last = now

    def _draw(self, now: float) -> None:
        width = 24
        filled = int(width * self.count / max(self.total, 1))
        tail = f" {self.activity}" if self.activity and self.count < self.total else ""
        self.stream.write(f"\r\033[K{self.label} [{'#' * filled}{' ' * (width - filled)}] {self.status()}{tail}")
        self.stream.flush()
        self.last = now
        self._drawn = True

    def eta(self) -> str:
        """Time left at the rate so far (skipped items excluded), as ``1h02m``, ``3m05s`` or ``12s``."""
        worked = self.count - self.skipped
        elapsed = time.monotonic() - self.start
        if worked <= 0 or elapsed <= 0:
            return "?"
        left = (self.total - self.count) * elapsed / worked
        return _duration(left)

    def status(self) -> str:
        """``120/2534, 2 failed, 3.1/s, ETA 13m02s``."""
        return ", ".join([f"{self.count}/{self.total}"] + self._details())

    def _details(self) -> list[str]:
        parts = []
        if self.skipped:
            parts.append(f"{self.skipped} kept")
        if self.failed:
            parts.append(f"{self.failed} failed")
        elapsed = time.monotonic() - self.start
        worked = self.count - self.skipped
        if worked and elapsed > 0:
            parts.append(f"{worked / elapsed:.3g}/s")
        if self.count < self.total:
            parts.append(f"ETA {self.eta()}")
        return parts

    def done(self, result: Any, failed: bool = False, skipped: bool = False) -> None:
        with self._lock:
            self._done(result, failed, skipped)

    def _done(self, result: Any, failed: bool, skipped: bool) -> None:
        self.activity = None
        self.count += 1
        self.failed += bool(failed)
        self.skipped += bool(skipped)
        if self.quiet:
            return
        now = time.monotonic()
        last_item = self.count == self.total
        if self.tty:
            if failed and self.describe is not None:
                self.stream.write("\r\033[K" + self.describe(result) + "\n")
            if now - self.last >= self.every or last_item or failed:
                self._draw(now)
            return
        if failed or last_item or self.count == 1 or now - self.last >= self.every:
            what = [self.describe(result)] if self.describe is not None else []
            line = "; ".join(what + [", ".join(self._details())] if self._details() else what)
            self.stream.write(f"[{self.count}/{self.total}] {line}".rstrip() + "\n")
            self.stream.flush()
            self.last = now


def _duration(seconds: float) -> str:
    seconds = int(round(seconds))
    if seconds >= 3600:
        return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"
    if seconds >= 60:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds}s"
