"""``motionrep info``: what a motion file holds, as text or as the JSON of :func:`motionrep.present.info.info_dict`.

Exit codes: 0 on success; 1 when the file cannot be read (one line naming it); 2 for a usage error (unknown
suffix, ``--clip`` on a file of one clip).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from ._common import (STDIN_NAME, body_model_option, echo_json, expand_globs, flagged, is_stdio, stdin_inputs,
                      usage_suffix)

__all__ = ["info"]


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def _fps(x: float) -> str:
    from ..model.timefmt import fps_text

    return fps_text(x)


def _rate(x: float) -> str:
    from ..model.timefmt import fps_text, frame_time_text

    return f"{fps_text(x)} (frame time {frame_time_text(x)} s)"


def _seconds(x: float) -> str:
    from ..model.timefmt import seconds_text

    return seconds_text(x)


def _info_text(d: dict[str, Any], verbose: bool = False) -> str:
    lines = [f"file:       {d['file']}"]
    if d["kind"] == "archive":
        lines.append(f"format:     archive of compressed clips (.mrc), {len(d['clips'])} clips")
        width = max([4] + [len(c["name"]) for c in d["clips"]])
        lines.append(f"  {'clip':<{width}}  {'codec':<16}  {'outcome':<10}  {'frames':>7}  {'fps':>7}  "
                     f"{'joints':>6}  {'bytes':>9}  {'payload bits/bone/frame':>23}  L-inf")
        for c in d["clips"]:
            err = "-" if c["max_error"] is None else f"{_fmt(c['max_error'])} ({c['max_error_percent']:.3g}%)"
            lines.append(f"  {c['name']:<{width}}  {c['codec']:<16}  {c['outcome']:<10}  {c['frames']:>7}  "
                         f"{_fps(c['fps']):>7}  {c['joints']:>6}  {c['bytes']:>9}  "
                         f"{c['payload_bits_per_bone_frame']:>23.3f}  {err}")
        return "\n".join(lines)
    if d["kind"] == "database":
        lines.append(f"format:     {d['format']} database, {len(d['clips'])} clips")
        width = max([4] + [len(c["name"]) for c in d["clips"]])
        lines.append(f"  {'clip':<{width}}  {'kind':<8}  {'frames':>7}  {'fps':>9}  {'duration':>10}  joints")
        for c in d["clips"]:
            kind = c["kind"] if c["kind"] == "motion" else f"{c['representation']}"
            lines.append(f"  {c['name']:<{width}}  {kind:<8}  {c['frames']:>7}  {_fps(c['fps']):>9}  "
                         f"{_seconds(c['duration']):>10}  {c['joints']}")
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
        from ..present.info import compressed_facts

        lines += [f"{label + ':':<12}{flagged(text)}" for label, text in compressed_facts(d, verbose)]
    lines += [
        f"joints:     {d['joints']}",
        f"end sites:  {d['end_sites']}",
        f"frames:     {d['frames']}",
        f"fps:        {_rate(d['fps'])}",
        f"duration:   {_seconds(d['duration'])}",
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


def _row(d: dict[str, Any]) -> list[str]:
    """One row of the ``info DIR`` table."""
    from ..pipeline.figures import PAYLOAD_BPBF

    kind = d["kind"]
    if kind in ("archive", "database"):
        clips = d["clips"]
        return [d["file"], d["format"], kind, str(len(clips)), str(sum(c["frames"] for c in clips)), "-", "-",
                "-", "-"]
    bpbf = d.get(PAYLOAD_BPBF)
    ev = d.get("evaluation") or {}
    err = "-" if ev.get("max_error_percent") is None else f"{ev['max_error_percent']:.3g}%"
    return [d["file"], d["format"], kind, "1", str(d["frames"]), _fmt(d["fps"]), str(d["joints"]),
            "-" if bpbf is None else f"{bpbf:.3f}", err]


def _table(described: list[dict[str, Any]]) -> str:
    """``info DIR``: one row per file."""
    from ..pipeline.figures import LABELS, PAYLOAD_BPBF

    head = ["file", "format", "kind", "clips", "frames", "fps", "joints", LABELS[PAYLOAD_BPBF], "L-inf"]
    rows = [head] + [_row(d) for d in described]
    widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
    return "\n".join("  ".join(c.ljust(w) if i < 3 else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths))).rstrip()
                     for r in rows)


@click.command("info")
@click.argument("files", metavar="FILE...", nargs=-1, required=True)
@click.option("--clip", metavar="NAME",
              help="The clip to describe in an HDF5 database or archive, or a glTF file's animation.")
@click.option("--json", "as_json", is_flag=True,
              help="Print one JSON object (a list of them for several files; keys: specs/formats/info-json.md).")
@click.option("--verbose", "-v", is_flag=True,
              help="Also the other size figures of a .mrc (stored numbers, the paper's ratio, vs float32).")
@body_model_option
def info(files: tuple[str, ...], clip: str | None, as_json: bool, verbose: bool) -> None:
    """Describe motion files: skeleton, frames, fps, duration, height, channel layout.

    \b
    FILE may be several files, quoted glob patterns ('clips/*.bvh'), a
    directory (searched recursively; a table, one row per file), or '-'
    (BVH, NPZ, HDF5, glTF or .mrc from standard input, told by its first
    bytes: cat db.h5 | motionrep info -); each is described in turn.
    Suffixes: .bvh, .npz, .h5, .hdf5, .gltf, .glb, .fbx, .mrc (an AMASS .npz
    with --body-model).

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
    format ("bvh" | "npz" | "hdf5" | "gltf" | "fbx" | "mrc"), kind ("motion" | "features" |
    "database" | "compressed" | "archive").
    Database: clips (list of {name, kind, frames, fps, duration, joints, and for
    features representation, representation_version, width}). Motion/features:
    clip, frames, fps, duration (s), joints, end_sites, channels, height,
    units (null when unknown), layout (per joint: name, parent, channels,
    rotation_order, position_axes, end_sites); features also representation
    {name, version, width}; compressed also codec, representation, bytes,
    parameters, payload_bytes, payload_bits_per_bone_frame,
    file_bits_per_bone_frame, arrays, evaluation, figures.
    """
    from ..present.info import info_dict
    from ..pipeline.sources import CLIP_SUFFIXES, SOURCE_SUFFIXES, scan_files

    given: list[str] = []
    table = False
    for f in expand_globs(files):
        if not is_stdio(f) and Path(f).is_dir():
            table = True
            given += [str(p) for p in scan_files(f)]
        else:
            given.append(f)
    for f in given:
        if is_stdio(f):
            continue
        suffix = usage_suffix(Path(f), SOURCE_SUFFIXES, "file")
        if clip is not None and suffix not in CLIP_SUFFIXES:
            raise click.UsageError("--clip applies to HDF5 databases and archives and to glTF files")
    with stdin_inputs(given) as paths:
        described = []
        for f, path in zip(given, paths):
            d = info_dict(Path(path), clip)
            if is_stdio(f):
                d["file"] = STDIN_NAME
            described.append(d)
            if not (as_json or table):
                if len(described) > 1:
                    click.echo()
                click.echo(_info_text(d, verbose))
    if table and not as_json:
        click.echo(_table(described))
    elif as_json:
        echo_json(described[0] if len(described) == 1 else described)
