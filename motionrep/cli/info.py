"""``motionrep info``: what a motion file holds, as text or as the JSON of :func:`motionrep.info.info_dict`.

Exit codes: 0 on success; 1 when the file cannot be read (one line naming it); 2 for a usage error (unknown
suffix, ``--clip`` on a file of one clip).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click

from ._common import STDIN_NAME, body_model_option, echo_json, expand_globs, is_stdio, stdin_inputs, usage_suffix

__all__ = ["info"]


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
        lines.append(f"codec:      {c['name']} (payload version {c['version']})"
                     + (f", parameters {json.dumps(c['params'])}" if c["params"] else ""))
        lines.append(f"outcome:    {c['description']}")
        lines.append(f"features:   {r['name']} version {r['version']}"
                     + (f", width {r['width']}" if r["width"] is not None else ""))
        lines.append(f"size:       {d['bytes']} bytes, {d['parameters']} stored numbers; payload {d['payload_bytes']} "
                     f"bytes, {d['bits_per_bone_frame']:.3f} bits/bone/frame (joints + end sites)")
        f = d["figures"]
        if f is not None:
            lines.append(f"ratios:     paper {f['paper_ratio']:.2f}x, vs float32 channels {f['float32_ratio']:.2f}x, "
                         f"{f['bits_per_joint_frame']:.2f} bits/joint/frame")
        e = d["evaluation"]
        if e is not None:
            bound = "none" if e.get("bound") is None else _fmt(e["bound"])
            if e.get("bound") is not None and d.get("max_error"):
                from ..bound import parse_max_error

                bound = f"--max-error {parse_max_error(d['max_error']).read_as(d['height'], d['units'])}"
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


@click.command("info")
@click.argument("files", metavar="FILE...", nargs=-1, required=True)
@click.option("--clip", metavar="NAME",
              help="The clip to describe in an HDF5 database or archive, or a glTF file's animation.")
@click.option("--json", "as_json", is_flag=True,
              help="Print one JSON object (a list of them for several files; keys: specs/formats/info-json.md).")
@body_model_option
def info(files: tuple[str, ...], clip: str | None, as_json: bool) -> None:
    """Describe motion files: skeleton, frames, fps, duration, height, channel layout.

    \b
    FILE may be several files, quoted glob patterns ('clips/*.bvh'), or '-'
    (BVH, NPZ, HDF5, .glb or .mrc from standard input, told by its first
    bytes: cat db.h5 | motionrep info -); each is described in turn.

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
    from ..info import info_dict
    from ..sources import CLIP_SUFFIXES, SOURCE_SUFFIXES

    given = expand_globs(files)
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
            if not as_json:
                if len(described) > 1:
                    click.echo()
                click.echo(_info_text(d))
    if as_json:
        echo_json(described[0] if len(described) == 1 else described)
