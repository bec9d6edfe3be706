"""``motionrep render``: stick-figure pictures of a clip and its decoded copy.

Exit codes: 0 on success; 1 when the pictures cannot be made (unreadable input, skeletons that differ, clips
of different length, a frame selection that selects nothing, ``.mp4`` without ffmpeg, matplotlib missing), with
one line on stderr and no output file left behind; 2 for a usage error (unknown output suffix, malformed
``--frames`` or ``--size``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

import click

from ..errors import ValidationError
from ._common import (STDIN_NAME, BatchProgress, body_model_option, bound_for, check_outputs, comparison_options,
                      flagged, force_option, is_stdio, match_options, quiet_option, stdin_inputs)

__all__ = ["render"]


def _read(path: Path, clip: str | None) -> Any:
    """The clip of ``path`` (``clip`` of a database or archive; any clip-bearing file, ``.mrc`` decoded)."""
    from ..pipeline.sources import open_source

    with open_source(path) as src:
        return src.read(clip if src.kind in ("database", "archive") else None)


def _parsed_by(parser: str) -> Callable[[click.Context, click.Parameter, str | None], Any]:
    """A click callback: the option's value parsed by ``motionrep.present.render.<parser>`` (imported when an option is
    given), its ``ValidationError`` a usage error."""

    def callback(ctx: click.Context, param: click.Parameter, value: str | None) -> Any:
        if value is None:
            return None
        from ..present import render

        try:
            return getattr(render, parser)(value)
        except ValidationError as exc:
            raise click.BadParameter(flagged(exc)) from None

    return callback


class _Bar:
    """``render``'s progress (``progress(done, total)`` from the drawing): the one progress mechanism,
    :class:`BatchProgress` over the frames, once the drawing says how many (a bar with an ETA on a terminal, a
    heartbeat line every 10 s otherwise)."""

    def __init__(self, label: str):
        self.label = label
        self.bar: BatchProgress | None = None

    def __call__(self, done: int, total: int) -> None:
        if self.bar is None:
            self.bar = BatchProgress(total, self.label).__enter__()
        self.bar.count_to(done)

    def __enter__(self) -> "_Bar":
        return self

    def __exit__(self, *exc: Any) -> None:
        if self.bar is not None:
            self.bar.__exit__(*exc)


def _labels(reference: Path, candidate: Path | None) -> tuple[str, str]:
    if candidate is None:
        return reference.name, ""
    if reference.name != candidate.name:
        return reference.name, candidate.name
    return str(reference), str(candidate)


@click.command("render")
@click.argument("reference", metavar="REF", type=click.Path(exists=True, dir_okay=False, allow_dash=True,
                                                            path_type=Path))
@click.argument("candidate", metavar="[CAND]", required=False,
                type=click.Path(exists=True, dir_okay=False, allow_dash=True, path_type=Path))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="OUT.gif (animation), OUT.png (filmstrip) or OUT.mp4 (animation; needs ffmpeg).")
@click.option("--frames", metavar="A:B[:STEP]", callback=_parsed_by("parse_frames"),
              help="Reference frames to show, a Python slice (0:120, 200:, -60:, 0:300:10). With a step, exactly "
                   "those frames are shown; without one, frames are picked by time (animation) or --count are "
                   "spread evenly (filmstrip).  Default: the whole clip.")
@click.option("--fps", type=float, default=None,
              help="Playback rate of an animation.  Default: the clip's rate, at most 25 (GIF) or 30 (MP4); "
                   "frames are skipped to play in real time.")
@click.option("--count", type=click.IntRange(min=1), default=8, show_default=True,
              help="Pictures in a filmstrip (when --frames has no step).")
@click.option("--max-frames", type=click.IntRange(min=1), default=150, show_default=True,
              help="Most frames in an animation or pictures in a filmstrip; a longer animation is shown at a "
                   "lower rate, still in real time.")
@click.option("--size", metavar="WxH", callback=_parsed_by("parse_size"),
              help="Output size in pixels (the whole filmstrip for PNG).  Default: fitted to the motion.")
@click.option("--up", type=click.Choice(["auto", "y", "z"]), default="auto", show_default=True,
              help="The data's up axis (BVH is usually Y-up); auto guesses it from the motion.")
@click.option("--clip", metavar="NAME",
              help="The clip to read from HDF5 databases, archives or glTF files (both files).")
@click.option("--max-error", "max_error", metavar="BOUND",
              help="Bound to draw on the error panel: '2%' of the character height or a distance in file units. "
                   "Default: the bound a .mrc candidate was compressed within, if it says.")
@comparison_options
@force_option
@quiet_option
@body_model_option
def render(reference: Path, candidate: Path | None, output: Path, frames: slice | None, fps: float | None,
           count: int, max_frames: int, size: tuple[int, int] | None, up: str, clip: str | None,
           max_error: str | None, force: bool, match: str = "order", strip_prefix: tuple[str, ...] = (),
           ignore_extra: bool = False, resample: bool = False, quiet: bool = False) -> None:
    """Draw REF (red) and the decoded CAND (blue) overlaid as stick figures, each frame's worst joint circled.

    REF and CAND may be any motion file motionrep reads, .mrc included, of the same skeleton ('-': BVH, NPZ,
    HDF5, .glb or .mrc from standard input).  A CAND at another frame rate is resampled at REF's frame times when
    both span the same time.  A panel under the pictures shows the error over time and the bound; the clip's
    worst joint is shown zoomed at its worst frame (an inset of an animation, the last cell of a filmstrip).
    On a terminal, a progress bar with an ETA shows on stderr while drawing.
    A CAND after another tool: --match names (--strip-prefix, --ignore-extra)
    and --resample as in evaluate; only the compared points and frames are
    drawn, and notes list what was left out.

    \b
    Examples:
      motionrep render walk.bvh walk.mrc -o walk.gif
      motionrep render walk.bvh walk.mrc -o walk.png --count 12
      motionrep render walk.bvh walk.mrc -o detail.png --frames 180:230:10
      motionrep render walk.bvh -o walk.gif --frames 0:240 --fps 20
    """
    from ..present.render import OUTPUT_SUFFIXES, check_output
    from ..present.render import render as draw

    options = match_options(match, strip_prefix, ignore_extra, resample)
    options = None if options.strict else options

    if output.suffix.lower() not in OUTPUT_SUFFIXES:
        raise click.UsageError(f"output {output}: cannot draw to {output.suffix or '(no suffix)'!r} files; use one "
                               "of " + ", ".join(OUTPUT_SUFFIXES))
    check_output(output)  # fail before reading anything (e.g. .mp4 without ffmpeg)
    check_outputs([output], force)
    with stdin_inputs([reference] + ([] if candidate is None else [candidate])) as paths:
        ref = _read(paths[0], clip)
        cand = None if candidate is None else _read(paths[1], clip)
        bound, how = bound_for(max_error, ref, paths[1:], clip)
    if how and not quiet:
        click.echo(f"bound: {how}", err=True)
    names = _labels(reference, candidate)
    names = tuple(STDIN_NAME if is_stdio(p) else n for p, n in zip((reference, candidate), names))
    with _Bar(f"drawing {output.name}") as bar:
        result = draw(output, ref, cand, names=names, frames=frames, fps=fps, count=count,
                      max_frames=max_frames, size=size, up=up, bound=bound, options=options,
                      progress=None if quiet else bar)
    for note in result.notes:
        click.echo(f"note: {flagged(note)}", err=True)
    n = len(result.frames)
    what = (f"{n} frame{'s' if n != 1 else ''} at {result.fps:.3g} fps" if result.fps is not None
            else f"{n} picture{'s' if n != 1 else ''}")
    line = f"wrote {output}: {what}, {result.size[0]}x{result.size[1]} pixels"
    if result.error is not None:
        from ..present.render import describe_error

        line += f"; worst joint {describe_error(result.error)}"
    if not quiet:
        click.echo(line)
