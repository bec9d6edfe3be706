"""``motionrep bench``: every codec x bound (or fixed-size sweep) x clip through the shared evaluator.

Exit codes: 0 when every run finished (a bound that a codec could not meet is an outcome, a ``failed`` row, not
an error); 1 for a library error before any work (unknown codec or representation, a parameter no codec has or
an invalid value, an unreadable input, matplotlib missing for ``--plot``), or after the table when some runs
ended with an error (for example ``svd`` without ``rank`` and without a bound), or when ``--out`` or
``--plot`` would replace an earlier run's files without ``--force``; 2 for a usage error (malformed
``-p``, unknown plot suffix).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from ._common import flagged
from ._common import BatchProgress, body_model_option, check_outputs, collect, force_option, quiet_compile_notice

__all__ = ["bench"]


@click.command("bench")
@click.argument("inputs", metavar="FILES_OR_DIRS...", nargs=-1, required=True,
                type=click.Path(exists=True, path_type=Path))
@click.option("--codec", "-c", "codecs", multiple=True,
              help="Codec to run (repeatable). Default: every installed codec; with -p, those that take one of "
                   "the -p parameters.")
@click.option("--representation", "-r", "representations", multiple=True,
              help="Representation the codecs compress (repeatable). Default: root-quat-axis-angle.")
@click.option("--max-error", "max_errors", multiple=True, metavar="BOUND",
              help="Bound on the L-inf joint error (repeatable): '2%' of character height, a distance in file "
                   "units, or 'none'. Default: 2%, or none when a -p value is a range or list (a sweep).")
@click.option("-p", "--param", "params", multiple=True, metavar="KEY=VALUES",
              help="Codec parameter for the codecs that have it (repeatable): one value, a range 'k=1..12', or a "
                   "list 'rank=1,2,4' (items may be ranges).")
@click.option("--seed", default=0, show_default=True, type=int, help="Random seed of every run.")
@click.option("--jobs", "-j", default=1, show_default=True, type=click.IntRange(1, 256),
              help="Worker processes (spawned; each uses one BLAS thread).")
@click.option("--out", "out", type=click.Path(file_okay=False, path_type=Path),
              help="Directory for bench.csv, bench.json and bench.md (created if needed; existing ones need "
                   "--force).")
@click.option("--plot", "plot", type=click.Path(dir_okay=False, path_type=Path),
              help="Draw the error against payload bits/bone/frame to this .png, .svg or .pdf.")
@click.option("--decode-poses", default=None, type=click.IntRange(0, 10**8), metavar="N",
              help="Poses decoded at random times to measure decode speed (0: skip). Default: 20000.")
@click.option("--wide", is_flag=True,
              help="Every column (the paper's ratio, bytes ratio, bits/joint/frame, xz -9, decode speed...); by "
                   "default the table fits 120 columns.")
@click.option("--quiet", "-q", is_flag=True, callback=quiet_compile_notice,
              help="No progress on stderr and no 'wrote ...' lines (the table stays).")
@force_option
@body_model_option
def bench(inputs: tuple[Path, ...], codecs: tuple[str, ...], representations: tuple[str, ...],
          max_errors: tuple[str, ...], params: tuple[str, ...], seed: int, jobs: int, out: Path | None,
          plot: Path | None, decode_poses: int | None, wide: bool, quiet: bool, force: bool) -> None:
    """Compare codecs on FILES_OR_DIRS (.bvh, .npz, .h5 databases; directories recursively).

    Runs every codec x representation x bound (or parameter value) x clip through the compression pipeline (the
    shared FK-based L-inf evaluator, measured on the payload decoded from the bytes), and prints one row per run:
    clip, codec, bound, outcome (K / rank, or 'failed: best L-inf' when the bound was not met), L-inf (% of
    height), payload bits/bone/frame, file bits/bone/frame, how many times smaller than the source, encode
    seconds; then the medians per codec and bound. The table fits 120 columns; --wide adds the L-inf in file
    units, the paper's ratio, bytes ratio (float32 channels / file), bits per joint per frame, bytes, xz -9 and
    decode poses per second (bench.md, CSV and JSON always have every column). Progress on stderr: each run as
    it finishes, and a line every 10 s with the ETA while none does.

    \b
    Examples:
      motionrep bench clips/ --codec svd --codec adaptive-fourier --max-error 1% --max-error 2%
      motionrep bench walk.bvh -c adaptive-fourier -c naive-fourier -p k=1..10 --plot rd.png
      motionrep bench walk.bvh -c svd -p rank=1..30 --out results/
      motionrep bench database.h5 --jobs 2 --out results/ --plot results/rd.png
    """
    from ..present.bench import (DEFAULT_DECODE_POSES, bench_tasks, format_compact, format_table, is_sweep, parse_sweep,
                         plot_rate_distortion, run_bench, summarize, write_csv, write_json)
    from ..defaults import DEFAULT_MAX_ERROR, DEFAULT_REPRESENTATION
    from ..errors import ParameterError
    from ..plugin.registry import codecs as installed_codecs
    from ..pipeline.sources import read_refs

    try:
        sweep = parse_sweep(params)
    except ParameterError as exc:
        raise click.BadParameter(flagged(exc), param_hint="-p/--param") from None
    if plot is not None and plot.suffix.lower() not in (".png", ".svg", ".pdf"):
        raise click.BadParameter(f"{plot}: use a .png, .svg or .pdf file", param_hint="--plot")
    outputs = [out / name for name in _OUT_FILES] if out is not None else []
    check_outputs([*outputs, plot], force)  # before any work: an earlier run's results are not replaced silently
    if plot is not None:
        from ..present.bench import require_matplotlib

        require_matplotlib()  # fail before any work when matplotlib is missing
    swept = any(is_sweep(p.partition("=")[2]) for p in params)
    bounds: list[str | None] = list(max_errors) or [None if swept else DEFAULT_MAX_ERROR]
    chosen = list(codecs)
    if not chosen:
        chosen = list(installed_codecs())
        if sweep:
            from ..present.bench import codec_parameter_names

            chosen = [c for c in chosen if set(sweep) & set(codec_parameter_names(c))] or chosen
    reps = list(representations) or [DEFAULT_REPRESENTATION]
    clips = collect(inputs)
    poses = DEFAULT_DECODE_POSES if decode_poses is None else decode_poses
    tasks = bench_tasks(clips, chosen, reps, bounds, sweep, seed=seed, decode_poses=poses)
    motions = {ref.name: motion for ref, motion in read_refs(clips)}  # every input read, and checked, first
    if jobs > 1:
        motions = {}  # workers read the clips themselves
    with BatchProgress(len(tasks), f"benchmarking {len(tasks)} runs", _describe_row, quiet) as bar:
        rows = run_bench(tasks, jobs=jobs, motions=motions, on_done=bar.done)
    rows = [_flag_row(r) for r in rows]  # messages name the command line's flags, not Python parameters
    summaries = summarize(rows)
    click.echo(format_table(rows, summaries) if wide else format_compact(rows, summaries, every_column="--wide"),
               nl=False)
    settings: dict[str, Any] = {
        "inputs": [str(p) for p in inputs], "codecs": chosen, "representations": reps, "max_errors": bounds,
        "params": {k: v for k, v in sweep.items()}, "seed": seed, "jobs": jobs, "decode_poses": poses}
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        write_csv(rows, out / "bench.csv")
        write_json(rows, out / "bench.json", summaries=summaries, settings=settings)
        _write_text(out / "bench.md", format_table(rows, summaries, markdown=True))
        if not quiet:
            click.echo(f"wrote {out / 'bench.csv'}, {out / 'bench.json'} and {out / 'bench.md'}")
    if plot is not None:
        plot_rate_distortion(rows, plot)
        if not quiet:
            click.echo(f"wrote {plot}")
    errors = [r for r in rows if r.status == "error"]
    if errors:
        raise click.ClickException(f"{len(errors)} of {len(rows)} runs ended with an error (first: {errors[0].clip}, "
                                   f"{errors[0].codec}: {errors[0].message})")


#: The files ``--out DIR`` writes.
_OUT_FILES = ("bench.csv", "bench.json", "bench.md")


def _write_text(path: Path, text: str) -> None:
    from ..io import atomic_path

    with atomic_path(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")


def _flag_row(row: Any) -> Any:
    """A row whose message names parameters (``max_error=2%``) as the flags (``--max-error 2%``)."""
    import dataclasses

    from ._flags import flag_text

    return dataclasses.replace(row, message=flag_text(row.message, row.mentions)) if row.mentions else row


def _describe_row(row: Any) -> str:
    """One finished run, for the progress lines on stderr."""
    err = "" if row.error_percent is None else f", L-inf {row.error_percent:.2f}%"
    ratio = "" if row.payload_bits_per_bone_frame is None else \
        f", {row.payload_bits_per_bone_frame:.3f} payload bits/bone/frame"
    secs = "" if row.encode_seconds is None else f", {row.encode_seconds:.1f} s"
    bound = "none" if row.max_error is None else row.max_error
    params = f" {row.params}" if row.params else ""
    return f"{row.clip} {row.codec} {bound}{params}: {row.outcome}{err}{ratio}{secs}"
