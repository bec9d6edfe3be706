"""What a motion file holds, as one JSON-ready dict: what ``motionrep info`` shows and ``--json`` prints.

:func:`info_dict` opens the file once (:func:`motionrep.pipeline.sources.open_source`) and describes it: the skeleton,
frames, frame rate, duration, height and channel layout of a clip; the clips of a database (from attributes
and dataset shapes only); for a compressed clip (a ``.mrc`` file, or one clip of an archive) also the codec,
its outcome, the representation, sizes, the compression figures and the evaluation stored with it; for an
archive, one row per clip.  Keys: ``specs/formats/info-json.md`` (versioned by :data:`INFO_JSON_VERSION`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from ..model._pose import Skeleton
from ..errors import FormatError, MotionrepError, Note, naming
from ..formats import BY_SUFFIX
from ..model.kinematics import character_height
from ..model.timefmt import duration

__all__ = ["INFO_JSON_VERSION", "FORMAT_NAMES", "info_dict", "skeleton_info", "compressed_info", "compressed_facts"]

#: Version of the ``motionrep info --json`` object (``specs/formats/info-json.md``); bumped when a key changes
#: meaning or disappears (adding keys does not bump it).
INFO_JSON_VERSION = 1

#: The ``format`` of each suffix in ``info --json`` (a compressed clip, whatever its suffix, is ``"mrc"``).
FORMAT_NAMES = {s: f.name for s, f in BY_SUFFIX.items()}


def skeleton_info(sk: Skeleton) -> dict[str, Any]:
    """``joints``, ``end_sites``, ``channels``, ``height``, ``units`` and the per-joint ``layout`` of ``sk``."""
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


def info_dict(path: str | os.PathLike[str], clip: str | None = None) -> dict[str, Any]:
    """The object ``motionrep info --json`` prints for ``path`` (keys in ``specs/formats/info-json.md``).

    Args:
        path: any clip-bearing file.
        clip: one clip of a database or archive (otherwise a database or archive of several clips is described
            as a list of clips).

    Raises:
        FormatError: naming the file (and clip) if it cannot be read, or ``clip`` is given for a file of one clip.
    """
    from ..pipeline.sources import open_source

    path = Path(path)
    with open_source(path) as src:
        fmt = "mrc" if src.kind == "compressed" else FORMAT_NAMES.get(path.suffix.lower(), "hdf5")
        base: dict[str, Any] = {"info_version": INFO_JSON_VERSION, "file": str(path), "format": fmt}
        if clip is not None and src.kind in ("motion", "compressed"):
            raise naming(FormatError("clip= applies to HDF5 databases, archives and glTF files; this file holds one "
                                     "clip", path), "clip=")
        names = src.names
        if src.kind == "archive" and clip is None and len(names) != 1:
            return {**base, "kind": "archive",
                    "clips": [_archive_row(name, src.container(name), src.size(name)) for name in names]}
        if src.kind in ("compressed", "archive"):
            name = src.resolve(clip)
            return {**base, **compressed_info(src.container(name), name, src.size(name))}
        if src.kind == "database" and clip is None and len(names) != 1:
            return {**base, "kind": "database", "clips": src.summaries()}
        name, item = src.read_stored(clip)
    from ..io import FeatureClip

    out = {**base, "kind": "features" if isinstance(item, FeatureClip) else "motion", "clip": name,
           "frames": item.num_frames, "fps": item.fps, "duration": item.duration, **skeleton_info(item.skeleton)}
    if isinstance(item, FeatureClip):
        out["representation"] = {"name": item.representation, "version": item.representation_version,
                                 "width": item.width}
    return out


def compressed_info(c: Any, name: str, size: int) -> dict[str, Any]:
    """``info`` of one compressed clip (a ``.mrc`` file or a clip of an archive): container ``c``
    (:class:`motionrep.io.container.Container`) stored as ``name`` in ``size`` bytes."""
    from ..pipeline import figures as fg
    from ..pipeline.compress import describe_outcome
    from ..pipeline.figures import compression_figures
    from ..plugin.registry import get_representation

    sk = c.skeleton
    bone_frames = c.num_frames * fg.bones(sk.num_joints, sk.num_end_sites)
    try:
        width: int | None = get_representation(c.representation).width(sk)
    except MotionrepError:  # the representation's plugin is not installed: no figures that need its width
        width = None
    figures = None
    if width is not None:
        figures = compression_figures(num_frames=c.num_frames, feature_width=width, num_parameters=c.num_parameters,
                                      num_channels=sk.num_channels, num_joints=sk.num_joints,
                                      compressed_bytes=size, num_end_sites=sk.num_end_sites,
                                      payload_bytes=c.payload_bytes).as_dict()
    return {"kind": "compressed", "clip": name, "frames": c.num_frames, "fps": c.fps,
            "duration": duration(c.num_frames, c.fps), **skeleton_info(sk),
            "codec": {"name": c.codec, "version": c.codec_version, "plugin": c.codec_plugin,
                      "params": dict(c.params), "outcome": dict(c.info),
                      "description": describe_outcome(c, detail=True)},
            "representation": {"name": c.representation, "version": c.representation_version,
                               "plugin": c.representation_plugin, "width": width},
            "bytes": size, "parameters": c.num_parameters, "payload_bytes": c.payload_bytes,
            fg.PAYLOAD_BPBF: fg.payload_bits_per_bone_frame(c.payload_bytes, bone_frames),
            fg.FILE_BPBF: fg.file_bits_per_bone_frame(size, bone_frames),
            # the name older readers know (info_version 1): the payload's figure, as above
            "bits_per_bone_frame": fg.payload_bits_per_bone_frame(c.payload_bytes, bone_frames),
            "arrays": [{"name": k, "dtype": a.dtype.str[1:], "shape": list(a.shape)} for k, a in c.arrays.items()],
            "evaluation": None if c.evaluation is None else dict(c.evaluation),
            "figures": figures,
            "motionrep_version": c.extra.get("motionrep_version"), "seed": c.extra.get("seed"),
            "max_error": None if c.bound is None or c.bound.asked is None else str(c.bound.asked),
            "bound": None if c.bound is None else c.bound.as_json(),
            "max_error_read_as": _read_as(c)}


def _read_as(c: Any) -> str | None:
    """How the stored bound reads for this clip (:meth:`motionrep.model.bound.MaxError.read_as`), or None."""
    if c.bound is None or c.bound.asked is None:
        return None
    from ..errors import ParameterError

    try:
        return c.bound.read_as(character_height(c.skeleton), c.skeleton.units)
    except ParameterError:  # a percentage of a character of height 0: no file motionrep writes says that
        return None


def _number(x: float) -> str:
    return f"{x:.6g}"


def compressed_facts(d: dict[str, Any], verbose: bool = False) -> list[tuple[str, Note]]:
    """The facts of one compressed clip, from its :func:`compressed_info`, as ``(label, text)`` lines: codec and
    parameters, outcome, features, sizes, (``verbose``: the payload and the other ratios,) the error stored with
    it and the bound it was made for.  What ``motionrep info`` prints and the viewer shows; a text that names
    the bound's parameter (``max_error=2% ...``) carries the mention (:class:`motionrep.errors.Note`).
    """
    from ..pipeline.figures import FILE_BPBF, PAYLOAD_BPBF, size_line

    c, r = d["codec"], d["representation"]
    params = ", ".join(f"{k}={'auto' if v is None else v}" for k, v in sorted(c["params"].items()))
    facts = [("codec", f"{c['name']} (payload version {c['version']})" + (f", parameters {params}" if params else "")),
             ("outcome", c["description"]),
             ("features", f"{r['name']} version {r['version']}" + (f", width {r['width']}" if r["width"] is not None
                                                                    else "")),
             ("size", size_line(d["bytes"], d[PAYLOAD_BPBF], d[FILE_BPBF], None))]
    f = d["figures"]
    if verbose:
        facts.append(("payload", f"{d['payload_bytes']} bytes, {d['parameters']} stored numbers"))
        if f is not None:
            facts.append(("ratios", f"paper {f['paper_ratio']:.2f}x, vs float32 channels {f['float32_ratio']:.2f}x, "
                                    f"{f['bits_per_joint_frame']:.2f} file bits/joint/frame"))
    e = d["evaluation"]
    if e is not None:
        bound, mentions = ("none" if e.get("bound") is None else _number(e["bound"])), ()
        if e.get("bound") is not None and d.get("max_error_read_as"):
            bound = f"max_error={d['max_error_read_as']}"
            mentions = ("max_error=",)
        facts.append(("L-inf", Note(f"{_number(e['max_error'])} ({e['max_error_percent']:.3g}% of height) at frame "
                                    f"{e['frame']}, {e['joint']}; mean {_number(e['mean_error'])}; bound {bound} "
                                    "(measured on the stored payload when written)", *mentions)))
    return [(label, text if isinstance(text, Note) else Note(text)) for label, text in facts]


def _archive_row(name: str, c: Any, size: int) -> dict[str, Any]:
    from ..pipeline import figures as fg
    from ..pipeline.compress import describe_outcome

    ev = c.evaluation or {}
    bone_frames = c.num_frames * fg.bones(c.skeleton.num_joints, c.skeleton.num_end_sites)
    return {"name": name, "codec": c.codec, "representation": c.representation, "outcome": describe_outcome(c),
            "frames": c.num_frames, "fps": c.fps, "duration": duration(c.num_frames, c.fps),
            "joints": c.skeleton.num_joints, "bytes": size,
            fg.PAYLOAD_BPBF: fg.payload_bits_per_bone_frame(c.payload_bytes, bone_frames),
            fg.FILE_BPBF: fg.file_bits_per_bone_frame(size, bone_frames), "max_error": ev.get("max_error"),
            "max_error_percent": ev.get("max_error_percent")}
