"""``motionrep merge``: join archives, ``.mrc`` files and directories of them (the shards of a database compressed
in parts) into one archive or directory, refusing clashing clip names unless told how to resolve them.

Exit codes: 0 on success; 1 for a file problem (an unreadable or damaged clip, names that clash, an output that
exists without ``--force``), with one line on stderr and no output; 2 for a usage error; 130 on Ctrl-C.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from ._common import check_overwrite, collect, force_option, quiet_option, usage_suffix

__all__ = ["merge", "CLASH_POLICIES"]

#: How clips of the same name in two inputs are resolved (identical bytes never clash).
CLASH_POLICIES = ("error", "first", "last", "prefix")


def _shard(path: Path) -> list[Any]:
    """The compressed clips of one input, under their own names (an archive's clip names, a directory's .mrc
    files by their path relative to it, a .mrc file by its stem)."""
    from ..errors import FormatError
    from ..pipeline.sources import open_source

    from ..formats import COMPRESSED_SUFFIXES, CONTAINER_SUFFIX

    refs = collect([path], scan=(CONTAINER_SUFFIX,) if path.is_dir() else COMPRESSED_SUFFIXES)
    if not path.is_dir():
        with open_source(path) as src:
            if src.kind not in ("compressed", "archive"):
                raise FormatError("holds motions, not compressed clips (merge joins archives and .mrc files)", path)
    return refs


def _read_bytes(ref: Any) -> bytes:
    from ..io.container import unpack
    from ..pipeline.sources import open_source

    with open_source(ref.path) as src:
        data = src.archive.read_bytes(ref.clip) if src.kind == "archive" else Path(ref.path).read_bytes()
    unpack(data, ref.source)  # verified before it is copied: a damaged clip stops the merge, naming it
    return data


@click.command("merge")
@click.argument("inputs", metavar="IN...", nargs=-1, required=True, type=click.Path(exists=True, path_type=Path))
@click.option("-o", "--output", "output", required=True, type=click.Path(path_type=Path),
              help="OUT.h5 (one archive) or a directory of .mrc files.")
@click.option("--on-clash", type=click.Choice(CLASH_POLICIES), default="error", show_default=True,
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
    from ..errors import FormatError
    from ..formats import COMPRESSED_SUFFIXES, CONTAINER_SUFFIX, is_archive_path
    from ..pipeline.sources import NAME_SEPARATOR, listing

    for p in inputs:
        if not p.is_dir():
            usage_suffix(p, COMPRESSED_SUFFIXES, "input")
        if p.exists() and output.exists() and p.resolve() == output.resolve():
            raise click.UsageError(f"input and output are the same: {p}")
    to_archive = is_archive_path(output)
    if not to_archive and output.suffix:
        raise click.UsageError(f"output {output}: merge writes OUT.h5 (an archive) or a directory")
    from ..io._atomic import remove_stale_files  # temporary files a killed run left beside (or in) the output

    remove_stale_files(output.parent if to_archive else output)
    shards = [(p, _shard(p)) for p in inputs]
    chosen: dict[str, tuple[Path, Any, bytes | None]] = {}
    clashes: list[str] = []
    for path, refs in shards:
        for ref in refs:
            if ref.name not in chosen:
                chosen[ref.name] = (path, ref, None)
                continue
            first_path, first, data = chosen[ref.name]
            data = data if data is not None else _read_bytes(first)
            mine = _read_bytes(ref)
            if mine == data:
                chosen[ref.name] = (first_path, first, data)  # the same clip twice: one copy
                continue
            if on_clash == "first":
                continue
            if on_clash == "last":
                chosen[ref.name] = (path, ref, mine)
            elif on_clash == "prefix":
                del chosen[ref.name]
                for p, r, d in ((first_path, first, data), (path, ref, mine)):
                    name = f"{p.stem}{NAME_SEPARATOR}{r.name}"
                    if name in chosen:
                        raise FormatError(f"clip {r.name!r} would be renamed {name!r}, which is already taken",
                                          p)
                    chosen[name] = (p, r, d)
            else:
                clashes.append(f"{ref.name} ({first_path} and {path})")
    if clashes:
        raise FormatError(f"{len(clashes)} clip name{'s' if len(clashes) != 1 else ''} clash with different "
                          f"contents: {listing(clashes)}; use --on-clash first|last|prefix", output)
    names = sorted(chosen)

    def clips():
        for name in names:
            _, ref, data = chosen[name]
            yield name, data if data is not None else _read_bytes(ref)

    if to_archive:
        from ..io.archive import write_archive

        check_overwrite(output, force)
        write_archive(clips(), output)
    else:
        from ..batch.store import DirectoryStore

        if output.exists() and not output.is_dir():
            raise click.UsageError(f"output {output} exists and is not a directory")
        for name in names:
            check_overwrite(output / f"{name}{CONTAINER_SUFFIX}", force)
        store = DirectoryStore(output)
        for name, data in clips():
            store.commit(name, data)
    if not quiet:
        click.echo(f"wrote {len(names)} clips from {len(inputs)} inputs to {output}")
