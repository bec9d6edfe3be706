"""``motionrep convert``: BVH / NPZ / HDF5 / glTF, one clip or many, motions or a representation's features.

Exit codes: 0 on success; 1 for a file problem (missing, malformed, unknown clip, a clip that cannot be written
in the target format), with one line on stderr naming the file (and the line for BVH, the clip for HDF5) and no
output file left behind; 2 for a usage error (unknown suffix, incompatible options, an input given twice,
``IN`` equal to ``OUT``).
"""

from __future__ import annotations

import contextlib
import shutil
from pathlib import Path
from typing import Any, Iterator

import click

from ..errors import naming
from ..formats import BY_SUFFIX, MOTION_SUFFIXES
from ._common import (MOTION_FORMATS, OUT_FORMATS, STDIO, STDOUT_NAME, BatchProgress, body_model_option,
                      check_gltf_units, check_outputs, collect, expand_globs, force_option, gltf_unit_options, gltf_write_options,
                      is_stdio, quiet_option, stdin_inputs, stdout_output)

__all__ = ["convert"]

_MOTION_SUFFIXES = MOTION_SUFFIXES


def _format_or_usage(path: Path, what: str) -> str:
    """The format selected by ``path``'s suffix; an ``.mrc`` output and unknown suffixes are usage errors (exit
    2).  An ``.mrc`` input is decoded, as an archive of them is (one rule)."""
    suffix = path.suffix.lower()
    fmt = BY_SUFFIX.get(suffix)
    if fmt is not None and fmt.name == "mrc" and what == "input":
        return "mrc"
    if fmt is not None and fmt.name == "mrc":
        raise click.UsageError(f"output {path}: compress with 'motionrep compress IN -o {path}'")
    if fmt is not None and not fmt.writes and what == "output":
        raise click.UsageError(f"output {path}: motionrep reads FBX but does not write it; write .glb or .bvh")
    if suffix not in _MOTION_SUFFIXES:
        raise click.UsageError(f"{what} {path}: unknown file type {suffix or '(no suffix)'!r}; use one of "
                               + ", ".join(_MOTION_SUFFIXES))
    return BY_SUFFIX[suffix].name


def _in_file_error(exc: Exception, path: Path) -> Exception:
    """A library error as a one-line FormatError naming a file (errors that already name one are kept)."""
    from ..errors import FormatError

    return exc if isinstance(exc, FormatError) else naming(FormatError(str(exc), path), *getattr(exc, "parameters", ()))


def _converted(refs: list, representation: Any) -> Iterator[tuple[Any, Any]]:
    """``(ref, what the output stores)``: the motion, or the features of ``representation`` (features already of
    that representation and version are copied exactly; other features are decoded first)."""
    from ..errors import MotionrepError
    from ..io import FeatureClip, features_from_motion, motion_from_features
    from ..pipeline.sources import read_refs

    clips = read_refs(refs, stored=True)
    for i in range(len(refs)):
        try:
            ref, item = next(clips)
            if isinstance(item, FeatureClip):
                if representation is not None and (item.representation, item.representation_version) == (
                        representation.name, representation.version):
                    yield ref, item
                    continue
                item = motion_from_features(item, ref.path, clip_name=ref.clip)
            item = item if representation is None else features_from_motion(item, representation.name)
        except MotionrepError as exc:
            raise _in_file_error(exc, Path(refs[i].path)) from None
        yield ref, item


def _write_one(item: Any, path: Path, decimals: int | None, clip_name: str | None = None,
               units: tuple[float | None, str | None] = (None, None), shown: Any = None) -> None:
    from ..errors import FormatError, MotionrepError
    from ..io import FeatureClip, format_of, write, write_features

    options: dict[str, Any] = {}
    fmt = format_of(path)
    if fmt == "gltf" and not isinstance(item, FeatureClip):
        try:
            options.update(gltf_write_options(item, path, *units, shown=shown))
        except MotionrepError as exc:
            raise naming(FormatError(f"cannot write: {exc}", path), *exc.parameters) from None
    if fmt == "bvh" and decimals is not None:
        options["decimals"] = decimals
    if fmt in ("hdf5", "gltf") and clip_name is not None:
        options["clip"] = clip_name
    try:
        if isinstance(item, FeatureClip):
            write_features(item, path, **options)
        else:
            write(item, path, **options)
    except MotionrepError as exc:
        if isinstance(exc, FormatError):
            raise
        raise naming(FormatError(f"cannot write: {exc}", path), *exc.parameters) from None


@contextlib.contextmanager
def _bar(items: Iterator, total: int, label: str) -> Iterator[Iterator]:
    """The ``(ref, item)`` pairs of ``items`` with progress on stderr when converting several clips (the one
    progress mechanism, :class:`BatchProgress`: a bar on a terminal, a heartbeat otherwise); a plain
    pass-through for one."""
    if total <= 1:
        yield items
        return
    with BatchProgress(total, label, lambda pair: f"converted {pair[0].name}") as bar:
        def counted() -> Iterator:
            for pair in items:
                bar.note(pair[0].name, "writing")
                yield pair
                bar.done(pair)

        yield counted()


@click.command("convert")
@click.argument("paths", nargs=-1, required=True, metavar="IN... OUT")
@click.option("--clip", metavar="NAME",
              help="Take only this clip out of the (single) HDF5 database, glTF or FBX file given.")
@click.option("--format", "out_format", type=click.Choice(sorted(OUT_FORMATS)), default=None,
              help="File format written when OUT is a directory (default: bvh).")
@click.option("--representation", "-r", metavar="NAME",
              help="Store the features of this registered representation instead of the motion (.npz/.h5).")
@click.option("--decimals", type=click.IntRange(0, 17), default=None,
              help="Digits after the decimal point in BVH output (default: exact, the shortest decimal that reads "
                   "back to the same value).")
@click.option("--append", is_flag=True,
              help="OUT.h5 exists: add the clips to it (a clip of the same name needs --force to be replaced).")
@gltf_unit_options
@force_option
@quiet_option
@body_model_option
def convert(paths: tuple[str, ...], clip: str | None, out_format: str | None, representation: str | None,
            decimals: int | None, append: bool, gltf_scale: float | None, units: str | None, force: bool,
            quiet: bool) -> None:
    """Convert motion files between BVH, NPZ, HDF5 and glTF (format from the suffix).

    \b
    IN... are files (.bvh, .npz, .h5/.hdf5, .gltf/.glb, .fbx, .mrc) or directories
    (searched recursively for those suffixes, in sorted order; hidden files are
    skipped). FBX is read, not written. An AMASS .npz (SMPL-H parameters) is
    posed through the body model given with --body-model.
    OUT is:
      - a .bvh, .npz, .glb or .gltf file: exactly one clip goes in (use --clip for
        a database or a glTF file of several animations);
      - a .h5/.hdf5 file: a database of every clip given, written atomically;
      - a directory (existing, ending in '/', or without suffix): one file per
        clip, <clip name>.<--format>, the directory created if needed.

    \b
    Clip names: from each file's path relative to the directory given (or its
    stem for a file given directly), without suffix, '/' replaced by '__'; a
    suffix is kept where two files would share a name. A database given alone
    keeps its clip names; among several inputs, a database of several clips
    gives '<file name>__<clip>'. The same rules name clips in compress and bench.

    \b
    Features: --representation NAME stores that representation's features
    (.npz/.h5); converting a features file to a motion format decodes it.
    A compressed clip (.mrc) or an archive of them (written by compress) is
    decoded, as decompress does.

    \b
    Standard input and output: IN '-' reads a motion file from standard input
    (BVH, NPZ, an HDF5 database or archive, .glb; told by its first bytes);
    OUT '-' writes one clip to standard output, as BVH (or --format npz/h5/glb).
    IN may also be a quoted glob pattern ('clips/*.bvh', 'mocap/**/*.bvh').
    An OUT that exists (or a file OUT/ would replace) needs --force; --append
    adds the clips to an existing .h5 database instead, keeping its other clips
    exactly (a clip of the same name is replaced only with --force).

    \b
    Errors: a bad input stops the run with one line naming the file (exit 1)
    and no output file; for directory output the message says which files were
    already written. An unknown suffix, options that do not apply, an input
    given twice, or IN equal to OUT are usage errors (exit 2).

    \b
    glTF size: glTF is in metres. --units cm|m|in|mm says the clip's unit,
    --scale M gives metres per file unit; without either, the units the input
    states, else (BVH states none) the first of m, cm, in, mm that makes the
    character 1-2.5 m tall, else the scale that makes it 1.8 m; one line on
    stderr says what was assumed. motionrep reads its glTF back in the clip's
    own units.

    \b
    Examples:
      motionrep convert walk.bvh walk.npz
      motionrep convert clips/ clips.h5
      motionrep convert more/ clips.h5 --append
      motionrep convert clips.h5 out/ --format npz
      motionrep convert clips.h5 walk.bvh --clip walk --decimals 4
      motionrep convert walk.bvh walk_rq.npz --representation root-quat-axis-angle
      motionrep convert walk.bvh walk.glb
      motionrep convert robot.glb dance.bvh --clip Dance
      motionrep convert mixamo.fbx walk.bvh
      motionrep convert amass.npz walk.bvh --body-model SMPLH_male.npz
      motionrep convert walk.npz - | head
      cat walk.bvh | motionrep convert - walk.glb
      motionrep convert walk.bvh walk.glb --units cm
    """
    if len(paths) < 2:
        raise click.UsageError("convert needs at least one input and an output: IN... OUT")
    raw_out = paths[-1]
    with stdin_inputs(expand_globs(paths[:-1]), allowed=MOTION_FORMATS) as inputs:
        wrote = _convert([Path(p) for p in inputs], raw_out, clip, out_format, representation, decimals, force,
                         append, (gltf_scale, units))
    if not quiet:
        click.echo(f"wrote {wrote}", err=is_stdio(raw_out))


def _convert(inputs: list[Path], raw_out: str, clip: str | None, out_format: str | None,
             representation: str | None, decimals: int | None, force: bool, append: bool = False,
             units: tuple[float | None, str | None] = (None, None)) -> str:
    """Convert; what was written, for the ``wrote ...`` line."""
    out = Path(raw_out)
    to_stdout = is_stdio(raw_out)
    to_directory = not to_stdout and (out.is_dir() or raw_out.endswith(("/", "\\")) or out.suffix == "")
    if to_directory and out.exists() and not out.is_dir():
        raise click.UsageError(f"output {out} exists and is not a directory")
    if to_stdout:
        out = Path(f"stdout{OUT_FORMATS[out_format or 'bvh']}")
    else:  # temporary files a killed run left beside (or in) the output
        from ..io._atomic import remove_stale_files

        remove_stale_files(out if to_directory else (out.parent if str(out.parent) else "."))
    out_fmt = {"h5": "hdf5"}.get(out_format or "bvh", out_format or "bvh") if to_directory else \
        _format_or_usage(out, "output")
    if out_format is not None and not (to_directory or to_stdout):
        raise click.UsageError("--format applies only when OUT is a directory or '-'; otherwise the suffix decides")
    for p in inputs:
        if p.exists() and out.exists() and p.resolve() == out.resolve():
            raise click.UsageError(f"input and output are the same: {p}")
        if not p.is_dir():
            _format_or_usage(p, "input")
    if append and (to_directory or to_stdout or out_fmt != "hdf5"):
        raise click.UsageError("--append adds clips to an .h5 database: OUT must be a .h5/.hdf5 file")
    append = append and out.exists()
    if out_fmt == "hdf5" and not to_stdout and out.exists() and not (append or force):
        from ..errors import OutputExistsError

        raise OutputExistsError("exists; use --force to overwrite it, or --append to add the clips to it", out)
    if not to_directory and not append:
        check_outputs([raw_out], force)
    if decimals is not None and out_fmt != "bvh":
        raise click.UsageError("--decimals applies only to BVH output")
    check_gltf_units(*units, out_fmt == "gltf")
    if representation is not None and out_fmt in ("bvh", "gltf"):
        kind = "BVH" if out_fmt == "bvh" else "glTF"
        raise click.UsageError(f"--representation needs .npz or .h5 output: {kind} holds motions, not features")
    if clip is not None and (len(inputs) != 1 or inputs[0].is_dir() or _format_or_usage(inputs[0], "input")
                             not in ("hdf5", "gltf", "fbx")):
        raise click.UsageError("--clip takes one clip out of a single HDF5 database, glTF or FBX file input")
    rep = None
    if representation is not None:
        from ..plugin.registry import get_representation

        rep = get_representation(representation)  # an unknown name fails before any work (exit 1, lists names)

    refs = collect(inputs, clip=clip, exclude=[] if to_stdout else [out])
    if to_directory:
        suffix = OUT_FORMATS[out_format or "bvh"]
        check_outputs([out / (r.name + suffix) for r in refs], force)
        _to_directory(refs, out, suffix, rep, decimals, units)
        return f"{len(refs)} file{'s' if len(refs) > 1 else ''} to {out}"
    if len(refs) != 1 and out_fmt != "hdf5":
        from ..pipeline.sources import listing

        raise click.UsageError(f"{STDIO if to_stdout else out} holds one clip but the inputs hold {len(refs)} "
                               f"({listing([r.name for r in refs])}); use --clip NAME, an .h5 output or a "
                               "directory")
    shown = STDOUT_NAME if to_stdout else str(out)
    with stdout_output(raw_out, out.suffix) as target:
        if out_fmt == "hdf5":
            _to_database(refs, target, rep, append, force)
            return f"{shown}: {len(refs)} clip{'s' if len(refs) > 1 else ''}"
        item = next(_converted(refs, rep))[1]
        _write_one(item, target, decimals, units=units, shown=STDIO if to_stdout else out)
    return f"{shown}: {item.num_frames} frames"


def _to_database(refs: list, out: Path, representation: Any, append: bool = False, force: bool = False) -> None:
    """Write the clips to the database ``out``; with ``append``, after the clips ``out`` already holds (copied as
    stored, bit for bit), those of the same name replaced when ``force``."""
    from ..errors import FormatError, MotionrepError
    from ..io import write_database
    from ..io._hdf5 import HDF5Database

    kept: list[str] = []
    if append:
        with HDF5Database(out) as db:
            names = db.names
        new = {r.name for r in refs}
        clash = [n for n in names if n in new]
        if clash and not force:
            from ..pipeline.sources import listing

            raise FormatError(f"already holds clip{'s' if len(clash) > 1 else ''} {listing(clash)}; use --force "
                              "to replace them", out)
        kept = [n for n in names if n not in new]

    def clips() -> Iterator[tuple[str, Any]]:
        if kept:
            with HDF5Database(out) as db:
                for name in kept:
                    yield db.read_stored(name)
        with _bar(_converted(refs, representation), len(refs), f"Converting {len(refs)} clips to {out}") as bar:
            for ref, item in bar:
                yield ref.name, item

    try:
        write_database(clips(), out)
    except MotionrepError as exc:
        raise _in_file_error(exc, out) from None


def _to_directory(refs: list, out: Path, suffix: str, representation: Any, decimals: int | None,
                  units: tuple[float | None, str | None] = (None, None)) -> None:
    from ..errors import FormatError, MotionrepError
    from ..pipeline.sources import listing

    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    written: list[str] = []
    try:
        with _bar(_converted(refs, representation), len(refs), f"Converting {len(refs)} clips into {out}") as bar:
            for ref, item in bar:
                target = out / (ref.name + suffix)
                _write_one(item, target, decimals, clip_name=ref.name, units=units)
                written.append(target.name)
    except MotionrepError as exc:
        exc = _in_file_error(exc, out)
        if not written and created:
            shutil.rmtree(out, ignore_errors=True)  # created by this run and still empty
            note = "nothing was written"
        else:
            note = (f"{len(written)} of {len(refs)} files were written to {out} before this error: "
                    f"{listing(written)}" if written else "nothing was written")
        raise FormatError(f"{exc.message}; {note}", exc.path, exc.line) from None
