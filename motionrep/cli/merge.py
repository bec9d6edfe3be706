"""``motionrep merge``: join archives, ``.mrc`` files and directories of them (the shards of a database compressed
in parts) into one archive or directory, refusing clashing clip names unless told how to resolve them.

Exit codes: 0 on success; 1 for a file problem (an unreadable or damaged clip, names that clash, an output that
exists without ``--force``), with one line on stderr and no output; 2 for a usage error; 130 on Ctrl-C.
"""

from __future__ import annotations

from pathlib import Path

import click

from ._common import check_overwrite, flagged, force_option, quiet_option, usage_suffix

from ..defaults import CLASH_POLICIES, DEFAULT_ON_CLASH

__all__ = ["merge"]


@click.command("merge")
@click.argument("inputs", metavar="IN...", nargs=-1, required=True, type=click.Path(exists=True, path_type=Path))
@click.option("-o", "--output", "output", required=True, type=click.Path(path_type=Path),
              help="OUT.h5 (one archive) or a directory of .mrc files.")
@click.option("--on-clash", type=click.Choice(CLASH_POLICIES), default=DEFAULT_ON_CLASH,
              show_default=True,
              help="Two inputs hold different clips of one name: stop (error), keep the first input's or the last "
                   "input's, or name both '<input name>__<clip>' (prefix).")
@force_option
@quiet_option
def merge(inputs: tuple[Path, ...], output: Path, on_clash: str, force: bool, quiet: bool) -> None:
    """Join compressed clips IN (archives, .mrc files, directories of .mrc files) into OUT.

    Every clip keeps its name and its bytes (each verified on the way). Two
    inputs may hold the same clip (the same bytes, as shards that overlap);
    different clips of one name are an error unless --on-clash says how to
    resolve them. OUT is written atomically; an existing OUT needs --force.

    \b
    Examples:
      motionrep merge part1.h5 part2.h5 -o all.h5
      motionrep merge part1.h5 part2.h5 -o all.h5 --on-clash last
      motionrep merge clips_mrc/ extra.mrc -o all.h5
    """
    from ..batch.merge import plan_merge
    from ..errors import ValidationError
    from ..formats import COMPRESSED_SUFFIXES, CONTAINER_SUFFIX, is_archive_path

    for p in inputs:
        if not p.is_dir():
            usage_suffix(p, COMPRESSED_SUFFIXES, "input")
        if p.exists() and output.exists() and p.resolve() == output.resolve():
            raise click.UsageError(f"input and output are the same: {p}")
    to_archive = is_archive_path(output)
    if not to_archive and output.suffix:
        raise click.UsageError(f"output {output}: merge writes OUT.h5 (an archive) or a directory")
    if not to_archive and output.exists() and not output.is_dir():
        raise click.UsageError(f"output {output} exists and is not a directory")
    try:
        plan = plan_merge(inputs, on_clash, output)
    except ValidationError as exc:  # how the inputs were given (a file twice): a usage error
        raise click.UsageError(flagged(exc)) from None
    for target in [output] if to_archive else [output / f"{name}{CONTAINER_SUFFIX}" for name in plan.names]:
        check_overwrite(target, force)
    plan.write(output)
    if not quiet:
        click.echo(f"wrote {len(plan.names)} clips from {len(inputs)} inputs to {output}")
