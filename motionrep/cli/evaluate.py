"""``motionrep evaluate``: the shared L-infinity error between two motion files, or two databases clip by clip.

Exit codes: 0 on success; 1 when the files cannot be read or compared (one line naming the problem); 2 for a
usage error (``--clip`` without a database, a database against a file of one clip without ``--clip``).
"""

from __future__ import annotations

from pathlib import Path

import click

from ._common import flagged
from ._common import (STDIN_NAME, body_model_option, collect, comparison_options, echo_json, is_stdio, match_options,
                      stdin_inputs)

__all__ = ["evaluate"]


@click.command("evaluate")
@click.argument("reference", metavar="REF", type=click.Path(exists=True, allow_dash=True, path_type=Path))
@click.argument("candidate", metavar="CAND", type=click.Path(exists=True, allow_dash=True, path_type=Path))
@click.option("--clip", metavar="NAME", help="Compare only this clip of a database or archive.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@comparison_options
@click.option("--common", is_flag=True,
              help="Two databases, archives or directories: compare the clips both hold and list the others.")
@body_model_option
def evaluate(reference: Path, candidate: Path, clip: str | None, as_json: bool, match: str,
             strip_prefix: tuple[str, ...], ignore_extra: bool, resample: bool, common: bool) -> None:
    """Compare two motion files of one skeleton with the shared L-inf joint-position error.

    Either file may be a .mrc, which is decoded first. REF and CAND may also
    be HDF5 databases, archives of compressed clips, or directories of motion
    files and .mrc files (as written by convert and compress): their clips are
    compared by name (clips named as every command names them), one report per
    clip and the worst of them; --clip NAME compares one clip. Each file is
    opened once. One of REF and CAND may be '-': BVH, NPZ, HDF5, .glb or .mrc
    from standard input, told by its first bytes, named <stdin>.

    The default is strict: same joints in the same order, same end sites,
    same frame rate and count. A candidate that went through another tool
    (Blender, a retargeter) compares with --match names (joints by name, in
    any order; --strip-prefix mixamorig: removes a namespace; end sites
    missing on one side or turned into bone tails are left out or paired by
    position), --ignore-extra (joints only one side has are left out) and
    --resample (the candidate sampled at the reference's frame times). Every
    report says which joints, end sites and frames were compared and which
    were left out.

    \b
    --json: one clip gives the report's keys (max_error, max_error_percent,
    mean_error, mean_error_percent, frame, joint, height, units, num_frames,
    num_points, comparison: {match, joints, end_sites, tails, frames,
    frame_count, method, left_out}) plus reference and candidate; several
    clips give {reference, candidate, clips: [report + clip], worst: report +
    clip, only_in_reference, only_in_candidate}.

    \b
    Examples:
      motionrep evaluate walk.bvh walk.mrc
      motionrep evaluate db.h5 db_compressed.h5 --json
      motionrep evaluate clips/ clips_mrc/
      motionrep decompress walk.mrc -o - | motionrep evaluate walk.bvh -
      motionrep evaluate - db.h5 < db_compressed.h5
      motionrep evaluate walk.bvh blender.glb --match names --resample
      motionrep evaluate db.h5 other.h5 --common
    """
    options = match_options(match, strip_prefix, ignore_extra, resample)
    with stdin_inputs([reference, candidate]) as (ref_path, cand_path):
        shown = [STDIN_NAME if is_stdio(p) else str(p) for p in (reference, candidate)]
        _evaluate(Path(ref_path), Path(cand_path), shown, clip, as_json, options, common)


def _evaluate(reference: Path, candidate: Path, shown: list[str], clip: str | None, as_json: bool,
              options: object = None, common: bool = False) -> None:
    from ..batch.engine import clip_sets, evaluate_clips, pair_clips
    from ..errors import ParameterError
    from ..pipeline.sources import CLIP_SUFFIXES, open_source

    if clip is not None and not any(p.suffix.lower() in CLIP_SUFFIXES or p.is_dir()
                                    for p in (reference, candidate)):
        raise click.UsageError("--clip applies to HDF5 databases, archives, glTF files and directories")
    if reference.is_dir() or candidate.is_dir():
        from ..batch.engine import evaluate_refs, pair_refs
        from ..errors import FormatError
        from ..pipeline.sources import SOURCE_SUFFIXES, listing

        sides = [collect([p], scan=SOURCE_SUFFIXES) for p in (reference, candidate)]
        if clip is not None:
            for i, p in enumerate((reference, candidate)):
                chosen = [r for r in sides[i] if len(sides[i]) > 1 and clip in (r.name, r.clip)] or sides[i]
                if len(chosen) > 1:
                    raise FormatError(f"no clip named {clip!r}; clips: {listing([r.name for r in sides[i]])}", p)
                sides[i] = chosen
        pairs = pair_refs(*sides, common=common)
        only = clip_sets([r.name for r in sides[0]], [r.name for r in sides[1]]) if len(pairs) > 1 else ([], [])
        reports = evaluate_refs(pairs, options=options)
    else:
        with open_source(reference) as ref, open_source(candidate) as cand:
            try:
                pairs = pair_clips(ref, cand, clip, common=common)
            except ParameterError as exc:
                raise click.UsageError(flagged(exc)) from None
            only = clip_sets(ref.names, cand.names) if common and clip is None and len(pairs) > 1 else ([], [])
            reports = evaluate_clips(ref, cand, pairs, options=options)
    if len(reports) == 1:
        report = reports[0][1]
        if as_json:
            echo_json(dict(report.as_dict(), reference=shown[0], candidate=shown[1]))
        else:
            which = f" (clip {clip})" if clip is not None else ""
            click.echo(f"{shown[0]} vs {shown[1]}{which}: {report.num_frames} frames, {report.num_points} points")
            click.echo(report.summary())
            for line in report.comparison.lines():
                click.echo(line)
        return
    worst_name, worst = max(reports, key=lambda item: item[1].max_error_percent)
    if as_json:
        echo_json({"reference": shown[0], "candidate": shown[1],
                   "clips": [dict(r.as_dict(), clip=n) for n, r in reports],
                   "worst": dict(worst.as_dict(), clip=worst_name),
                   "only_in_reference": only[0], "only_in_candidate": only[1]})
        return
    click.echo(f"{shown[0]} vs {shown[1]}: {len(reports)} clips")
    width = max(4, *(len(n) for n, _ in reports))
    click.echo(f"  {'clip':<{width}}  {'frames':>7}  {'L-inf':>10}  {'% height':>8}  {'mean':>10}  worst at")
    for n, r in reports:
        click.echo(f"  {n:<{width}}  {r.num_frames:>7}  {r.max_error:>10.4g}  {r.max_error_percent:>8.3f}  "
                   f"{r.mean_error:>10.4g}  frame {r.frame}, {r.joint}")
    click.echo(f"worst: {worst_name}: {worst.summary()}")
    for line in worst.comparison.lines():
        click.echo(f"worst: {line}")
    incomplete = [n for n, r in reports if not r.comparison.complete]
    if incomplete:
        click.echo(f"left something out (see --json): {len(incomplete)} clips: {', '.join(incomplete)}")
    for names, side in zip(only, ("reference", "candidate")):
        if names:
            click.echo(f"only in the {side}, not compared ({len(names)}): {', '.join(names)}")
