"""Joining compressed clips from several inputs (HDF5 archives, ``.mrc`` files, directories of ``.mrc`` files:
the shards of a database compressed in parts) into one archive or directory, and the policy for clips of one
name in two inputs.

Every clip keeps its name and its bytes, each verified on the way.  Two inputs may hold the same clip (the same
bytes, as shards that overlap): one copy is kept.  Different clips of one name are resolved by ``on_clash``:
``"error"`` (refuse, naming every clash), ``"first"`` / ``"last"`` (keep the first or last input's), or
``"prefix"`` (keep both, renamed ``<input stem>__<clip>``).  :func:`plan_merge` reads and resolves; the plan's
:meth:`MergePlan.write` writes the result atomically (``motionrep merge`` checks for existing outputs between
the two).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator, Sequence

from ..defaults import CLASH_POLICIES, DEFAULT_ON_CLASH
from ..errors import FormatError, ValidationError, naming

__all__ = ["CLASH_POLICIES", "MergePlan", "plan_merge"]


def _shard(path: Path) -> list[Any]:
    """The compressed clips of one input, under their own names (an archive's clip names, a directory's .mrc
    files by their path relative to it, a .mrc file by its stem)."""
    from ..formats import COMPRESSED_SUFFIXES, CONTAINER_SUFFIX
    from ..pipeline.sources import collect_clips, open_source

    refs = collect_clips([path], scan=(CONTAINER_SUFFIX,) if path.is_dir() else COMPRESSED_SUFFIXES)
    if not path.is_dir():
        with open_source(path) as src:
            if src.kind not in ("compressed", "archive"):
                raise FormatError("holds motions, not compressed clips (merge joins archives and .mrc files)", path)
    return refs


def _read_bytes(ref: Any) -> bytes:
    """A clip's ``.mrc`` bytes, verified (a damaged clip stops the merge, naming it)."""
    from ..io.container import unpack
    from ..pipeline.sources import open_source

    with open_source(ref.path) as src:
        data = src.archive.read_bytes(ref.clip) if src.kind == "archive" else Path(ref.path).read_bytes()
    unpack(data, ref.source)
    return data


@dataclass(frozen=True)
class MergePlan:
    """What a merge writes: ``names`` (sorted) and, for each, the input it comes from and its clip reference
    (``chosen``; the bytes when they were already read to compare)."""

    inputs: tuple[Path, ...]
    chosen: dict[str, tuple[Path, Any, bytes | None]]

    @property
    def names(self) -> list[str]:
        return sorted(self.chosen)

    def clips(self) -> Iterator[tuple[str, bytes]]:
        """``(name, .mrc bytes)`` in name order, each verified."""
        for name in self.names:
            _, ref, data = self.chosen[name]
            yield name, data if data is not None else _read_bytes(ref)

    def write(self, output: str | os.PathLike[str]) -> None:
        """Write the clips to ``output``: an HDF5 archive (``.h5``), atomically, or a directory of ``.mrc``
        files (each written atomically; created if missing).  Existing files are replaced: check first."""
        from ..formats import is_archive_path
        from ..io._atomic import remove_stale_files  # what a killed run left beside (or in) the output

        output = Path(output)
        to_archive = is_archive_path(output)
        remove_stale_files(output.parent if to_archive else output)
        if to_archive:
            from ..io.archive import write_archive

            write_archive(self.clips(), output)
            return
        from .store import DirectoryStore

        store = DirectoryStore(output)
        for name, data in self.clips():
            store.commit(name, data)


def plan_merge(inputs: Sequence[str | os.PathLike[str]], on_clash: str = DEFAULT_ON_CLASH,
               output: str | os.PathLike[str] | None = None) -> MergePlan:
    """Read the compressed clips of ``inputs`` (archives, ``.mrc`` files, directories of ``.mrc`` files) and
    resolve clips of one name by ``on_clash`` (:data:`CLASH_POLICIES`); ``output``, the merge's result, is the
    file a clash error names.

    Raises:
        ValidationError: an unknown ``on_clash``; inputs given in a way :func:`collect_clips` refuses.
        FormatError: an input that holds motions, a damaged clip, clashing names under ``"error"``, or a
            ``"prefix"`` name already taken.
    """
    from ..pipeline.sources import NAME_SEPARATOR, listing

    if on_clash not in CLASH_POLICIES:
        raise naming(ValidationError(f"on_clash must be one of {', '.join(CLASH_POLICIES)}, got {on_clash!r}"),
                     "on_clash")
    paths = tuple(Path(p) for p in inputs)
    shards = [(p, _shard(p)) for p in paths]
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
        raise naming(FormatError(f"{len(clashes)} clip name{'s' if len(clashes) != 1 else ''} clash with different "
                                 f"contents: {listing(clashes)}; use on_clash=first|last|prefix", output), "on_clash=")
    return MergePlan(paths, chosen)
