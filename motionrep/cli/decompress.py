"""``motionrep decompress``: a ``.mrc`` file (or an archive of them) back to motion files.

Exit codes: 0 on success; 1 for a file problem (malformed or altered file, codec not installed), with one line
on stderr and no output file; 2 for a usage error.
"""

from __future__ import annotations

from pathlib import Path

import click

from ._common import MOTION_OUT_SUFFIXES, usage_suffix

__all__ = ["decompress"]


@click.command("decompress")
@click.argument("source", metavar="IN", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("-o", "--output", "output", required=True, type=click.Path(path_type=Path),
              help="OUT.bvh, OUT.npz or OUT.h5 (an archive decompresses to an .h5 database or a directory).")
@click.option("--fps", type=float, default=None, help="Resample to this frame rate (decoded at the new times).")
@click.option("--clip", metavar="NAME", help="Only this clip of an archive.")
def decompress(source: Path, output: Path, fps: float | None, clip: str | None) -> None:
    """Decode a compressed IN.mrc (or an archive of them) into a motion file.

    \b
    Examples:
      motionrep decompress walk.mrc -o walk2.bvh
      motionrep decompress walk.mrc -o walk60.bvh --fps 60
      motionrep decompress clips.h5 -o clips_decoded.h5
    """
    from ..compress import decompress as decode
    from ..compress import write_decoded
    from ..sources import open_source

    if fps is not None and not fps > 0:
        raise click.BadParameter("must be > 0", param_hint="--fps")
    usage_suffix(source, (".mrc", ".h5", ".hdf5"), "input")
    with open_source(source) as src:
        if src.kind not in ("compressed", "archive"):
            raise click.UsageError(f"input {source} holds motions, not compressed clips: use 'motionrep convert'")
        names = [src.resolve(clip)] if clip is not None else src.names
        single = len(names) == 1 and (src.kind == "compressed" or output.suffix.lower() in MOTION_OUT_SUFFIXES)
        if single:
            usage_suffix(output, MOTION_OUT_SUFFIXES, "output")
            motion = decode(src.container(names[0]), fps, path=source)
            write_decoded(motion, output)
            which = f" (clip {names[0]})" if src.kind == "archive" else ""
            click.echo(f"wrote {output}{which}: {motion.num_frames} frames at {motion.fps:g} fps")
            return

        def decoded():
            for name in names:
                yield name, decode(src.container(name), fps, path=f"{source}[{name}]")

        if output.suffix.lower() in (".h5", ".hdf5"):
            from ..io import write_database

            write_database(decoded(), output)
        elif not output.suffix:
            output.mkdir(parents=True, exist_ok=True)
            for name, motion in decoded():
                write_decoded(motion, output / f"{name}.bvh")
        else:
            raise click.UsageError(f"output {output}: an archive of {len(names)} clips decompresses to OUT.h5 or a "
                                   "directory (or pick one with --clip)")
    click.echo(f"wrote {len(names)} clips to {output}")
