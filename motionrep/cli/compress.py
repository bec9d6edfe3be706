"""``motionrep compress``: one clip into a ``.mrc`` file, or many into an archive or a directory of them.

Many clips run on the batch engine (:func:`motionrep.batch.engine.compress_clips`): in this process, in ``--jobs``
worker processes, or on a Dask cluster (``--scheduler``); each finished clip is committed to the output at once
(:mod:`motionrep.batch.store`), ``--resume`` skips the clips the output already holds from the same source and
setting, and the run ends with its totals (:mod:`motionrep.batch.totals`).

Exit codes: 0 on success; 1 for a library error (unknown codec or representation, bad parameter, bound not
met, malformed file, an output that exists without ``--force``; in a batch, after the totals, when any clip
failed, every other clip kept), with one line on stderr and no output file for what failed; 2 for a usage
error; 130 (Ctrl-C), 143 (SIGTERM) or 129 (SIGHUP) when interrupted, every finished clip kept.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from ._common import flag_text, flagged
from ._common import (MOTION_FORMATS, STDIN_NAME, STDOUT_NAME, BatchProgress, CodecProgress, Interrupted,
                      body_model_option, check_overwrite, collect, display_name, echo_json, force_option, is_stdio,
                      parse_params, quiet_compile_notice, stdin_inputs, stdout_output)

__all__ = ["compress"]

# the library's defaults, from their one home (standard library only, so `motionrep --help` stays light)
from ..defaults import DEFAULT_CODEC, DEFAULT_MAX_ERROR, DEFAULT_REPRESENTATION  # noqa: E402


def _report_lines(name: str, result: Any, out: str | None, verbose: bool = False) -> list[str]:
    c, r, f = result.container, result.report, result.figures
    how = result.bound_read_as()
    bound = "none (--max-error none)" if how is None else f"--max-error {how}"
    from ..pipeline.compress import describe_outcome
    from ..model.timefmt import duration_text, fps_text

    return [
        f"{name}: {c.num_frames} frames at {fps_text(c.fps)} fps ({duration_text(c.num_frames, c.fps)}), {c.skeleton.num_joints} joints "
        f"(+{c.skeleton.num_end_sites} end sites)",
        f"representation {c.representation} ({f.feature_width} features); codec {c.codec}: "
        f"{describe_outcome(c, detail=True)}",
        f"{r.summary()}; bound {bound}",
        f"size: {f.summary()}",
        *([f"more figures: {f.details()}"] if verbose else []),
        f"{'wrote ' + out if out else 'result'}: {len(result.data)} bytes in {result.seconds:.1f} s",
    ]


@click.command("compress")
@click.argument("inputs", metavar="IN...", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("-o", "--output", "output", required=True, type=click.Path(path_type=Path),
              help="OUT.mrc for one clip ('-': standard output); for several clips (a directory, a database): "
                   "OUT.h5 (one archive) or OUT/ (.mrc files).")
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
@click.option("--scheduler", metavar="ADDRESS", envvar="MOTIONREP_SCHEDULER", show_envvar=True,
              help="Run the clips on this Dask distributed scheduler (tcp://host:8786) instead of local worker "
                   "processes; needs pip install 'motionrep[dask]'.")
@click.option("--send-clips", is_flag=True,
              help="With --scheduler: read each clip here and send it to the workers (for workers that do not see "
                   "this file system); by default they read the clips by path. Standard input ('-') is always "
                   "sent.")
@click.option("--resume", is_flag=True,
              help="Keep the clips the output already holds from the same source (SHA-256) with the same codec, "
                   "parameters, representation, bound and seed; compress the others. A clip stored with another "
                   "setting is refused (naming what changed) unless --recompress-changed.")
@click.option("--recompress-changed", is_flag=True,
              help="With --resume: recompress (and replace) the clips stored with another setting.")
@force_option
@click.option("--timeout", type=click.FloatRange(min=0, min_open=True), default=None, metavar="SECONDS",
              help="Most seconds one clip may take; a clip over it fails and the others go on.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object; no progress.")
@click.option("--verbose", "-v", is_flag=True,
              help="Also the other size figures (the paper's parameter ratio, vs float32 channels) and the "
                   "codec's internal diagnostics (the transform codec's 'bisect regions=...').")
@click.option("--quiet", "-q", is_flag=True, callback=quiet_compile_notice,
              help="Print nothing on success (no progress, report or 'wrote').")
@body_model_option
def compress(inputs: tuple[Path, ...], output: Path, codec: str, representation: str, max_error: str,
             params: tuple[str, ...], seed: int, clip: str | None, jobs: int, scheduler: str | None,
             send_clips: bool, resume: bool, recompress_changed: bool, force: bool, timeout: float | None,
             as_json: bool, verbose: bool, quiet: bool) -> None:
    """Compress motion files IN into OUT.mrc, within --max-error of the original.

    IN may be files (.bvh, .npz, .h5 databases, archives), directories (searched
    recursively) or several of them; clips are named as by convert. One clip
    goes to OUT.mrc; several go to OUT.h5 (an archive of .mrc containers) or to
    the directory OUT/, in --jobs worker processes or on a Dask cluster
    (--scheduler, or MOTIONREP_SCHEDULER).

    \b
    Many clips: each finished clip is committed to OUT at once, so an
    interrupted run (Ctrl-C, a killed process) keeps every finished clip and
    --resume finishes the rest. An existing OUT needs --force or --resume.
    Progress (clips done, failures, ETA) goes to stderr, a line every 10 s when
    it is not a terminal (MOTIONREP_PROGRESS_SECONDS); the run ends with its
    totals: clips, every failure with its reason, raw and compressed MB, the
    overall ratio, bits/bone/frame, the worst error and its clip, wall and CPU
    time (--json: the same under "totals"). Exit code 1 when any clip failed
    (the others are kept), 130 on Ctrl-C.

    \b
    The report says how --max-error was read ("2% of height 152 = 3.04 cm",
    or "1.5 cm = 0.99% of height (read as a distance in file units...)");
    --json: "bound" (file units), "max_error_request" and "max_error_read_as".

    \b
    Standard input and output: IN '-' reads a motion file from standard input
    (BVH, NPZ, an HDF5 database, .glb; told by its first bytes, named
    <stdin>); with --scheduler its clips are sent to the workers, which cannot
    read it (a note says so). -o - writes the .mrc to standard output once it
    is complete, the report going to stderr (not with --json). -f is --force.

    \b
    Examples:
      motionrep compress walk.bvh -o walk.mrc
      motionrep compress walk.bvh -o walk.mrc --max-error 0.5 -p region=32
      motionrep compress walk.bvh -o walk.mrc --codec adaptive-fourier
      motionrep compress walk.bvh -o walk.mrc --codec svd -p rank=8 --max-error none
      motionrep compress clips/ -o clips.h5 --codec svd --jobs 2
      motionrep compress clips/ -o clips.h5 --codec svd --jobs 2 --resume
      motionrep compress clips/ -o clips.h5 --scheduler tcp://10.0.0.5:8786
      cat walk.bvh | motionrep compress - -o - > walk.mrc
      cat db.h5 | motionrep compress - -o db_mrc.h5 --scheduler tcp://10.0.0.5:8786
    """
    from ..pipeline.compress import Pipeline

    pipeline = Pipeline.build(codec, representation, parse_params(params), max_error, seed)  # before any work
    to_stdout = is_stdio(output)
    if to_stdout and as_json:
        raise click.UsageError("-o - writes the .mrc to standard output, where --json would print too: give one")
    with stdin_inputs(inputs, allowed=MOTION_FORMATS) as given:
        piped = [str(g) for p, g in zip(inputs, given) if is_stdio(p)]
        _compress(given, output, pipeline, clip, jobs, scheduler, send_clips or piped, resume, force, timeout,
                  as_json, _Say(verbose, quiet, recompress_changed))


class _Say:
    """How much to print (--verbose, --quiet) and --recompress-changed, passed down together."""

    def __init__(self, verbose: bool = False, quiet: bool = False, recompress_changed: bool = False):
        self.verbose, self.quiet, self.recompress_changed = verbose, quiet, recompress_changed


def _compress(inputs: list, output: Path, pipeline: Any, clip: str | None, jobs: int, scheduler: str | None,
              send_clips: bool | list[str], resume: bool, force: bool, timeout: float | None, as_json: bool,
              say: _Say) -> None:
    from ..formats import CONTAINER_SUFFIX, is_archive_path

    to_stdout = is_stdio(output)
    to_mrc = to_stdout or output.suffix.lower() == CONTAINER_SUFFIX
    to_archive = is_archive_path(output)
    if not (to_mrc or to_archive or not output.suffix):
        raise click.UsageError(f"output {output}: write one clip to OUT.mrc, many to OUT.h5 (one archive) or a "
                               "directory")
    if scheduler and jobs > 1:
        raise click.UsageError("--jobs runs local worker processes and --scheduler a Dask cluster: give one")
    if send_clips is True and not scheduler:
        raise click.UsageError("--send-clips applies with --scheduler")
    if resume and force:
        raise click.UsageError("--resume keeps what the output holds and --force overwrites it: give one")
    if say.recompress_changed and not resume:
        raise click.UsageError("--recompress-changed applies with --resume")
    refs = collect(inputs, clip=clip, exclude=[] if to_stdout else [output, journal_of(output)])
    if to_mrc:
        if len(refs) != 1:
            from ..pipeline.sources import listing

            shown = STDOUT_NAME if to_stdout else output
            raise click.UsageError(f"output {shown}: the inputs hold {len(refs)} clips "
                                   f"({listing([r.name for r in refs])}); a .mrc file holds one: write them to "
                                   "OUT.h5 or a directory, or pick one with --clip")
        if resume:
            raise click.UsageError("--resume applies to many clips (OUT.h5 or a directory)")
        if not to_stdout:
            check_overwrite(output, force)
        _compress_one(refs[0], output, pipeline, as_json, timeout, say)
    else:
        _compress_many(refs, output, pipeline, as_json, jobs=jobs, scheduler=scheduler, send_clips=send_clips,
                       resume=resume, force=force, timeout=timeout, say=say)


def journal_of(output: Path) -> Path:
    from ..batch.store import journal_path

    return journal_path(output)


def _compress_one(ref: Any, output: Path, pipeline: Any, as_json: bool, timeout: float | None, say: _Say) -> None:
    from ..batch.engine import time_limit
    from ..errors import UncodableClipError, naming
    from ..io.container import write_container
    from ..pipeline.compress import compress_clip

    progress = None if as_json or say.quiet else CodecProgress(pipeline.codec, verbose=say.verbose)
    try:
        with time_limit(timeout, display_name(ref.source)):
            result = compress_clip(pipeline, ref, progress=progress)
    except UncodableClipError as exc:  # the clip, not the setting: name the file
        raise naming(UncodableClipError(f"{display_name(ref.source)}: {exc}"), *exc.parameters) from None
    from ..formats import CONTAINER_SUFFIX

    with stdout_output(output, CONTAINER_SUFFIX) as target:
        write_container(result.data, target)
    source = display_name(ref.source)
    if as_json:
        echo_json(dict(result.as_dict(), input=source, output=str(output)))
    elif not say.quiet:  # the report goes to stderr when the .mrc went to standard output
        to_stdout = is_stdio(output)
        for line in _report_lines(source, result, STDOUT_NAME if to_stdout else str(output), say.verbose):
            click.echo(line, err=to_stdout)


def _error_text(failure: Any) -> str:
    """A failed clip's message, its parameter mentions shown as flags."""
    return display_name(flag_text(failure.message, failure.parameters))


def _clip_line(o: Any) -> str:
    if o.failed:
        return f"{o.name}: FAILED: {_error_text(o.failure)}"
    if o.skipped:
        return f"{o.name}: kept (compressed by an earlier run from the same source and setting)"
    r = o.result
    how = r.bound_read_as()
    bound = "none" if how is None else f"--max-error {how}"
    from ..pipeline.figures import LABELS, PAYLOAD_BPBF

    bpbf = r.figures.payload_bits_per_bone_frame
    size = "" if bpbf is None else f" ({bpbf:.3f} {LABELS[PAYLOAD_BPBF]})"
    return (f"{o.name}: {len(r.data)} bytes{size}, L-inf {r.report.max_error:.4g} "
            f"({r.report.max_error_percent:.3g}%), bound {bound}, {r.outcome}")


def _compress_many(refs: list, output: Path, pipeline: Any, as_json: bool, *, jobs: int, scheduler: str | None,
                   send_clips: bool | list[str], resume: bool, force: bool, timeout: float | None,
                   say: _Say) -> None:
    from ..batch.many import compress_into
    from ..errors import BatchInterrupted, SettingChangedError

    if scheduler and send_clips and send_clips is not True:  # '-': Dask workers cannot read this machine's stdin
        click.echo(f"note: {STDIN_NAME} is read here and its clips sent to the Dask workers (as --send-clips does)",
                   err=True)
    with BatchProgress(len(refs), f"compressing {len(refs)} clips", _clip_line, quiet=as_json or say.quiet) as bar:
        clocks: dict[str, CodecProgress] = {}

        def progress(name: str, stage: str, fields: Any) -> None:  # inside a clip
            clock = clocks.setdefault(name, CodecProgress(pipeline.codec, verbose=say.verbose))
            if clock.shows(fields):
                bar.note(name, clock.text(stage, fields))

        try:
            run = compress_into(refs, output, pipeline, jobs=jobs, scheduler=scheduler, send_clips=send_clips,
                                resume=resume, force=force, recompress_changed=say.recompress_changed,
                                timeout=timeout, progress=progress,
                                on_done=lambda o: bar.done(o, failed=o.failed, skipped=o.skipped))
        except SettingChangedError as exc:
            raise click.UsageError(flagged(exc)) from None
        except BatchInterrupted as exc:
            if not exc.finished:
                raise Interrupted(exc.signum, f"no clip had finished; nothing was written to {output}") from None
            raise Interrupted(exc.signum, f"{exc.finished} of {exc.total} clips finished and kept in {output}; run "
                                          "the same command with --resume to compress the rest") from None
    outcomes = run.outcomes
    totals = run.totals(reason=_error_text)
    failed = run.failed
    if as_json:
        clips = {}
        for o in outcomes:  # a failed clip's library error names parameters: the command line shows the flags
            summary = dict(o.summary, status=o.status)
            if o.failed:
                summary.pop("parameters", None)
                summary["error"] = flag_text(o.failure.message, o.failure.parameters)
            clips[o.name] = summary
        echo_json({"input": [display_name(r.source) for r in refs], "output": str(output), "clips": clips,
                   "totals": totals.as_dict()})
    elif not say.quiet:
        for o in outcomes:
            click.echo(_clip_line(o))
        stored = len(outcomes) - len(failed)
        click.echo(f"wrote {stored} of {len(outcomes)} clips to {output}")
        for line in totals.lines(verbose=say.verbose):
            click.echo(line)
    if failed:
        raise click.ClickException(f"{len(failed)} of {len(outcomes)} clips failed (listed above); the other "
                                   f"{len(outcomes) - len(failed)} are in {output}")
