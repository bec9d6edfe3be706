"""``motionrep compress``: one clip into a ``.mrc`` file, or many into an archive or a directory of them.

Exit codes: 0 on success; 1 for a library error (unknown codec or representation, bad parameter, bound not
met, malformed file; in a batch, after the report, when any clip failed), with one line on stderr and no
output file for what failed; 2 for a usage error.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from ._common import BatchProgress, CodecProgress, collect, echo_json, parse_params

__all__ = ["compress"]

# the defaults, written out so that `motionrep --help` does not import the library (a test checks they agree)
DEFAULT_CODEC = "adaptive-fourier"
DEFAULT_REPRESENTATION = "root-quat-axis-angle"
DEFAULT_MAX_ERROR = "2%"


def _report_lines(name: str, result: Any, out: str | None) -> list[str]:
    c, r, f = result.container, result.report, result.figures
    bound = "none" if result.bound is None else f"{result.bound:.4g} ({c.extra.get('max_error')})"
    from ..compress import describe_outcome

    return [
        f"{name}: {c.num_frames} frames at {c.fps:g} fps, {c.skeleton.num_joints} joints "
        f"(+{c.skeleton.num_end_sites} end sites)",
        f"representation {c.representation} ({f.feature_width} features); codec {c.codec}: "
        f"{describe_outcome(c, detail=True)}",
        f"{r.summary()}; bound {bound}",
        f"compression: {f.summary()}",
        f"{'wrote ' + out if out else 'result'}: {len(result.data)} bytes in {result.seconds:.1f} s",
    ]


@click.command("compress")
@click.argument("inputs", metavar="IN...", nargs=-1, required=True,
                type=click.Path(exists=True, dir_okay=True, path_type=Path))
@click.option("-o", "--output", "output", required=True, type=click.Path(path_type=Path),
              help="OUT.mrc for one clip; for several clips (a directory, a database): OUT.h5 (one archive) or "
                   "OUT/ (.mrc files).")
@click.option("--codec", "-c", default=DEFAULT_CODEC, show_default=True, help="Codec name (see motionrep plugins).")
@click.option("--representation", "-r", default=DEFAULT_REPRESENTATION, show_default=True,
              help="Representation the codec compresses.")
@click.option("--max-error", default=DEFAULT_MAX_ERROR, show_default=True,
              help="Bound on the L-inf joint error: '2%' of character height, a distance in file units, or 'none'.")
@click.option("-p", "--param", "params", multiple=True, metavar="KEY=VALUE",
              help="Codec parameter (repeatable); 'motionrep plugins --describe CODEC' lists them.")
@click.option("--seed", default=0, show_default=True, type=int, help="Random seed (same seed, same bytes).")
@click.option("--clip", metavar="NAME", help="Compress only this clip of an HDF5 database or archive.")
@click.option("--jobs", "-j", default=1, show_default=True, type=click.IntRange(1, 256),
              help="Worker processes for many clips (spawned; each uses one BLAS thread).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object; no progress.")
def compress(inputs: tuple[Path, ...], output: Path, codec: str, representation: str, max_error: str,
             params: tuple[str, ...], seed: int, clip: str | None, jobs: int, as_json: bool) -> None:
    """Compress motion files IN into OUT.mrc, within --max-error of the original.

    IN may be files (.bvh, .npz, .h5 databases, archives), directories (searched
    recursively) or several of them; clips are named as by convert. One clip
    goes to OUT.mrc; several go to OUT.h5 (an archive of .mrc containers) or to
    the directory OUT/, in --jobs worker processes.

    \b
    Examples:
      motionrep compress walk.bvh -o walk.mrc --codec adaptive-fourier
      motionrep compress walk.bvh -o walk.mrc --codec svd -p rank=8 --max-error none
      motionrep compress clips/ -o clips.h5 --codec svd --jobs 2
    """
    from ..compress import Pipeline

    pipeline = Pipeline.build(codec, representation, parse_params(params), max_error, seed)  # before any work
    to_mrc = output.suffix.lower() == ".mrc"
    to_archive = output.suffix.lower() in (".h5", ".hdf5")
    if not (to_mrc or to_archive or not output.suffix):
        raise click.UsageError(f"output {output}: write one clip to OUT.mrc, many to OUT.h5 (one archive) or a "
                               "directory")
    refs = collect(inputs, clip=clip, exclude=[output])
    if to_mrc:
        if len(refs) != 1:
            from ..sources import listing

            raise click.UsageError(f"output {output}: the inputs hold {len(refs)} clips "
                                   f"({listing([r.name for r in refs])}); a .mrc file holds one: write them to "
                                   "OUT.h5 or a directory, or pick one with --clip")
        _compress_one(refs[0], output, pipeline, as_json)
    else:
        _compress_many(refs, output, to_archive, pipeline, jobs, as_json)


def _compress_one(ref: Any, output: Path, pipeline: Any, as_json: bool) -> None:
    from ..container import write_container
    from ..sources import open_source

    with open_source(ref.path) as src:
        motion = src.read(ref.clip)
    progress = None if as_json else CodecProgress(pipeline.codec)
    result = pipeline.compress(motion, progress=progress, source_bytes=ref.source_bytes)
    write_container(result.data, output)
    if as_json:
        echo_json(dict(result.as_dict(), input=ref.source, output=str(output)))
    else:
        for line in _report_lines(ref.source, result, str(output)):
            click.echo(line)


def _compress_many(refs: list, output: Path, to_archive: bool, pipeline: Any, jobs: int, as_json: bool) -> None:
    from ..archive import write_archive
    from ..batch import compress_clips
    from ..container import write_container

    if not to_archive:
        output.mkdir(parents=True, exist_ok=True)

    def describe(outcome: Any) -> str:
        return f"{outcome.name}: " + ("FAILED" if outcome.failed else outcome.summary["outcome"])

    with BatchProgress(len(refs), f"compressing {len(refs)} clips", describe, quiet=as_json) as bar:
        def done(outcome: Any) -> None:
            if not to_archive and not outcome.failed:
                write_container(outcome.data, output / f"{outcome.name}.mrc")
            bar.done(outcome)

        outcomes = compress_clips(refs, pipeline, jobs=jobs, on_done=done)
    good = [o for o in outcomes if not o.failed]
    if to_archive and good:
        write_archive([(o.name, o.data) for o in good], output)
    failed = [o for o in outcomes if o.failed]
    if as_json:
        echo_json({"input": [r.source for r in refs], "output": str(output),
                   "clips": {o.name: o.summary for o in outcomes}})
    else:
        for o in outcomes:
            s = o.summary
            if o.failed:
                click.echo(f"{o.name}: FAILED: {s['error']}")
            else:
                ev, fig = s["evaluation"], s["figures"]
                click.echo(f"{o.name}: {s['bytes']} bytes, L-inf {ev['max_error']:.4g} "
                           f"({ev['max_error_percent']:.3g}%), paper ratio {fig['paper_ratio']:.1f}x, "
                           f"{s['outcome']}")
        click.echo(f"wrote {len(good)} of {len(outcomes)} clips to {output}")
    if failed:
        raise click.ClickException(f"{len(failed)} of {len(outcomes)} clips failed (first: {failed[0].name}: "
                                   f"{failed[0].summary['error']})")
