"""Progress on stderr, one mechanism for every command: :class:`BatchProgress` for work counted in items (the
clips of ``compress`` and ``convert``, the runs of ``bench``, the frames ``render`` draws) and
:class:`CodecProgress` for a codec's own progress inside one clip.

On a terminal the count is a ``click.progressbar`` (bar, position, ETA, and what is going on), redrawn in place;
otherwise (a log, a pipe, CI) lines: one per finished item where the command describes items, and a heartbeat,
a line every 10 s (``MOTIONREP_PROGRESS_SECONDS``) while the work goes on, with the ETA.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from typing import Any, Callable, Mapping

import click

__all__ = ["BatchProgress", "CodecProgress"]


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
    """Progress of ``total`` items on stderr; nothing when ``quiet``.  Use as a context manager; call
    ``done(result, failed=...)`` as each item finishes (``skipped`` items, kept from an earlier run, are counted
    apart and left out of the rate), or :meth:`count_to` with the number done so far.

    On a terminal: a ``click.progressbar``, ``label [####    ] 120/2534  00:13:02  2 failed, 3.1/s``, redrawn in
    place; a failed item is named on its own line above it.  Otherwise, when ``describe`` is given:
    ``[120/2534] <describe(result)>; 2 failed, ETA 13m02s`` at most once every ``every`` seconds (and for the
    first and last item), a failed item always on its own line; without ``describe``, only the heartbeat.

    Heartbeat: while the work goes on, a line every ``every`` seconds since the last line (on a terminal the bar
    is redrawn every second), ``[0/9] working, 1m02s elapsed, ETA ?; c0: train K=3 loss=2.1e-03``, with the
    latest :meth:`note` (a codec's progress inside the item, when the work runs in this process), from a daemon
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
        self._bar: Any = None  # the click progress bar, on a terminal, once drawn

    def __enter__(self) -> "BatchProgress":
        if not self.quiet:
            self._beat = threading.Thread(target=self._heartbeat, name="motionrep-progress", daemon=True)
            self._beat.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        self._stop.set()
        if self._beat is not None:
            self._beat.join(timeout=5)
        with self._lock:
            if self._bar is not None:
                self._bar.render_finish()

    def note(self, name: str, text: str) -> None:
        """The latest activity inside an item (``name: text``), shown by the heartbeat."""
        self.activity = f"{name}: {text}"

    def _heartbeat(self) -> None:
        while not self._stop.wait(min(0.25, self.every / 2)):  # polls often enough for a short `every`
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
                    self._write(f"[{self.count}/{self.total}] {line}\n")
                    self.last = now

    def _write(self, text: str) -> None:
        self.stream.write(text)
        self.stream.flush()

    def _tail(self, _item: Any = None) -> str | None:
        """What the bar shows after its ETA: kept and failed items, the rate, the latest activity."""
        parts = [p for p in self._details() if not p.startswith("ETA")]
        if self.activity and self.count < self.total:
            parts.append(self.activity)
        return ", ".join(parts) or None

    def _draw(self, now: float) -> None:
        if self._bar is None:
            self._bar = click.progressbar(length=max(self.total, 1), label=self.label, file=self.stream, width=24,
                                          show_eta=True, show_pos=True, item_show_func=self._tail)
            self._bar.start -= now - self.start  # click measures its ETA from the work's start
        if self.count > self._bar.pos:
            self._bar.update(self.count - self._bar.pos)  # draws, with the ETA click measures
        else:
            self._bar.render_progress()  # the heartbeat: the same count, the latest activity
        self.last = now

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
        """One more item finished (``result``, for ``describe``)."""
        with self._lock:
            self._done(result, failed, skipped)

    def count_to(self, count: int) -> None:
        """``count`` items are done (for work that reports how far it is rather than each item)."""
        with self._lock:
            while self.count < min(count, self.total):
                self._done(None, False, False, quietly=self.count + 1 < count)

    def _done(self, result: Any, failed: bool, skipped: bool, quietly: bool = False) -> None:
        self.activity = None
        self.count += 1
        self.failed += bool(failed)
        self.skipped += bool(skipped)
        if self.quiet or quietly:
            return
        now = time.monotonic()
        last_item = self.count == self.total
        if self.tty:
            if failed and self.describe is not None:
                self._write("\r\033[K" + self.describe(result) + "\n")  # above the bar, drawn again below
            if now - self.last >= self.every or last_item or failed:
                self._draw(now)
            return
        if self.describe is None:
            return  # no lines per item: the heartbeat says how far the work is
        if failed or last_item or self.count == 1 or now - self.last >= self.every:
            details = self._details()
            line = "; ".join([self.describe(result)] + ([", ".join(details)] if details else []))
            self._write(f"[{self.count}/{self.total}] {line}".rstrip() + "\n")
            self.last = now


def _duration(seconds: float) -> str:
    seconds = int(round(seconds))
    if seconds >= 3600:
        return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"
    if seconds >= 60:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds}s"
