"""An interactive viewer: one self-contained HTML file showing a motion and its decoded copies overlaid in 3D.

The page needs no server and no network: three.js (shipped as package data under its MIT licence, see
``motionrep/data/viewer/README.md``), the viewer's script and every clip are inside the file; a
Content-Security-Policy forbids any request.  Each clip is embedded as the ``.glb`` file motionrep writes
(:func:`motionrep.io.gltf_bytes`) and read by three.js's own ``GLTFLoader``, so the page also shows that three.js
opens motionrep's glTF.  The skeletons are drawn as bones (:func:`motionrep.present.render.bone_segments`: reference red
and wider, decoded copies on top in their own colours, so they stay apart where they overlap), with play/pause, a timeline to scrub, orbit and
zoom, the per-frame error of every candidate under the timeline with the bound drawn and each candidate's worst
frame one click away, and the facts of each clip (codec, parameters, sizes, ratios, the error and how the bound
was read).  Each clip is named by its label and its codec settings (:attr:`ViewClip.name`); an error
magnification slider draws every candidate at ``reference + k * (candidate - reference)`` (``k`` from 1 to
:data:`MAX_MAGNIFICATION`), so an error of 2 % of the height can be seen, and a candidate's joints are coloured
(and grown) by their error at the frame, from the candidate's colour at zero to yellow at the bound (or at the
largest error without one), magenta beyond the bound.  The camera starts on the character as it stands at the
first frame, filling most of the view's height; a character that moves more than its own height is followed.
Durations are :func:`motionrep.model.timefmt.duration` (``frames / fps``) and rates as the file states them.

The errors are the shared measure (:class:`motionrep.pipeline.evaluate.Evaluator`), computed here in float64; the page
only draws them.  A candidate at another frame rate is resampled at the reference's frame times first
(:func:`motionrep.present.render.align_candidate`).
"""

from __future__ import annotations

import base64
import html
import json
import math
import os
import re
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from numpy.typing import NDArray

from .._version import __version__
from ..model._pose import Motion
from ..errors import ValidationError
from ..pipeline.evaluate import ErrorReport, Evaluator, compare
from ..io import atomic_path

__all__ = ["ViewClip", "ViewResult", "view_html", "write_view", "distinct_names", "REFERENCE_COLOR",
           "CANDIDATE_COLORS", "MAX_MAGNIFICATION"]

REFERENCE_COLOR = "#d62728"  # red, as in the pictures of motionrep render
#: Colours of the candidates, in order (blue first, as in motionrep render).
CANDIDATE_COLORS = ("#1f5fd6", "#1a9e3f", "#e08a00", "#8e44ad", "#17a5b8", "#7f4f24")
#: Most candidates one page shows.
MAX_CANDIDATES = len(CANDIDATE_COLORS)
#: Largest error magnification of the page's slider (a candidate drawn at reference + k x its offset).
MAX_MAGNIFICATION = 100


def distinct_names(paths: Sequence[str]) -> list[str]:
    """The shortest tail of each path (``walk.mrc``, then ``svd/walk.mrc``...) that tells it from the others.

    >>> distinct_names(["a/svd/walk.mrc", "a/fourier/walk.mrc", "walk.bvh"])
    ['svd/walk.mrc', 'fourier/walk.mrc', 'walk.bvh']
    """
    parts = [tuple(q.rstrip("/\\") if i == 0 and q == Path(p).anchor else q for i, q in enumerate(Path(p).parts))
             or (str(p),) for p in paths]  # an anchor "/" joins as "" + "/": "/x/walk.mrc", not "//x/walk.mrc"
    depth = [1] * len(parts)
    while True:
        names = ["/".join(q[-d:]) for q, d in zip(parts, depth)]
        clash = [i for i, n in enumerate(names) if names.count(n) > 1 and depth[i] < len(parts[i])]
        if not clash:
            return names
        for i in clash:
            depth[i] += 1


@dataclass(frozen=True)
class ViewClip:
    """A clip to show.

    Attributes:
        motion: the motion.
        label: its name on the page (usually the file name).
        facts: ``(name, value)`` lines shown with it (codec, parameters, sizes...).
        settings: the codec and its settings in a few words (``"svd rank=4, within 2%"``), shown after the label
            in the legend, the HUD and the facts, so that candidates from different codecs are told apart.
    """

    motion: Motion
    label: str
    facts: tuple[tuple[str, str], ...] = ()
    settings: str = ""

    @property
    def name(self) -> str:
        """The label with the settings: ``"svd/walk.mrc (svd rank=4, within 2%)"``."""
        return f"{self.label} ({self.settings})" if self.settings else self.label


@dataclass(frozen=True)
class ViewResult:
    """What :func:`write_view` wrote.

    Attributes:
        path: the HTML file.
        bytes: its size.
        frames: frames of the reference (every candidate is shown at these).
        errors: the shared error of each candidate.
        worst_frame: the frame with the largest error of the first candidate (``None`` without candidates).
        notes: things the user should know (resampling).
        worst_frames: the frame with the largest error of each candidate (the page's "Worst frame" buttons).
    """

    path: Path | None
    bytes: int
    frames: int
    errors: tuple[ErrorReport, ...]
    worst_frame: int | None
    notes: tuple[str, ...] = field(default=())
    worst_frames: tuple[int, ...] = field(default=())


def _asset(name: str) -> str:
    return (resources.files("motionrep") / "data" / "viewer" / name).read_text(encoding="utf-8")


def _script(text: str) -> str:
    """Script text safe inside a ``<script>`` element: no ``</script`` or ``<!--`` can end or change it.

    ``<\\/`` means ``</`` in JavaScript strings and regular expressions; the shipped scripts hold no ``<!--``.
    """
    if "<!--" in text:
        raise ValidationError("a script to embed contains '<!--'")
    return text.replace("</", "<\\/")


def _json_script(value: Any) -> str:
    """JSON safe inside a ``<script>`` element: every ``<`` (only ever inside strings) escaped as ``\\u003c``."""
    return json.dumps(value, separators=(",", ":"), allow_nan=False).replace("<", "\\u003c")


def _as_clip(item: ViewClip | Motion, label: str) -> ViewClip:
    if isinstance(item, ViewClip):
        return item
    if isinstance(item, Motion):
        return ViewClip(item, label)
    raise ValidationError(f"a clip to view must be a Motion or a ViewClip, got {type(item).__name__}")


def _text(value: Any) -> str:
    """A fact's value as shown: never Python's ``None`` or ``nan``."""
    if value is None:
        return "-"
    if isinstance(value, float) and not math.isfinite(value):
        return "-"
    return str(value)


def _rounded(values: np.ndarray, digits: int = 6) -> list[float]:
    return [float(f"{v:.{digits}g}") for v in np.asarray(values, dtype=np.float64).tolist()]


def view_html(reference: ViewClip | Motion, candidates: Sequence[ViewClip | Motion] = (), *,
              bound: float | None = None, bound_text: str | None = None, title: str | None = None,
              up: str = "auto", match: Any = None) -> tuple[str, ViewResult]:
    """The viewer page for ``reference`` and ``candidates``, as text, and what it shows.

    Args:
        reference: the original clip.
        candidates: decoded copies (at most :data:`MAX_CANDIDATES`), each with the reference's skeleton structure;
            one at another frame rate is resampled at the reference's frame times.
        bound: an error bound in file units, drawn on the error curve (for example the ``--max-error`` a file
            was compressed with).
        bound_text: how the bound was given and read (``"2% of height = 3.04 cm"``); default: the bound in units.
        title: the page's title; default: the clips' labels.
        up: ``"y"``, ``"z"`` or ``"auto"``: the reference's up axis (:func:`motionrep.model.ops.detect_up_axis`).
        match: a :class:`motionrep.pipeline.pairing.MatchOptions` for candidates after another tool (joints by name, end
            sites missing, another rate or length): each candidate is drawn with its own skeleton at the
            reference's frame times (held on its last frame after its end), its error is measured on the points
            and frames paired, and the notes say what was left out.  Default: strict.

    Raises:
        ValidationError: skeletons that differ, clips of different length, too many candidates, a bad bound.
    """
    from ..io import gltf_bytes
    from ..model.kinematics import global_positions, point_names
    from ..model.ops import detect_up_axis
    from .render import align_candidate, bone_segments
    from ..model.timefmt import duration, duration_text, rate_text

    ref = _as_clip(reference, "reference")
    cands = [_as_clip(c, f"candidate {i + 1}") for i, c in enumerate(candidates)]
    if len(cands) > MAX_CANDIDATES:
        raise ValidationError(f"the viewer shows at most {MAX_CANDIDATES} candidates at once, got {len(cands)}")
    if bound is not None and not (isinstance(bound, (int, float)) and math.isfinite(bound) and bound >= 0):
        raise ValidationError(f"bound must be a distance >= 0 in file units, got {bound!r}")
    if up not in ("auto", "y", "z"):
        raise ValidationError(f"up must be 'auto', 'y' or 'z', got {up!r}")

    evaluator = Evaluator(ref.motion)
    ref_pos = evaluator.reference_positions
    if up == "auto":
        step = max(1, ref.motion.num_frames // 500)
        up = detect_up_axis(ref_pos[::step])
    names = point_names(ref.motion.skeleton)
    units = ref.motion.skeleton.units
    notes: list[str] = []
    reports: list[ErrorReport] = []
    clips: list[dict[str, Any]] = []

    def clip_entry(clip: ViewClip, motion: Motion, role: str, color: str) -> dict[str, Any]:
        glb = gltf_bytes(motion, clip=clip.label, scale=1.0, up=up)
        return {"label": clip.label, "settings": clip.settings, "name": clip.name, "role": role, "color": color,
                "fps": motion.fps, "rateText": rate_text(motion.fps),
                "durationText": duration_text(motion.num_frames, motion.fps),
                "segments": bone_segments(motion).tolist(),
                "frames": motion.num_frames, "joints": motion.num_joints,
                "endSites": motion.skeleton.num_end_sites,
                "facts": [[_text(k), _text(v)] for k, v in clip.facts],
                "glb": base64.b64encode(glb).decode("ascii")}

    clips.append(clip_entry(ref, ref.motion, "reference", REFERENCE_COLOR))
    for i, cand in enumerate(cands):
        if match is not None:
            aligned, report, dist = _paired(evaluator, cand, match)
            note = report.comparison.method
            notes.extend(f"{cand.label}: {line}" for line in report.comparison.lines())
        else:
            aligned, note = align_candidate(ref.motion, cand.motion, ref.name, cand.name)
            if note:
                notes.append(note)
            pos = global_positions(aligned)
            report = evaluator.positions_error(pos)
            dist = np.sqrt(np.sum((pos - ref_pos) ** 2, axis=-1))  # (F, P)
        reports.append(report)
        entry = clip_entry(cand, aligned, "candidate", CANDIDATE_COLORS[i])
        entry.update({
            "error": {"max": report.max_error, "maxPercent": report.max_error_percent, "mean": report.mean_error,
                      "meanPercent": report.mean_error_percent, "frame": report.frame, "joint": report.joint},
            "perFrame": _rounded(dist.max(axis=1)),
            "perFrameJoint": dist.argmax(axis=1).astype(int).tolist(),
            "resampled": note,
        })
        clips.append(entry)

    height = evaluator.height
    data = {
        "version": __version__,
        "title": title or " vs ".join(c.label for c in [ref, *cands]),
        "duration": duration(ref.motion.num_frames, ref.motion.fps),
        "durationText": duration_text(ref.motion.num_frames, ref.motion.fps),
        "maxMagnification": MAX_MAGNIFICATION,
        "units": units,
        "height": height,
        "fps": ref.motion.fps,
        "frames": ref.motion.num_frames,
        "pointNames": list(names),
        "up": up,
        "bound": None if bound is None else float(bound),
        "boundText": bound_text if bound_text is not None or bound is None else
        f"{bound:.4g}{' ' + units if units else ' file units'}"
        + (f" = {100 * bound / height:.3g}% of height" if height > 0 else ""),
        "clips": clips,
        "notes": notes,
    }
    page = _asset("viewer.html")
    replacements = {
        "<!--MOTIONREP-TITLE-->": html.escape(str(data["title"])),
        "/*MOTIONREP-CSS*/": _asset("viewer.css"),
        "/*MOTIONREP-THREE*/": _script(_asset("three.min.js")),
        "/*MOTIONREP-APP*/": _script(_asset("viewer.js")),
        "/*MOTIONREP-DATA*/": _json_script(data),
    }
    # one pass, so nothing inserted (a label, a script) is itself searched for a placeholder
    page = re.sub("|".join(re.escape(k) for k in replacements), lambda m: replacements[m.group(0)], page)
    worst = reports[0].frame if reports else None
    return page, ViewResult(None, len(page.encode("utf-8")), ref.motion.num_frames, tuple(reports), worst,
                            tuple(notes), tuple(r.frame for r in reports))


def _paired(evaluator: Evaluator, cand: ViewClip, match: Any) -> tuple[Motion, ErrorReport, NDArray]:
    """A candidate after another tool: at the reference's frame times, its report on the paired points and frames,
    and ``(F, J + E)`` distances of the reference's points (0 where a point is not paired)."""
    from ..model.kinematics import global_positions
    from ..model.ops import interpolate_frames
    from ..pipeline.pairing import pair_points

    ref = evaluator.reference
    report = compare(ref, cand.motion, match, evaluator=evaluator)
    points = pair_points(ref.skeleton, cand.motion.skeleton, match)
    at = np.minimum(np.arange(ref.num_frames) / ref.fps * cand.motion.fps, cand.motion.num_frames - 1)
    aligned = interpolate_frames(cand.motion, at, ref.fps)
    pos = global_positions(aligned)[:, list(points.candidate)]
    dist = np.zeros((ref.num_frames, len(evaluator.names)))
    dist[:, list(points.reference)] = np.sqrt(np.sum((pos - evaluator.reference_positions[:, list(points.reference)])
                                                     ** 2, axis=-1))
    return aligned, report, dist


def write_view(path: str | os.PathLike[str], reference: ViewClip | Motion,
               candidates: Sequence[ViewClip | Motion] = (), **options: Any) -> ViewResult:
    """Write the viewer page (:func:`view_html`) to ``path``, atomically.

    Returns:
        :class:`ViewResult` with the path and the file's size.
    """
    page, result = view_html(reference, candidates, **options)
    data = page.encode("utf-8")
    with atomic_path(path) as tmp:
        Path(tmp).write_bytes(data)
    return ViewResult(Path(path), len(data), result.frames, result.errors, result.worst_frame, result.notes,
                      result.worst_frames)
