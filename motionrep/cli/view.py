"""``motionrep view``: one self-contained HTML page with a clip and its decoded copies in 3D.

Exit codes: 0 on success; 1 when the page cannot be made (unreadable input, skeletons that differ, clips of
different length), with one line on stderr and no output file left behind; 2 for a usage error (an output that
is not ``.html``, one that exists without ``--force``, ``--clip`` for files of one clip).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from ._flags import flagged
from ._common import (STDIN_NAME, body_model_option, bound_for, check_outputs, comparison_options, expand_globs,
                      force_option, is_stdio, match_options, quiet_option, stdin_inputs)

__all__ = ["view"]


def _clip_facts(src: Any, name: str) -> list[tuple[str, str]]:
    """What a compressed clip says about itself: ``info``'s facts (:func:`motionrep.present.info.compressed_facts`,
    every figure), with the flags the command line names."""
    from ..present.info import compressed_facts, compressed_info

    return [(label, flagged(text))
            for label, text in compressed_facts(compressed_info(src.container(name), name, src.size(name)), True)]


def _settings(src: Any, name: str) -> str:
    """A compressed clip's codec and settings in a few words, for its label: ``"svd rank=4, within 2%"``."""
    from ..pipeline.compress import describe_outcome

    c = src.container(name)
    words = [c.codec]
    outcome = describe_outcome(c)
    if outcome:
        words.append(outcome)
    asked = None if c.bound is None else c.bound.asked
    text = " ".join(words)
    return f"{text}, within {asked}" if asked is not None else text


@click.command("view")
@click.argument("reference", metavar="REF")
@click.argument("candidates", metavar="[CAND]...", nargs=-1)
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="OUT.html: one file, no server or network needed; open it in any browser.")
@click.option("--clip", metavar="NAME", help="The clip to show from HDF5 databases, archives and glTF files.")
@click.option("--max-error", "max_error", metavar="BOUND",
              help="Bound to draw on the error curve: '2%' of the character height or a distance in file units. "
                   "Default: the bound the first .mrc candidate was compressed within, if any.")
@click.option("--up", type=click.Choice(["auto", "y", "z"]), default="auto", show_default=True,
              help="The data's up axis (BVH is usually Y-up); auto guesses it from the motion.")
@comparison_options
@force_option
@quiet_option
@body_model_option
def view(reference: str, candidates: tuple[str, ...], output: Path, clip: str | None, max_error: str | None,
         up: str, force: bool, match: str = "order", strip_prefix: tuple[str, ...] = (), ignore_extra: bool = False,
         resample: bool = False, quiet: bool = False) -> None:
    """Write one HTML page showing REF and its decoded copies CAND... in 3D.

    The skeletons are overlaid (REF red, the candidates blue, green, orange...),
    with play/pause, a timeline to scrub, orbit/zoom/pan, the error of every
    candidate frame by frame with the bound and each one's worst frame one
    click away, an error magnification slider (x1 to x100), joints coloured
    by their error, and each clip's facts (codec, parameters, sizes, ratios,
    errors).  Each clip is labelled by enough of its path to tell the files
    apart and, for a .mrc, its codec and settings.  REF and
    CAND may be any motion file motionrep reads, .mrc and .glb included, of the
    same skeleton; '-' reads BVH, NPZ, HDF5, .glb or .mrc from standard input;
    quoted glob patterns give several candidates.  A CAND at another frame
    rate is resampled at REF's frame times.  A CAND after another tool:
    --match names (--strip-prefix, --ignore-extra) and --resample as in
    evaluate; notes list what each error left out.

    \b
    Examples:
      motionrep view walk.bvh walk.mrc -o walk.html
      motionrep view walk.bvh walk_svd.mrc walk_fourier.mrc -o compare.html
      motionrep view dance.glb -o dance.html --clip Dance
    """
    from ..pipeline.sources import open_source
    from ..present.view import MAX_CANDIDATES, ViewClip, distinct_names, write_view

    options = match_options(match, strip_prefix, ignore_extra, resample)
    options = None if options.strict else options

    if output.suffix.lower() not in (".html", ".htm"):
        raise click.UsageError(f"output {output}: the viewer is an HTML page; name it OUT.html")
    check_outputs([output], force)
    cands = expand_globs(candidates)
    if len(cands) > MAX_CANDIDATES:
        raise click.UsageError(f"the viewer shows at most {MAX_CANDIDATES} candidates at once, got {len(cands)}")
    given = [reference, *cands]
    # enough of each path to tell the files apart (svd/walk.mrc, fourier/walk.mrc)
    shown = distinct_names([STDIN_NAME if is_stdio(g) else str(g) for g in given])
    with stdin_inputs(given) as paths:
        clips: list[ViewClip] = []
        for k, path in enumerate(paths):
            with open_source(Path(path)) as src:
                many = src.kind in ("database", "archive")
                if clip is not None and not many:
                    raise click.UsageError(f"--clip applies to HDF5 databases and archives and to glTF files, "
                                           f"not {given[k]}")
                name = src.resolve(clip if many else None)
                motion = src.read(name)
                coded = src.kind in ("compressed", "archive")
                facts = _clip_facts(src, name) if coded else []
                settings = _settings(src, name) if coded else ""
            label = f"{shown[k]}[{name}]" if many else shown[k]
            clips.append(ViewClip(motion, label, tuple(facts), settings))
        bound, how = bound_for(max_error, clips[0].motion, paths[1:], clip)
    result = write_view(output, clips[0], clips[1:], bound=bound, bound_text=how, up=up, match=options)
    for note in result.notes:
        click.echo(f"note: {flagged(note)}", err=True)
    line = f"wrote {output}: {result.frames} frames, {len(clips)} clip{'s' if len(clips) > 1 else ''}, " \
           f"{result.bytes / 1e6:.1f} MB"
    if result.errors:
        from ..present.render import describe_error

        line += f"; worst joint of {clips[1].label}: {describe_error(result.errors[0])}"
    if not quiet:
        click.echo(line)
