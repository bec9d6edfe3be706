"""What the command modules share: ``-p`` parsing, progress on stderr, JSON output, file-type checks."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

import click

__all__ = ["parse_params", "collect", "echo_json", "CodecProgress", "BatchProgress", "usage_suffix", "MOTION_OUT_SUFFIXES"]

#: Suffixes of the motion files commands write (the format from the suffix).
MOTION_OUT_SUFFIXES = (".bvh", ".npz", ".h5", ".hdf5")


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
    """:func:`motionrep.sources.collect_clips`, with a problem in how the inputs were given (a file given twice,
    an unknown suffix) as a usage error (exit 2)."""
    from ..errors import ValidationError
    from ..sources import collect_clips

    try:
        return collect_clips(inputs, **options)
    except ValidationError as exc:
        raise click.UsageError(str(exc)) from None


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


class CodecProgress:
    """A codec's progress on stderr, in the codec's words (``Codec.describe_progress``): the first report of
    every stage, then at most one line every ``every`` seconds."""

    def __init__(self, codec: Any, every: float = 0.5):
        self.codec, self.every = codec, every
        self.last = -float("inf")
        self.stage: str | None = None

    def __call__(self, stage: str, fields: Mapping[str, Any]) -> None:
        now = time.monotonic()
        if stage == self.stage and now - self.last < self.every:
            return
        self.last, self.stage = now, stage
        click.echo("  " + self.codec.describe_progress(stage, fields), err=True)


class BatchProgress:
    """Progress of many items on stderr: a bar with an ETA on a terminal, else one line per finished item
    (``describe(item_result)``); nothing when ``quiet``.  Use as a context manager; call ``done(result)``."""

    def __init__(self, total: int, label: str, describe: Callable[[Any], str] | None = None, quiet: bool = False):
        self.total, self.count, self.describe, self.quiet = total, 0, describe, quiet
        self.bar = None
        if not quiet and sys.stderr.isatty():
            self.bar = click.progressbar(length=total, label=label, file=sys.stderr, show_pos=True, show_eta=True)

    def __enter__(self) -> "BatchProgress":
        if self.bar is not None:
            self.bar.__enter__()
        return self

    def __exit__(self, *exc: Any) -> None:
        if self.bar is not None:
            self.bar.__exit__(*exc)

    def done(self, result: Any) -> None:
        self.count += 1
        if self.quiet:
            return
        if self.bar is not None:
            self.bar.update(1)
        elif self.describe is not None:
            click.echo(f"[{self.count}/{self.total}] {self.describe(result)}", err=True)
