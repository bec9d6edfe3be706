"""The ``convert`` and ``info`` commands (registered on :data:`motionrep.cli.cli` when imported).

Exit codes: 0 on success; 1 for a file problem (missing, malformed, unknown clip, a clip that cannot be written
in the target format), with one line on stderr naming the file (and the line for BVH, the clip for HDF5) and no
output file left behind; 2 for a usage error (unknown suffix, incompatible options, ``IN`` equal to ``OUT``).
"""

from __future__ import annotations

import contextlib
import json
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

import click

from ._model import Motion
from .cli import cli
from .errors import FormatError, MotionrepError
from .io import (
    SUFFIXES,
    FeatureClip,
    features_from_motion,
    format_of,
    list_clips,
    motion_from_features,
    read_stored,
    write,
    write_database,
    write_features,
)
from .io import _ERRORS as _FORMAT_ERRORS
from .io._hdf5 import clip_summaries
from .kinematics import character_height

__all__ = ["convert", "info", "INFO_JSON_VERSION", "info_dict"]

#: Version of the ``motionrep info --json`` object (``specs/formats/info-json.md``); bumped when a key changes
#: meaning or disappears (adding keys does not bump it).
INFO_JSON_VERSION = 1

#: Separator that replaces ``/`` when a relative path becomes a clip name.
NAME_SEPARATOR = "__"
_OUT_FORMATS = {"bvh": ".bvh", "npz": ".npz", "h5": ".h5"}
_MAX_LISTED = 10


# ---------------------------------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------------------------------
def _format_or_usage(path: Path, what: str) -> str:
    """The format selected by ``path``'s suffix; an unknown suffix is a usage error (exit 2)."""
    if path.suffix.lower() == ".mrc" and what == "input":
        raise click.UsageError(f"input {path} is a compressed clip: decode it with "
                               f"'motionrep decompress {path} -o OUT.bvh'")
    if path.suffix.lower() == ".mrc" and what == "output":
        raise click.UsageError(f"output {path}: compress with 'motionrep compress IN -o {path}'")
    try:
        return format_of(path)
    except FormatError:
        raise click.UsageError(f"{what} {path}: unknown file type {path.suffix or '(no suffix)'!r}; use one of "
                               + ", ".join(SUFFIXES)) from None


def _listing(names: list[str]) -> str:
    shown = ", ".join(names[:_MAX_LISTED])
    return shown + (f", ... ({len(names) - _MAX_LISTED} more)" if len(names) > _MAX_LISTED else "")


def _in_file_error(exc: MotionrepError, path: Path) -> FormatError:
    """A library error as a one-line FormatError naming a file (errors that already name one are kept)."""
    if isinstance(exc, FormatError):
        return exc
    return FormatError(str(exc), path)


@dataclass
class _Source:
    """One clip to convert: the file, the clip inside it (databases), and its name in the output."""

    path: Path
    clip: str | None
    name: str


def _is_hidden(rel: Path) -> bool:
    return any(part.startswith(".") for part in rel.parts)


def _scan_directory(directory: Path, out: Path) -> list[tuple[Path, str]]:
    """Known-suffix files under ``directory`` (sorted, hidden files and ``out`` skipped) with their names."""
    out_resolved = out.resolve()
    found = []
    for p in sorted(directory.rglob("*")):
        rel = p.relative_to(directory)
        if _is_hidden(rel) or p.suffix.lower() not in SUFFIXES or not p.is_file():
            continue
        r = p.resolve()
        if r == out_resolved or out_resolved in r.parents:
            continue  # never read the output (or an earlier run's output) back in
        found.append((p, NAME_SEPARATOR.join(rel.with_suffix("").parts)))
    if not found:
        raise FormatError("no " + ", ".join(SUFFIXES) + " files in this directory", directory)
    return found


def _unique_names(files: list[tuple[Path, str]]) -> list[tuple[Path, str]]:
    """Keep the suffix (``walk.bvh``, ``walk.npz``) on names that two files would otherwise share."""
    counts: dict[str, int] = {}
    for _, name in files:
        counts[name] = counts.get(name, 0) + 1
    return [(p, name + p.suffix if counts[name] > 1 else name) for p, name in files]


def _gather(inputs: list[Path], out: Path, clip: str | None) -> list[_Source]:
    """Expand the inputs (files, directories, databases) into the clips to convert, with unique names."""
    files: list[tuple[Path, str]] = []
    for p in inputs:
        if p.is_dir():
            files.extend(_scan_directory(p, out))
        else:
            _format_or_usage(p, "input")
            if not p.exists():
                raise FormatError("no such file or directory", p)
            files.append((p, p.stem))
    first: dict[Path, Path] = {}
    for p, _ in files:
        r = p.resolve()
        if r in first:
            raise click.UsageError(f"input {p} is given twice" + (f" (also as {first[r]})" if first[r] != p else ""))
        first[r] = p
    files = _unique_names(files)
    single = len(files) == 1
    sources: list[_Source] = []
    for p, name in files:
        if format_of(p) != "hdf5":
            sources.append(_Source(p, None, name))
            continue
        clips = list_clips(p)
        if clip is not None:
            if clip not in clips:
                raise FormatError(f"no clip named {clip!r}; clips in this file: {_listing(clips)}", p)
            sources.append(_Source(p, clip, clip))
        elif single:  # one database in: its clips keep their names
            sources.extend(_Source(p, c, c) for c in clips)
        elif len(clips) == 1:
            sources.append(_Source(p, clips[0], name))
        else:
            sources.extend(_Source(p, c, f"{name}{NAME_SEPARATOR}{c}") for c in clips)
    seen: dict[str, _Source] = {}
    for s in sources:
        if s.name in seen:
            raise FormatError(f"two inputs would both be clip {s.name!r} ({seen[s.name].path} and {s.path}); "
                              "rename one", s.path)
        seen[s.name] = s
    return sources


def _load(src: _Source, representation: str | None) -> Motion | FeatureClip:
    """Read one source clip and turn it into what the output stores (motion, or features of ``representation``)."""
    try:
        name, item = read_stored(src.path, src.clip)
        if representation is not None and isinstance(item, FeatureClip):
            from .plugins import get_representation

            rep = get_representation(representation)
            if item.representation == rep.name and item.representation_version == rep.version:
                return item  # already these features: copy them exactly
        if isinstance(item, FeatureClip):
            fmt = format_of(src.path)
            item = motion_from_features(item, src.path, _FORMAT_ERRORS[fmt],
                                        clip_name=name if fmt == "hdf5" else None)
        return item if representation is None else features_from_motion(item, representation)
    except MotionrepError as exc:
        raise _in_file_error(exc, src.path) from None


def _write_one(item: Motion | FeatureClip, path: Path, decimals: int | None, clip_name: str | None = None) -> None:
    options: dict[str, Any] = {}
    fmt = format_of(path)
    if fmt == "bvh" and decimals is not None:
        options["decimals"] = decimals
    if fmt == "hdf5" and clip_name is not None:
        options["clip"] = clip_name
    try:
        if isinstance(item, FeatureClip):
            write_features(item, path, **options)
        else:
            write(item, path, **options)
    except MotionrepError as exc:
        if isinstance(exc, FormatError):
            raise
        raise FormatError(f"cannot write: {exc}", path) from None


def _progress(sources: list[_Source], label: str) -> Any:
    """A progress bar on stderr when converting several clips; a plain pass-through otherwise."""
    if len(sources) > 1:
        return click.progressbar(sources, label=label, file=sys.stderr,
                                 item_show_func=lambda s: s.name if s is not None else None)
    return contextlib.nullcontext(sources)


def _is_directory_target(out: Path, raw: str) -> bool:
    return out.is_dir() or raw.endswith(("/", "\\")) or out.suffix == ""


# ---------------------------------------------------------------------------------------------------------------
# convert
# ---------------------------------------------------------------------------------------------------------------
@cli.command("convert")
@click.argument("paths", nargs=-1, required=True, metavar="IN... OUT")
@click.option("--clip", metavar="NAME", help="Take only this clip out of the (single) HDF5 database given.")
@click.option("--format", "out_format", type=click.Choice(sorted(_OUT_FORMATS)), default=None,
              help="File format written when OUT is a directory (default: bvh).")
@click.option("--representation", "-r", metavar="NAME",
              help="Store the features of this registered representation instead of the motion (.npz/.h5).")
@click.option("--decimals", type=click.IntRange(0, 17), default=None,
              help="Digits after the decimal point in BVH output (default 6).")
def convert(paths: tuple[str, ...], clip: str | None, out_format: str | None, representation: str | None,
            decimals: int | None) -> None:
    """Convert motion files between BVH, NPZ and HDF5 (format from the suffix).

    \b
    IN... are files (.bvh, .npz, .h5/.hdf5) or directories (searched recursively
    for those suffixes, in sorted order; hidden files are skipped). OUT is:
      - a .bvh or .npz file: exactly one clip goes in (use --clip for a database);
      - a .h5/.hdf5 file: a database of every clip given, written atomically;
      - a directory (existing, ending in '/', or without suffix): one file per
        clip, <clip name>.<--format>, the directory created if needed.

    \b
    Clip names: from each file's path relative to the directory given (or its
    stem for a file given directly), without suffix, '/' replaced by '__'; a
    suffix is kept where two files would share a name. A database given alone
    keeps its clip names; among several inputs, a database of several clips
    gives '<file name>__<clip>'.

    \b
    Features: --representation NAME stores that representation's features
    (.npz/.h5); converting a features file to a motion format decodes it.

    \b
    Errors: a bad input stops the run with one line naming the file (exit 1)
    and no output file; for directory output the message says which files were
    already written. An unknown suffix, options that do not apply, or IN equal
    to OUT are usage errors (exit 2).

    \b
    Examples:
      motionrep convert walk.bvh walk.npz
      motionrep convert clips/ clips.h5
      motionrep convert clips.h5 out/ --format npz
      motionrep convert clips.h5 walk.bvh --clip walk --decimals 4
      motionrep convert walk.bvh walk_rq.npz --representation root-quat-axis-angle
    """
    if len(paths) < 2:
        raise click.UsageError("convert needs at least one input and an output: IN... OUT")
    raw_out = paths[-1]
    out = Path(raw_out)
    inputs = [Path(p) for p in paths[:-1]]
    to_directory = _is_directory_target(out, raw_out)
    if to_directory and out.exists() and not out.is_dir():
        raise click.UsageError(f"output {out} exists and is not a directory")
    out_fmt = (out_format or "bvh") if to_directory else _format_or_usage(out, "output")
    out_fmt = {"h5": "hdf5"}.get(out_fmt, out_fmt)
    if out_format is not None and not to_directory:
        raise click.UsageError("--format applies only when OUT is a directory; otherwise the suffix decides")
    for p in inputs:
        if p.exists() and out.exists() and p.resolve() == out.resolve():
            raise click.UsageError(f"input and output are the same: {p}")
    if decimals is not None and out_fmt != "bvh":
        raise click.UsageError("--decimals applies only to BVH output")
    if representation is not None and out_fmt == "bvh":
        raise click.UsageError("--representation needs .npz or .h5 output: BVH holds motions, not features")
    if clip is not None and (len(inputs) != 1 or inputs[0].is_dir() or _format_or_usage(inputs[0], "input")
                             != "hdf5"):
        raise click.UsageError("--clip takes one clip out of a single HDF5 database input")
    if representation is not None:
        from .plugins import get_representation

        get_representation(representation)  # an unknown name fails before any work (exit 1, lists the names)

    sources = _gather(inputs, out, clip)
    if to_directory:
        _convert_to_directory(sources, out, _OUT_FORMATS[out_format or "bvh"], representation, decimals)
    elif out_fmt == "hdf5":
        _convert_to_database(sources, out, representation)
    else:
        if len(sources) != 1:
            raise click.UsageError(f"{out} holds one clip but the inputs hold {len(sources)} "
                                   f"({_listing([s.name for s in sources])}); use --clip NAME, an .h5 output or "
                                   "a directory")
        _write_one(_load(sources[0], representation), out, decimals)


def _convert_to_database(sources: list[_Source], out: Path, representation: str | None) -> None:
    def clips() -> Iterator[tuple[str, Motion | FeatureClip]]:
        with _progress(sources, f"Converting {len(sources)} clips to {out}") as bar:
            for src in bar:
                yield src.name, _load(src, representation)

    try:
        write_database(clips(), out)
    except MotionrepError as exc:
        raise _in_file_error(exc, out) from None


def _convert_to_directory(sources: list[_Source], out: Path, suffix: str, representation: str | None,
                          decimals: int | None) -> None:
    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    written: list[str] = []
    try:
        with _progress(sources, f"Converting {len(sources)} clips into {out}") as bar:
            for src in bar:
                target = out / (src.name + suffix)
                _write_one(_load(src, representation), target, decimals, clip_name=src.name)
                written.append(target.name)
    except MotionrepError as exc:
        exc = _in_file_error(exc, out)
        if not written and created:
            shutil.rmtree(out, ignore_errors=True)  # created by this run and still empty
            note = "nothing was written"
        else:
            note = (f"{len(written)} of {len(sources)} files were written to {out} before this error: "
                    f"{_listing(written)}" if written else "nothing was written")
        raise FormatError(f"{exc.message}; {note}", exc.path, exc.line) from None


# ---------------------------------------------------------------------------------------------------------------
# info
# ---------------------------------------------------------------------------------------------------------------
def _skeleton_info(item: Motion | FeatureClip) -> dict[str, Any]:
    sk = item.skeleton
    sites = [0] * sk.num_joints
    for p in sk.end_site_parents.tolist():
        sites[p] += 1
    return {
        "joints": sk.num_joints,
        "end_sites": sk.num_end_sites,
        "channels": sk.num_channels,
        "height": character_height(sk),
        "units": sk.units,
        "layout": [
            {"name": sk.names[j], "parent": None if j == 0 else sk.names[int(sk.parents[j])],
             "channels": list(sk.channels[j]), "rotation_order": sk.rotation_orders[j],
             "position_axes": sk.position_axes[j], "end_sites": sites[j]}
            for j in range(sk.num_joints)
        ],
    }


def info_dict(path: str | Path, clip: str | None = None) -> dict[str, Any]:
    """The object ``motionrep info --json`` prints (keys in ``specs/formats/info-json.md``).

    Raises:
        FormatError: naming the file (and clip) if it cannot be read.
    """
    path = Path(path)
    if path.suffix.lower() == ".mrc":
        from .container import read_container

        if clip is not None:
            raise FormatError("--clip applies to HDF5 databases and archives; a .mrc file holds one clip", path)
        base = {"info_version": INFO_JSON_VERSION, "file": str(path), "format": "mrc"}
        return {**base, **_compressed_info(read_container(path), path.stem, path.stat().st_size)}
    fmt = format_of(path)
    base: dict[str, Any] = {"info_version": INFO_JSON_VERSION, "file": str(path), "format": fmt}
    if fmt == "hdf5":
        from .compress import archive_sizes, is_archive, read_archive

        if is_archive(path):
            sizes = archive_sizes(path)
            if clip is None and len(sizes) != 1:
                containers = read_archive(path)
                return {**base, "kind": "archive", "clips": [_archive_row(name, c, sizes[name])
                                                             for name, c in containers.items()]}
            name, container = next(iter(read_archive(path, clip).items()))
            return {**base, **_compressed_info(container, name, sizes[name])}
    if fmt == "hdf5" and clip is None:
        summaries = clip_summaries(path)
        if len(summaries) != 1:
            return {**base, "kind": "database", "clips": summaries}
    name, item = read_stored(path, clip)
    out = {**base, "kind": "features" if isinstance(item, FeatureClip) else "motion", "clip": name,
           "frames": item.num_frames, "fps": item.fps, "duration": item.duration, **_skeleton_info(item)}
    if isinstance(item, FeatureClip):
        out["representation"] = {"name": item.representation, "version": item.representation_version,
                                 "width": item.width}
    return out


def _compressed_info(c, name: str, size: int) -> dict[str, Any]:
    """``info`` of one compressed clip (a ``.mrc`` file or a clip of an archive)."""
    from .evaluate import compression_figures
    from .plugins import get_representation

    sk = c.skeleton
    try:
        width: int | None = get_representation(c.representation).width(sk)
    except MotionrepError:  # the representation's plugin is not installed: no figures that need its width
        width = None
    figures = None
    if width is not None:
        figures = compression_figures(num_frames=c.num_frames, feature_width=width, num_parameters=c.num_parameters,
                                      num_channels=sk.num_channels, num_joints=sk.num_joints,
                                      compressed_bytes=size).as_dict()
    return {"kind": "compressed", "clip": name, "frames": c.num_frames, "fps": c.fps,
            "duration": c.num_frames / c.fps, **_skeleton_info(c),
            "codec": {"name": c.codec, "version": c.codec_version, "plugin": c.codec_plugin,
                      "params": dict(c.params), "outcome": dict(c.info)},
            "representation": {"name": c.representation, "version": c.representation_version,
                               "plugin": c.representation_plugin, "width": width},
            "bytes": size, "parameters": c.num_parameters,
            "arrays": [{"name": k, "dtype": a.dtype.str[1:], "shape": list(a.shape)} for k, a in c.arrays.items()],
            "evaluation": None if c.evaluation is None else dict(c.evaluation),
            "figures": figures,
            "motionrep_version": c.extra.get("motionrep_version"), "seed": c.extra.get("seed"),
            "max_error": c.extra.get("max_error")}


def _archive_row(name: str, c, size: int) -> dict[str, Any]:
    ev = c.evaluation or {}
    return {"name": name, "codec": c.codec, "representation": c.representation, "outcome": _outcome(c.info),
            "frames": c.num_frames, "fps": c.fps, "duration": c.num_frames / c.fps,
            "joints": c.skeleton.num_joints, "bytes": size, "max_error": ev.get("max_error"),
            "max_error_percent": ev.get("max_error_percent")}


def _outcome(info: dict[str, Any]) -> str:
    """``K=5`` / ``rank=9``: the codec's outcome without long lists."""
    return ", ".join(f"{k}={v}" for k, v in info.items() if not isinstance(v, (list, dict))) or "-"


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def _info_text(d: dict[str, Any]) -> str:
    lines = [f"file:       {d['file']}"]
    if d["kind"] == "archive":
        lines.append(f"format:     archive of compressed clips (.mrc), {len(d['clips'])} clips")
        width = max([4] + [len(c["name"]) for c in d["clips"]])
        lines.append(f"  {'clip':<{width}}  {'codec':<16}  {'outcome':<10}  {'frames':>7}  {'fps':>7}  "
                     f"{'joints':>6}  {'bytes':>9}  L-inf")
        for c in d["clips"]:
            err = "-" if c["max_error"] is None else f"{_fmt(c['max_error'])} ({c['max_error_percent']:.3g}%)"
            lines.append(f"  {c['name']:<{width}}  {c['codec']:<16}  {c['outcome']:<10}  {c['frames']:>7}  "
                         f"{_fmt(c['fps']):>7}  {c['joints']:>6}  {c['bytes']:>9}  {err}")
        return "\n".join(lines)
    if d["kind"] == "database":
        lines.append(f"format:     {d['format']} database, {len(d['clips'])} clips")
        width = max([4] + [len(c["name"]) for c in d["clips"]])
        lines.append(f"  {'clip':<{width}}  {'kind':<8}  {'frames':>7}  {'fps':>9}  {'duration':>10}  joints")
        for c in d["clips"]:
            kind = c["kind"] if c["kind"] == "motion" else f"{c['representation']}"
            lines.append(f"  {c['name']:<{width}}  {kind:<8}  {c['frames']:>7}  {_fmt(c['fps']):>9}  "
                         f"{_fmt(c['duration']) + ' s':>10}  {c['joints']}")
        return "\n".join(lines)
    units = d["units"] if d["units"] else "file units (unknown)"
    lines += [
        f"format:     {d['format']} ({d['kind']})",
        f"clip:       {d['clip']}",
    ]
    if d["kind"] == "features":
        r = d["representation"]
        lines.append(f"features:   {r['name']} version {r['version']}, width {r['width']}")
    if d["kind"] == "compressed":
        c, r = d["codec"], d["representation"]
        lines.append(f"codec:      {c['name']} (payload version {c['version']}), {_outcome(c['outcome'])}"
                     + (f", parameters {json.dumps(c['params'])}" if c["params"] else ""))
        omega = c["outcome"].get("omega")
        if omega and isinstance(c["outcome"].get("K"), list):  # one network per window
            lines.append(f"            K per window: {', '.join(str(k) for k in c['outcome']['K'])}")
        elif omega:
            lines.append(f"            frequencies (cycles over the clip): {', '.join(_fmt(w) for w in omega)}")
        lines.append(f"features:   {r['name']} version {r['version']}"
                     + (f", width {r['width']}" if r["width"] is not None else ""))
        lines.append(f"size:       {d['bytes']} bytes, {d['parameters']} stored numbers")
        f = d["figures"]
        if f is not None:
            lines.append(f"ratios:     paper {f['paper_ratio']:.2f}x, vs float32 channels {f['float32_ratio']:.2f}x, "
                         f"{f['bits_per_joint_frame']:.2f} bits/joint/frame")
        e = d["evaluation"]
        if e is not None:
            bound = "none" if e.get("bound") is None else _fmt(e["bound"])
            if e.get("bound") is not None and d.get("max_error"):
                bound += f" (--max-error {d['max_error']})"
            lines.append(f"L-inf:      {_fmt(e['max_error'])} ({e['max_error_percent']:.3g}% of height) at frame "
                         f"{e['frame']}, {e['joint']}; mean {_fmt(e['mean_error'])}; bound {bound} "
                         "(measured on the stored payload when written)")
    lines += [
        f"joints:     {d['joints']}",
        f"end sites:  {d['end_sites']}",
        f"frames:     {d['frames']}",
        f"fps:        {_fmt(d['fps'])}",
        f"duration:   {_fmt(d['duration'])} s",
        f"height:     {_fmt(d['height'])} {units}",
        f"channels:   {d['channels']}",
        "channel layout (joint: channels in file order [rotation order]):",
    ]
    depth: dict[str, int] = {}
    for j in d["layout"]:
        depth[j["name"]] = 0 if j["parent"] is None else depth[j["parent"]] + 1
    width = max(2 * depth[j["name"]] + len(j["name"]) for j in d["layout"])
    for j in d["layout"]:
        label = "  " * depth[j["name"]] + j["name"]
        chans = " ".join(j["channels"]) or "(none)"
        order = f" [{j['rotation_order']}]" if j["rotation_order"] else ""
        lines.append(f"  {label:<{width}}  {chans}{order}")
    return "\n".join(lines)


@cli.command("info")
@click.argument("file", metavar="FILE")
@click.option("--clip", metavar="NAME", help="The clip to describe in an HDF5 database or archive.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object (keys: specs/formats/info-json.md).")
def info(file: str, clip: str | None, as_json: bool) -> None:
    """Describe a motion file: skeleton, frames, fps, duration, height, channel layout.

    \b
    For an HDF5 database of several clips (without --clip): each clip's name,
    kind, frames, fps, duration and joints. For a features file: the
    representation, its version and the feature width. For a compressed
    .mrc file (or a clip of an archive made by compress): the codec, its
    outcome (K and frequencies, or rank), size, compression ratios and the
    error measured when it was written; an archive without --clip lists its
    clips with codec, size and error.

    \b
    --json prints one object; the keys are documented in
    specs/formats/info-json.md. Always present: info_version (1), file,
    format ("bvh" | "npz" | "hdf5" | "mrc"), kind ("motion" | "features" |
    "database" | "compressed" | "archive").
    Database: clips (list of {name, kind, frames, fps, duration, joints, and for
    features representation, representation_version, width}). Motion/features:
    clip, frames, fps, duration (s), joints, end_sites, channels, height,
    units (null when unknown), layout (per joint: name, parent, channels,
    rotation_order, position_axes, end_sites); features also representation
    {name, version, width}; compressed also codec, representation, bytes,
    parameters, arrays, evaluation, figures.
    """
    path = Path(file)
    if path.suffix.lower() != ".mrc":
        _format_or_usage(path, "file")
    if clip is not None and (path.suffix.lower() == ".mrc" or format_of(path) != "hdf5"):
        raise click.UsageError("--clip applies to HDF5 databases and archives")
    d = info_dict(path, clip)
    click.echo(json.dumps(d, indent=2) if as_json else _info_text(d))
