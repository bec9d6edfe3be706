"""``motionrep decompress``: compressed clips (``.mrc`` files, archives, directories of them) back to motion files.

Exit codes: 0 on success; 1 for a file problem (malformed or altered file, codec not installed, an output that
exists without ``--force``), with one line on stderr and no output file; 2 for a usage error; 130 on Ctrl-C.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Iterator

import click

from .. import formats
from ._common import (MOTION_OUT_SUFFIXES, OUT_FORMATS, STDOUT_NAME, check_gltf_units, check_overwrite, collect,
                      force_option, gltf_unit_options, gltf_write_options, is_stdio, quiet_option, stdin_inputs,
                      stdout_output, usage_suffix)

__all__ = ["decompress"]

#: What decompress reads from a directory: .mrc files and archives.
COMPRESSED_SUFFIXES = formats.COMPRESSED_SUFFIXES


def decoded_clips(refs: list, fps: float | None) -> Iterator[tuple[Any, Any]]:
    """``(ref, motion)`` for compressed clips, each file opened once for a run of its clips.

    Raises:
        FormatError: naming the file, for one that holds motions rather than compressed clips.
    """
    from ..pipeline.compress import decompress as decode
    from ..errors import FormatError
    from ..pipeline.sources import read_refs

    def decoded(src: Any, ref: Any) -> Any:
        if src.kind not in ("compressed", "archive"):
            raise FormatError("holds motions, not compressed clips: use 'motionrep convert'", ref.path)
        return decode(src.container(ref.clip), fps, path=ref.source)

    return read_refs(refs, reader=decoded)


@click.command("decompress")
@click.argument("inputs", metavar="IN...", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("-o", "--output", "output", required=True, type=click.Path(path_type=Path),
              help="OUT.bvh, OUT.npz or OUT.h5 for one clip ('-': standard output, see --format); for several, "
                   "OUT.h5 (a motion database) or a directory (one .bvh per clip, or --format).")
@click.option("--fps", type=float, default=None, help="Resample to this frame rate (decoded at the new times).")
@click.option("--clip", metavar="NAME", help="Only this clip of an archive.")
@click.option("--format", "out_format", type=click.Choice(sorted(OUT_FORMATS)), default=None,
              help="File format written to standard output (-o -) or into a directory OUT/ (default: bvh).")
@gltf_unit_options
@force_option
@quiet_option
def decompress(inputs: tuple[Path, ...], output: Path, fps: float | None, clip: str | None, out_format: str | None,
               gltf_scale: float | None, units: str | None, force: bool, quiet: bool) -> None:
    """Decode compressed clips IN (.mrc files, archives, or directories of them) into motion files.

    Clips are named as compress named them (a directory's .mrc files by their
    path relative to it, an archive's by its clip names). One clip goes to
    OUT.bvh / OUT.npz / OUT.h5; several to OUT.h5 (a database) or the
    directory OUT/ (one .bvh per clip, or --format). An existing output needs
    --force (-f).

    \b
    Standard input and output: IN '-' reads a .mrc file or an archive from
    standard input (told by its first bytes, named <stdin>); -o - writes the
    one decoded clip to standard output, as BVH (or --format npz/h5/glb/gltf),
    only once it is complete.

    \b
    glTF size: --units cm|m|in|mm or --scale M (metres per file unit); without
    either, the units the clip states, else the guess of convert (a character
    1-2.5 m tall), said in one line on stderr.

    \b
    Examples:
      motionrep decompress walk.mrc -o walk2.bvh
      motionrep decompress walk.mrc -o walk.glb --units cm
      motionrep decompress walk.mrc -o walk60.bvh --fps 60
      motionrep decompress clips.h5 -o clips_decoded.h5
      motionrep decompress clips_mrc/ -o clips_decoded/
      cat walk.mrc | motionrep decompress - -o - | head
      cat clips.h5 | motionrep decompress - -o clips_decoded/
    """
    if fps is not None and not fps > 0:
        raise click.BadParameter("must be > 0", param_hint="--fps")
    to_stdout = is_stdio(output)
    if out_format is not None and not (to_stdout or not output.suffix):
        raise click.UsageError("--format applies only when OUT is '-' or a directory; otherwise the suffix decides")
    for p in inputs:
        if not (is_stdio(p) or p.is_dir()):
            usage_suffix(p, COMPRESSED_SUFFIXES, "input")
    suffix = OUT_FORMATS[out_format or "bvh"]
    written_as = suffix if to_stdout or not output.suffix else output.suffix.lower()
    gltf_out = written_as in formats.BY_NAME["gltf"].all_suffixes
    check_gltf_units(gltf_scale, units, gltf_out)
    with stdin_inputs(inputs, allowed=formats.STDIN_COMPRESSED) as given:
        _decompress(given, output, fps, clip, suffix, force, (gltf_scale, units), quiet)


def _decompress(inputs: list, output: Path, fps: float | None, clip: str | None, suffix: str, force: bool,
                units: tuple[float | None, str | None] = (None, None), quiet: bool = False) -> None:
    from ..pipeline.compress import write_decoded

    def written(motion: Any, target: Path, shown: Any) -> None:
        write_decoded(motion, target, **gltf_write_options(motion, target, *units, shown=shown))

    to_stdout = is_stdio(output)
    refs = collect(inputs, clip=clip, exclude=[] if to_stdout else [output], scan=COMPRESSED_SUFFIXES)
    if to_stdout and len(refs) != 1:
        from ..pipeline.sources import listing

        raise click.UsageError(f"{STDOUT_NAME} holds one clip but the inputs hold {len(refs)} "
                               f"({listing([r.name for r in refs])}); pick one with --clip, or write OUT.h5 or a "
                               "directory")
    to_file = to_stdout or output.suffix.lower() in MOTION_OUT_SUFFIXES
    if len(refs) == 1 and to_file:
        if not to_stdout:
            check_overwrite(output, force)
        with stdout_output(output, suffix) as target:
            ref, motion = next(decoded_clips(refs, fps))
            written(motion, target, STDOUT_NAME if to_stdout else output)
        which = f" (clip {ref.clip})" if ref.clip is not None else ""
        shown = STDOUT_NAME if to_stdout else output
        from ..model.timefmt import fps_text

        if not quiet:
            click.echo(f"wrote {shown}{which}: {motion.num_frames} frames at {fps_text(motion.fps)} fps",
                       err=to_stdout)
        return
    if formats.is_archive_path(output):
        from ..io import write_database

        check_overwrite(output, force)
        write_database(((ref.name, motion) for ref, motion in decoded_clips(refs, fps)), output)
    elif not output.suffix:
        if output.exists() and not output.is_dir():
            raise click.UsageError(f"output {output} exists and is not a directory")
        for ref in refs:
            check_overwrite(output / f"{ref.name}{suffix}", force)
        for ref, motion in decoded_clips(refs, fps):
            output.mkdir(parents=True, exist_ok=True)  # once the first clip is decoded: no empty OUT/ on error
            written(motion, output / f"{ref.name}{suffix}", None)
    else:
        raise click.UsageError(f"output {output}: {len(refs)} clips decompress to OUT.h5 or a directory (or pick "
                               "one with --clip)")
    if not quiet:
        click.echo(f"wrote {len(refs)} clips to {output}")
