"""The ``compress``, ``decompress``, ``evaluate`` and ``example`` commands (registered on the CLI group).

Exit codes: 0 on success; 1 for a library error (unknown codec or representation, bad parameter, bound not
met, malformed or altered file), with one line on stderr and no output file; 2 for a usage error.
"""

from __future__ import annotations

import json
import shutil
import sys
import time
from pathlib import Path
from typing import Any, Mapping

import click

from ._cli_io import _listing
from .cli import cli
from .compress import (DEFAULT_CODEC, DEFAULT_MAX_ERROR, DEFAULT_REPRESENTATION, ClipJob, CompressResult,
                       batch_jobs, compress_batch, compress_file, decode_container, decompress_file, is_archive,
                       parse_max_error, read_archive, write_archive, write_decoded)
from .errors import FormatError

__all__ = ["compress", "decompress", "evaluate", "example"]


def _parse_params(pairs: tuple[str, ...]) -> dict[str, str]:
    out: dict[str, str] = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep or not key.strip():
            raise click.BadParameter(f"expected KEY=VALUE, got {pair!r}", param_hint="-p/--param")
        out[key.strip()] = value.strip()
    return out


def _fmt(v: Any) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def _outcome(info: Mapping[str, Any]) -> str:
    if "windows" in info and isinstance(info.get("K"), list):
        return f"{info['windows']} windows, K per window [{', '.join(map(str, info['K']))}]"
    if "omega" in info:
        return f"K={info.get('K')}, omega=[{', '.join(_fmt(o) for o in info['omega'])}] cycles/clip, " \
               f"hidden {info.get('hidden')}"
    return ", ".join(f"{k}={_fmt(v)}" for k, v in info.items()) or "-"


class _Progress:
    """Prints codec progress on stderr, at most every 0.5 s (and always when K changes)."""

    def __init__(self) -> None:
        self.last = 0.0
        self.key: Any = None

    def __call__(self, stage: str, fields: Mapping[str, Any]) -> None:
        now = time.monotonic()
        key = (stage, fields.get("window"), fields.get("K"), fields.get("rank"))
        if key == self.key and now - self.last < 0.5:
            return
        self.last, self.key = now, key
        parts = [stage]
        for name in ("window", "K", "rank", "iteration"):
            if name in fields:
                parts.append(f"{name}={fields[name]}")
        if "loss" in fields:
            parts.append(f"loss={fields['loss']:.3e}")
        if "error" in fields:
            pct = fields.get("error_percent")
            parts.append(f"L-inf={fields['error']:.4g}" + (f" ({pct:.2f}%)" if pct is not None else ""))
        click.echo("  " + " ".join(parts), err=True)


def _report_lines(name: str, result: CompressResult, out: str | None) -> list[str]:
    c, r, f = result.container, result.report, result.figures
    bound = "none" if result.bound is None else f"{result.bound:.4g} ({c.extra.get('max_error')})"
    return [
        f"{name}: {c.num_frames} frames at {c.fps:g} fps, {c.skeleton.num_joints} joints "
        f"(+{c.skeleton.num_end_sites} end sites)",
        f"representation {c.representation} ({f.feature_width} features); codec {c.codec}: {_outcome(c.info)}",
        f"{r.summary()}; bound {bound}",
        f"compression: {f.summary()}",
        f"{'wrote ' + out if out else 'result'}: {len(result.data)} bytes in {result.seconds:.1f} s",
    ]


@cli.command("compress")
@click.argument("source", metavar="IN", type=click.Path(exists=True, dir_okay=True, path_type=Path))
@click.option("-o", "--output", "output", required=True, type=click.Path(path_type=Path),
              help="OUT.mrc for one clip; for a directory or .h5 database: OUT.h5 (one archive) or OUT/ (.mrc files).")
@click.option("--codec", "-c", default=DEFAULT_CODEC, show_default=True, help="Codec name (see motionrep plugins).")
@click.option("--representation", "-r", default=DEFAULT_REPRESENTATION, show_default=True,
              help="Representation the codec compresses.")
@click.option("--max-error", default=DEFAULT_MAX_ERROR, show_default=True,
              help="Bound on the L-inf joint error: '2%' of character height, a distance in file units, or 'none'.")
@click.option("-p", "--param", "params", multiple=True, metavar="KEY=VALUE",
              help="Codec parameter (repeatable); 'motionrep plugins --describe CODEC' lists them.")
@click.option("--seed", default=0, show_default=True, type=int, help="Random seed (same seed, same bytes).")
@click.option("--clip", metavar="NAME", help="Compress only this clip of an HDF5 database.")
@click.option("--jobs", "-j", default=1, show_default=True, type=click.IntRange(1, 256),
              help="Worker processes for a directory or database.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object; no progress.")
def compress(source: Path, output: Path, codec: str, representation: str, max_error: str, params: tuple[str, ...],
             seed: int, clip: str | None, jobs: int, as_json: bool) -> None:
    """Compress a motion file IN into OUT.mrc, within --max-error of the original.

    \b
    Examples:
      motionrep compress walk.bvh -o walk.mrc --codec adaptive-fourier
      motionrep compress walk.bvh -o walk.mrc --codec svd -p rank=8 --max-error none
      motionrep compress clips/ -o clips.h5 --codec svd --jobs 2
    """
    raw = _parse_params(params)
    # validate names, parameters and the bound before any work
    from .plugins import get_codec, get_representation

    codec_obj = get_codec(codec)
    get_representation(representation)
    codec_obj.parse_params(raw)
    parse_max_error(max_error)
    options = dict(codec=codec, representation=representation, max_error=max_error, params=raw, seed=seed)
    many = source.is_dir() or (source.suffix.lower() in (".h5", ".hdf5") and clip is None
                                and _database_size(source) > 1)
    if many:
        _compress_many(source, output, jobs, as_json, options)
        return
    if output.suffix.lower() != ".mrc":
        raise click.UsageError(f"output {output}: a single clip is written to a .mrc file")
    result = compress_file(source, output, clip=clip, progress=None if as_json else _Progress(), **options)
    if as_json:
        click.echo(json.dumps(dict(result.as_dict(), input=str(source), output=str(output)), indent=2))
    else:
        for line in _report_lines(str(source), result, str(output)):
            click.echo(line)


def _database_size(path: Path) -> int:
    from .io import list_clips

    return len(list_clips(path))


def _compress_many(source: Path, output: Path, jobs: int, as_json: bool, options: dict[str, Any]) -> None:
    job_list: list[ClipJob] = batch_jobs(source)
    to_archive = output.suffix.lower() in (".h5", ".hdf5")
    if not to_archive and output.suffix:
        raise click.UsageError(f"output {output}: write many clips to OUT.h5 (one archive) or a directory")
    summaries: dict[str, dict[str, Any]] = {}
    done_data: dict[str, bytes] = {}
    if not to_archive:
        output.mkdir(parents=True, exist_ok=True)

    def on_done(name: str, data: bytes | None, summary: dict[str, Any]) -> None:
        summaries[name] = summary
        if data is not None:
            done_data[name] = data
            if not to_archive:
                from .container import write_container

                write_container(data, output / f"{name}.mrc")

    stream = sys.stderr
    if as_json:
        compress_batch(job_list, jobs_count=jobs, on_done=on_done, **options)
    else:
        with click.progressbar(length=len(job_list), label=f"compressing {len(job_list)} clips", file=stream,
                               show_pos=True) as bar:
            def tick(name: str, data: bytes | None, summary: dict[str, Any]) -> None:
                on_done(name, data, summary)
                bar.update(1)

            compress_batch(job_list, jobs_count=jobs, on_done=tick, **options)
    if to_archive and done_data:
        write_archive({job.name: done_data[job.name] for job in job_list if job.name in done_data}, output)
    failed = {name: s for name, s in summaries.items() if "error" in s}
    if as_json:
        click.echo(json.dumps({"input": str(source), "output": str(output), "clips": summaries}, indent=2))
    else:
        for job in job_list:
            s = summaries[job.name]
            if "error" in s:
                click.echo(f"{job.name}: FAILED: {s['error']}")
            else:
                ev, fig = s["evaluation"], s["figures"]
                click.echo(f"{job.name}: {s['bytes']} bytes, L-inf {ev['max_error']:.4g} "
                           f"({ev['max_error_percent']:.3g}%), paper ratio {fig['paper_ratio']:.1f}x, "
                           f"{_outcome(s['info'])}")
        click.echo(f"wrote {len(done_data)} of {len(job_list)} clips to {output}")
    if failed:
        raise click.ClickException(f"{len(failed)} of {len(job_list)} clips failed (first: "
                                   f"{next(iter(failed))}: {next(iter(failed.values()))['error']})")


@cli.command("decompress")
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
    """
    from .io import SUFFIXES

    if fps is not None and not fps > 0:
        raise click.BadParameter("must be > 0", param_hint="--fps")
    if source.suffix.lower() in (".h5", ".hdf5") and is_archive(source):
        containers = read_archive(source, clip)
        if len(containers) == 1 and output.suffix.lower() in SUFFIXES:
            (name, container), = containers.items()
            write_decoded(decode_container(container, fps, path=source), output)
            click.echo(f"wrote {output} (clip {name})")
            return
        if output.suffix.lower() in (".h5", ".hdf5"):
            from .io import write_database

            write_database(((n, decode_container(c, fps, path=source)) for n, c in containers.items()), output)
        elif not output.suffix:
            output.mkdir(parents=True, exist_ok=True)
            for n, c in containers.items():
                write_decoded(decode_container(c, fps, path=source), output / f"{n}.bvh")
        else:
            raise click.UsageError(f"output {output}: an archive of {len(containers)} clips decompresses to "
                                   "OUT.h5 or a directory (or pick one with --clip)")
        click.echo(f"wrote {len(containers)} clips to {output}")
        return
    if output.suffix.lower() not in SUFFIXES:
        raise click.UsageError(f"output {output}: unknown file type {output.suffix or '(no suffix)'!r}; use one of "
                               + ", ".join(SUFFIXES))
    motion = decompress_file(source, output, fps)
    click.echo(f"wrote {output}: {motion.num_frames} frames at {motion.fps:g} fps")


@cli.command("evaluate")
@click.argument("reference", metavar="REF", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.argument("candidate", metavar="CAND", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--clip", metavar="NAME", help="Compare only this clip of a database or archive.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def evaluate(reference: Path, candidate: Path, clip: str | None, as_json: bool) -> None:
    """Compare two motion files of one skeleton with the shared L-inf joint-position error.

    Either file may be a .mrc, which is decoded first. REF and CAND may also
    be HDF5 databases or archives of compressed clips (as written by
    convert and compress): their clips are compared by name, one report per
    clip and the worst of them; --clip NAME compares one clip.

    \b
    --json: one clip gives the report's keys (max_error, max_error_percent,
    mean_error, mean_error_percent, frame, joint, height, units, num_frames,
    num_points) plus reference and candidate; several clips give
    {reference, candidate, clips: [report + clip], worst: report + clip}.

    \b
    Examples:
      motionrep evaluate walk.bvh walk.mrc
      motionrep evaluate db.h5 db_compressed.h5 --json
    """
    from .evaluate import max_joint_error

    if clip is not None and not any(p.suffix.lower() in (".h5", ".hdf5") for p in (reference, candidate)):
        raise click.UsageError("--clip applies to HDF5 databases and archives")
    ref_names, cand_names = _clip_names(reference, clip), _clip_names(candidate, clip)
    if len(ref_names) == 1 and len(cand_names) == 1:
        pairs = [(ref_names[0], ref_names[0], cand_names[0])]
    elif len(ref_names) > 1 and len(cand_names) > 1:
        missing = [n for n in ref_names if n not in cand_names]
        extra = [n for n in cand_names if n not in ref_names]
        if missing or extra:
            where = "; ".join(part for part in (
                f"only in {reference}: {_listing(missing)}" if missing else "",
                f"only in {candidate}: {_listing(extra)}" if extra else "") if part)
            raise FormatError(f"the two files hold different clips ({where}); use --clip NAME to compare one")
        pairs = [(n, n, n) for n in ref_names]
    else:
        many, names = (reference, ref_names) if len(ref_names) > 1 else (candidate, cand_names)
        raise click.UsageError(f"{many} holds {len(names)} clips ({_listing(names)}) and the other file one; "
                               "use --clip NAME")
    reports = []
    for name, ref_clip, cand_clip in pairs:
        report = max_joint_error(_read_clip(reference, ref_clip), _read_clip(candidate, cand_clip))
        reports.append((name, report))
    if len(reports) == 1:
        report = reports[0][1]
        if as_json:
            click.echo(json.dumps(dict(report.as_dict(), reference=str(reference), candidate=str(candidate)),
                                  indent=2))
        else:
            which = f" (clip {clip})" if clip is not None else ""
            click.echo(f"{candidate} vs {reference}{which}: {report.num_frames} frames, {report.num_points} points")
            click.echo(report.summary())
        return
    worst_name, worst = max(reports, key=lambda item: item[1].max_error_percent)
    if as_json:
        click.echo(json.dumps({"reference": str(reference), "candidate": str(candidate),
                               "clips": [dict(r.as_dict(), clip=n) for n, r in reports],
                               "worst": dict(worst.as_dict(), clip=worst_name)}, indent=2))
        return
    click.echo(f"{candidate} vs {reference}: {len(reports)} clips")
    width = max(4, *(len(n) for n, _ in reports))
    click.echo(f"  {'clip':<{width}}  {'frames':>7}  {'L-inf':>10}  {'% height':>8}  {'mean':>10}  worst at")
    for n, r in reports:
        click.echo(f"  {n:<{width}}  {r.num_frames:>7}  {r.max_error:>10.4g}  {r.max_error_percent:>8.3f}  "
                   f"{r.mean_error:>10.4g}  frame {r.frame}, {r.joint}")
    click.echo(f"worst: {worst_name}: {worst.summary()}")


def _clip_names(path: Path, clip: str | None) -> list[str]:
    """The clips ``path`` holds (one for BVH, NPZ and .mrc files); only ``clip`` of a database or archive when
    given (a one-clip file is taken as it is: ``--clip`` then applies to the other file)."""
    from .compress import archive_sizes
    from .io import list_clips

    suffix = path.suffix.lower()
    if suffix == ".mrc":
        return [path.stem]
    database = suffix in (".h5", ".hdf5")
    names = list(archive_sizes(path)) if database and is_archive(path) else list_clips(path)
    if clip is None or not database:
        return names
    if clip not in names:
        raise FormatError(f"no clip {clip!r}; clips: {_listing(names)}", path)
    return [clip]


def _read_clip(path: Path, name: str):
    suffix = path.suffix.lower()
    if suffix == ".mrc":
        return decompress_file(path)
    if suffix in (".h5", ".hdf5") and is_archive(path):
        (container,) = read_archive(path, name).values()
        return decode_container(container, path=path)
    from .io import read

    return read(path, clip=name) if suffix in (".h5", ".hdf5") else read(path)


@cli.command("example")
@click.argument("output", metavar="OUT.bvh", type=click.Path(dir_okay=False, path_type=Path))
def example(output: Path) -> None:
    """Write the demo clip shipped with motionrep (a synthetic 450-frame walk) to OUT.bvh.

    \b
    Quick start:
      motionrep example walk.bvh
      motionrep compress walk.bvh -o walk.mrc --codec adaptive-fourier
    """
    from ._demo import demo_path
    from .io import atomic_path

    if output.suffix.lower() != ".bvh":
        raise click.UsageError(f"output {output}: the demo clip is a .bvh file")
    with atomic_path(output) as tmp:
        shutil.copyfile(demo_path(), tmp)
    click.echo(f"wrote {output} (synthetic walk, 450 frames at 30 fps, 15 joints)")
