"""Stick-figure pictures of a motion and its decoded copy, overlaid: animations (GIF, MP4) and filmstrips (PNG).

The reference is drawn in red and the candidate (the decoded motion) in blue, over each other, as in Fig. 1 of
Tojo et al. 2022: the reference wider and opaque, the candidate on top with a thin white rim, so where they agree
a blue line has a red edge and the two never blend into a third colour.  In every picture the joint or end site
with the largest position error *of that frame* is circled; the clip's *worst joint* -- the largest error at any
frame, the shared L-infinity measure (world positions after forward kinematics) -- is named in the title with its
error in file units and in percent of the character height (:func:`motionrep.model.kinematics.character_height`), and
shown zoomed at its worst frame: in an inset in the corner of an animation, in the last cell of a filmstrip
(which, like the last picture without a candidate, spans the cells the last row leaves over, so no cell is
empty); the title says the units.  Under the pictures, a panel
shows the error over time: each frame's largest joint error, in file units and % of the height, with the bound
when one is given, the worst frame and (in an animation) the current frame.

Pictures use one orthographic camera for the whole rendering, so the same length is drawn the same size across,
up and in depth, in every frame: the figure's proportions are never distorted.  The camera looks across the main
direction of the root's travel (a walk is seen from the side, as in the paper's Fig. 1), 25 degrees towards the
front and 15 degrees from above; a clip that stays in place is seen three-quarter.  A clip that travels further
than 1.5 times the width the figure needs is followed (the floor moves under a figure kept large in the middle);
otherwise the travel across the floor is shown.  Bones join every end site to its joint and every joint to its
parent, except joints moved by position channels over the clip (a root-motion node: :func:`bone_segments`); a
grey shadow of the reference on the floor shows depth and foot contact.  The up axis is detected
(:func:`motionrep.model.ops.detect_up_axis`) unless given.

matplotlib is imported only when a picture is drawn, always on the non-interactive Agg canvas (no window, no
``pyplot`` state).

Time alignment: a candidate with the same frame rate must have the same number of frames.  A candidate at
another frame rate (decoded at other times, ``motionrep decompress --fps``) must span the same time from its
first to its last frame, within one frame time of the coarser clip; it is then resampled at the reference's
frame times , and the error is measured on that resampled motion.

Frame choice: without a step in ``frames``, an animation picks frames by time so that it plays in real time
(at most ``max_frames`` of them: a long clip is shown at a lower rate), the worst frame replacing the frame
picked nearest to it, and a filmstrip shows ``count`` evenly spaced frames, the one nearest the worst frame
replaced by it.  With a step (``"0:300:10"``) exactly those frames are shown.

The package: :mod:`~motionrep.present.render.frames` (which frames, at what rate), :mod:`~motionrep.present.render.scene`
(the up axis, the alignment, the bones, the camera), :mod:`~motionrep.present.render.draw` (matplotlib: the panels,
the zoomed worst joint, the error panel and the animation writer) and :mod:`~motionrep.present.render.strip` (the
filmstrip); :func:`render` puts them together.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...model._pose import Motion
from ...errors import FormatError, ValidationError, naming
from ...pipeline.evaluate import ErrorReport, Evaluator, compare
from ...io import atomic_path
from ...model.kinematics import character_height, global_positions, point_names
from .draw import (CANDIDATE_COLOR, REFERENCE_COLOR, Curve, Progress, describe_error, require_matplotlib,
                   write_animation)
from .frames import (GIF_MAX_FPS, animation_frames, check_size, filmstrip_frames, parse_frames, parse_size,
                     select_frames)
from .scene import Worst, align_candidate, bone_segments, build_scene, detect_up_axis
from .strip import write_filmstrip

__all__ = [
    "render",
    "RenderResult",
    "describe_error",
    "parse_frames",
    "parse_size",
    "detect_up_axis",
    "align_candidate",
    "bone_segments",
    "check_output",
    "require_matplotlib",
    "OUTPUT_SUFFIXES",
    "REFERENCE_COLOR",
    "CANDIDATE_COLOR",
]

#: Output suffixes and what each writes.
OUTPUT_SUFFIXES: dict[str, str] = {".gif": "animation", ".mp4": "animation", ".png": "filmstrip"}


@dataclass(frozen=True)
class RenderResult:
    """What :func:`render` wrote.

    Attributes:
        path: the output file.
        kind: ``"animation"`` (GIF, MP4) or ``"filmstrip"`` (PNG).
        frames: the reference frame shown in each animation frame or filmstrip panel.
        fps: playback rate of an animation (``None`` for a filmstrip).
        size: ``(width, height)`` in pixels.
        up: the up axis used (``"y"`` or ``"z"``).
        error: the shared L-infinity error of the candidate and where it is (``None`` without a candidate).
        notes: things the user should know (resampling, frames dropped to respect ``max_frames``).
    """

    path: Path
    kind: str
    frames: tuple[int, ...]
    fps: float | None
    size: tuple[int, int]
    up: str
    error: ErrorReport | None
    notes: tuple[str, ...] = field(default=())


def check_output(path: str | os.PathLike[str]) -> str:
    """Check that :func:`render` can write ``path`` before any work is done; returns its suffix.

    Raises:
        FormatError: an unknown suffix, or ``.mp4`` when ffmpeg is not installed.
        MotionrepError: matplotlib is not installed.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in OUTPUT_SUFFIXES:
        raise FormatError(f"cannot draw to {suffix or '(no suffix)'!r} files; use one of "
                          + ", ".join(OUTPUT_SUFFIXES), path)
    require_matplotlib()
    if suffix == ".mp4":
        from matplotlib import animation

        if not animation.writers.is_available("ffmpeg"):
            raise FormatError("writing .mp4 needs ffmpeg, which was not found on PATH; write a .gif instead", path)
    return suffix


def render(path: str | os.PathLike[str], reference: Motion, candidate: Motion | None = None, *,
           names: tuple[str, str] = ("reference", "candidate"), frames: slice | str | None = None,
           fps: float | None = None, count: int = 8, max_frames: int = 150,
           size: tuple[int, int] | None = None, up: str = "auto", bound: float | None = None,
           options: Any = None, progress: Progress | None = None) -> RenderResult:
    """Draw ``reference`` (red) and ``candidate`` (blue) overlaid, to a GIF/MP4 animation or a PNG filmstrip.

    With a candidate, a panel under the pictures shows the error over time (each frame's largest joint error,
    in file units and % of the height), ``bound`` as a dashed line, the worst frame as a dot and, in an
    animation, the current frame; the worst frame is always one of the frames shown.

    Args:
        path: output file; ``.gif`` (Pillow), ``.mp4`` (needs ffmpeg) or ``.png`` (a grid of frames).  Written
            atomically: a failure leaves no file.
        reference: the original clip.
        candidate: the decoded clip, with the same skeleton structure (see :func:`align_candidate` for clips at
            another frame rate); ``None`` draws the reference alone.
        names: labels of the two clips (usually file names).
        frames: a slice of reference frames, or its text (``"100:300"``, ``"0:200:25"``).  Without a step, an
            animation picks frames by time to play in real time and a filmstrip shows ``count`` evenly spaced
            frames (the one nearest the worst frame replaced by it); with a step, exactly those frames are shown.
        fps: playback rate of an animation.  Default: the clip's rate capped to 25 fps for GIF (a rate GIF stores
            exactly) or 30 fps for MP4.  GIF plays at most 50 fps.
        count: panels of a filmstrip when ``frames`` has no step.
        max_frames: most frames in an animation or panels in a filmstrip; an animation of a long clip is shown at
            a lower rate (still real time) to stay within it.
        size: ``(width, height)`` of the output in pixels (the whole filmstrip for PNG).  Default: fitted to the
            motion: the figure about 480 pixels high (followed when it travels), 640 to 960 pixels wide, with
            the error panel under it, for an animation; pictures about 300 pixels high (the strip at most 1800
            wide) and the error panel for a filmstrip.
        up: ``"y"`` or ``"z"`` for the data's up axis, or ``"auto"`` (:func:`detect_up_axis`).
        bound: an error bound in file units drawn on the error panel (the ``--max-error`` a file was made with).
        options: a :class:`motionrep.pipeline.pairing.MatchOptions` for a candidate after another tool (joints by name,
            end sites missing, another rate): only the compared points and frames are drawn and measured, and
            the notes say what was left out.  Default: strict.
        progress: called as ``progress(done, total)`` while drawing: after each animation frame or filmstrip
            picture, and once more (``done == total``) when the file is written.

    Returns:
        :class:`RenderResult`.

    Raises:
        FormatError: unknown output suffix; ``.mp4`` without ffmpeg.
        ValidationError: bad frame selection, rate, size or count; skeletons that differ; clips of different
            length.
        MotionrepError: matplotlib is not installed.
    """
    out = Path(path)
    suffix = check_output(out)
    if not isinstance(count, (int, np.integer)) or count < 1:
        raise ValidationError(f"count must be a positive integer, got {count!r}")
    if not isinstance(max_frames, (int, np.integer)) or max_frames < 1:
        raise ValidationError(f"max_frames must be a positive integer, got {max_frames!r}")
    if fps is not None:
        if not (isinstance(fps, (int, float, np.number)) and math.isfinite(fps) and fps > 0):
            raise ValidationError(f"fps must be a positive number, got {fps!r}")
        fps = float(fps)
        if suffix == ".gif" and fps > GIF_MAX_FPS:
            raise naming(ValidationError(f"a GIF cannot play faster than {GIF_MAX_FPS:g} fps, got fps={fps:g}"), "fps=")
    if size is not None:
        size = check_size(size)
        if suffix == ".mp4" and (size[0] % 2 or size[1] % 2):
            raise ValidationError(f"an MP4 needs an even width and height, got {size[0]}x{size[1]}")
    if up not in ("auto", "y", "z"):
        raise ValidationError(f"up must be 'auto', 'y' or 'z', got {up!r}")
    if bound is not None and not (isinstance(bound, (int, float, np.number)) and math.isfinite(bound) and bound >= 0):
        raise ValidationError(f"bound must be a distance >= 0 in file units, got {bound!r}")
    names = (str(names[0]), str(names[1]))

    notes: list[str] = []
    paired = None
    if candidate is not None and options is not None:
        from ...pipeline.pairing import compared_bones, paired_positions

        error = compare(reference, candidate, options)
        ref_sub, cand_sub, points, _ = paired_positions(reference, candidate, options)
        notes.extend(error.comparison.lines())
        if ref_sub.shape[0] < reference.num_frames:
            reference = reference.frames(slice(0, ref_sub.shape[0]))
        paired = (error, ref_sub, cand_sub, compared_bones(reference.skeleton, points.reference), points.names)
    elif candidate is not None:
        candidate, note = align_candidate(reference, candidate, names[0], names[1])
        if note:
            notes.append(note)
    selected, exact = select_frames(frames, reference.num_frames, names[0])

    error = worst = curve = None
    height = character_height(reference.skeleton)
    units = reference.skeleton.units
    bones = None
    if paired is not None:
        error, ref_pos, cand_pos, bones, names_ = paired
        worst = Worst(error, names_.index(error.joint))
        dist = np.linalg.norm(ref_pos - cand_pos, axis=-1)  # (F, P) on the compared points
        curve = Curve(dist.max(axis=1), dist.argmax(axis=1), names_, None if bound is None else float(bound),
                      units, height)
    elif candidate is None:
        ref_pos = global_positions(reference)
        cand_pos = None
    else:
        evaluator = Evaluator(reference)
        ref_pos = evaluator.reference_positions
        cand_pos = global_positions(candidate)
        error = evaluator.positions_error(cand_pos)
        names_ = point_names(reference.skeleton)
        worst = Worst(error, names_.index(error.joint))
        dist = np.linalg.norm(ref_pos - cand_pos, axis=-1)  # (F, P)
        curve = Curve(dist.max(axis=1), dist.argmax(axis=1), names_, None if bound is None else float(bound),
                       units, height)
    if up == "auto":
        up = detect_up_axis(ref_pos[selected])
    scene = build_scene(ref_pos, cand_pos, bone_segments(reference) if bones is None else bones, up, selected, height,
                        reference.fps)

    rate = None
    worst_frame = None if error is None else error.frame
    if suffix == ".png":
        shown = filmstrip_frames(selected, exact, int(count), int(max_frames), worst_frame)
    else:
        shown, rate, more = animation_frames(selected, exact, reference.fps, fps, int(max_frames), suffix,
                                              worst_frame)
        notes.extend(more)
    with atomic_path(out) as tmp:
        if suffix == ".png":
            size = write_filmstrip(tmp, scene, shown, size, names, worst, curve, reference.num_frames,
                                    reference.fps, units, (int(selected[0]), int(selected[-1])), progress)
        else:
            size = write_animation(tmp, suffix, scene, shown, rate, size, names, worst, curve,
                                    reference.num_frames, reference.fps, units, progress)
    return RenderResult(out, OUTPUT_SUFFIXES[suffix], tuple(int(f) for f in shown), rate, size, up, error,
                        tuple(notes))
