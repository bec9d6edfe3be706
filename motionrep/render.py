"""Stick-figure pictures of a motion and its decoded copy, overlaid: animations (GIF, MP4) and filmstrips (PNG).

The reference is drawn in red and the candidate (the decoded motion) in blue, over each other, as in Fig. 1 of
Tojo et al. 2022.  The *worst joint* -- the joint or end site with the largest position error at any frame, the
shared L-infinity measure (world positions after forward kinematics) -- is circled on every frame and named in
the title with its error in file units and in percent of the character height
(:func:`motionrep.kinematics.character_height`).

Pictures use one fixed orthographic camera for the whole rendering, so the same length is drawn the same size
across, up and in depth, in every frame: the figure's proportions are never distorted and its travel across
the floor is visible.  The camera looks across the main direction of the root's travel (a walk is seen from the
side, as in the paper's Fig. 1), 25 degrees towards the front and 15 degrees from above; a clip that stays in
place is seen three-quarter.  Bones join every joint to its parent and every end site to its joint; a grey
shadow of the reference on the floor shows depth and foot contact.  The up axis is detected
(:func:`detect_up_axis`) unless given.

matplotlib is an optional dependency (``pip install 'motionrep[plot]'``); it is imported only when a picture is
drawn, always on the non-interactive Agg canvas (no window, no ``pyplot`` state).

Time alignment: a candidate with the same frame rate must have the same number of frames.  A candidate at
another frame rate (decoded at other times, ``motionrep decompress --fps``) must span the same time from its
first to its last frame, within one frame time of the coarser clip; it is then resampled at the reference's
frame times (:func:`motionrep.ops.resample`), and the error is measured on that resampled motion.

Frame choice: without a step in ``frames``, an animation picks frames by time so that it plays in real time
(at most ``max_frames`` of them: a long clip is shown at a lower rate), and a filmstrip shows ``count`` evenly
spaced frames, the one nearest the worst frame replaced by it.  With a step (``"0:300:10"``) exactly those
frames are shown.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from numpy.typing import NDArray

from ._model import Motion
from .errors import FormatError, MotionrepError, ValidationError
from .io import atomic_path
from .evaluate import ErrorReport, Evaluator
from .kinematics import character_height, global_positions, point_names
from .ops import resample

__all__ = [
    "render",
    "RenderResult",
    "describe_error",
    "parse_frames",
    "parse_size",
    "detect_up_axis",
    "align_candidate",
    "check_output",
    "OUTPUT_SUFFIXES",
    "REFERENCE_COLOR",
    "CANDIDATE_COLOR",
]

#: Output suffixes and what each writes.
OUTPUT_SUFFIXES: dict[str, str] = {".gif": "animation", ".mp4": "animation", ".png": "filmstrip"}

REFERENCE_COLOR = "#d62728"  # red
CANDIDATE_COLOR = "#1f5fd6"  # blue
_MARK_COLOR = "#111111"

#: Default playback-rate cap: GIF delays are whole centiseconds and browsers slow down anything under 2 cs,
#: so 25 fps (4 cs) is exact and plays everywhere.
_GIF_DEFAULT_FPS = 25.0
_GIF_MAX_FPS = 50.0
_MP4_DEFAULT_FPS = 30.0
_MIN_SIDE, _MAX_SIDE = 64, 8192
_DPI = 100


# ---- small pure helpers (no matplotlib) ------------------------------------------------------------------------

def describe_error(report: ErrorReport) -> str:
    """The worst joint of a report in a few words: ``"LeftHand 3.21 cm = 1.9% of height, frame 123"``."""
    unit = f" {report.units}" if report.units else " units"
    pct = "" if not math.isfinite(report.max_error_percent) else f" = {report.max_error_percent:.3g}% of height"
    return f"{report.joint} {report.max_error:.3g}{unit}{pct}, frame {report.frame}"


_FRAMES_RE = re.compile(r"^\s*(-?\d+)?\s*:\s*(-?\d+)?\s*(?::\s*(-?\d+)?\s*)?$")


def parse_frames(text: str) -> slice:
    """Parse a frame selection with Python slice semantics: ``"a:b"``, ``"a:b:step"``, ``":100"``, ``"-50:"``,
    or a single frame ``"57"`` (negative numbers count from the end).

    Raises:
        ValidationError: for anything else, a zero or negative step included.
    """
    s = str(text).strip()
    if re.fullmatch(r"-?\d+", s):
        i = int(s)
        return slice(i, i + 1 if i != -1 else None)
    m = _FRAMES_RE.match(s)
    if not m:
        raise ValidationError(f"invalid frame selection {text!r}: use a:b or a:b:step (Python slice, "
                              "e.g. 0:120, 100:, -60:, 0:300:10) or one frame number")
    start, stop, step = (None if g is None else int(g) for g in m.groups())
    if step is not None and step <= 0:
        raise ValidationError(f"invalid frame selection {text!r}: the step must be a positive integer")
    return slice(start, stop, step)


def parse_size(text: str) -> tuple[int, int]:
    """Parse ``"WIDTHxHEIGHT"`` in pixels (each 64..8192).

    Raises:
        ValidationError: for anything else.
    """
    m = re.fullmatch(r"\s*(\d+)\s*[xX×]\s*(\d+)\s*", str(text))
    if not m:
        raise ValidationError(f"invalid size {text!r}: use WIDTHxHEIGHT in pixels, e.g. 640x480")
    w, h = int(m.group(1)), int(m.group(2))
    _check_size((w, h))
    return w, h


def _check_size(size: Sequence[int]) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in size)
    except (TypeError, ValueError):
        raise ValidationError(f"size must be (width, height) in pixels, got {size!r}") from None
    if not (_MIN_SIDE <= w <= _MAX_SIDE and _MIN_SIDE <= h <= _MAX_SIDE):
        raise ValidationError(f"size {w}x{h} is out of range: width and height must be {_MIN_SIDE}..{_MAX_SIDE} "
                              "pixels")
    return w, h


def _select(frames: slice | str | None, num_frames: int, name: str) -> tuple[NDArray[np.int64], bool]:
    """Frame indices chosen by ``frames`` and whether they are exact (an explicit step was given)."""
    if frames is None:
        sl = slice(None)
    elif isinstance(frames, str):
        sl = parse_frames(frames)
    elif isinstance(frames, slice):
        sl = frames
        if sl.step is not None and sl.step <= 0:
            raise ValidationError(f"invalid frame selection: the step must be a positive integer, got {sl.step}")
    else:
        raise ValidationError(f"frames must be a slice or a string like '0:120', got {type(frames).__name__}")
    idx = np.arange(num_frames)[sl]
    if idx.size == 0:
        shown = _slice_text(sl)
        raise ValidationError(f"frame selection {shown!r} selects no frames of the {num_frames} in {name} "
                              f"(valid frames 0..{num_frames - 1})")
    return idx.astype(np.int64), sl.step is not None


def _slice_text(sl: slice) -> str:
    parts = ["" if sl.start is None else str(sl.start), "" if sl.stop is None else str(sl.stop)]
    if sl.step is not None:
        parts.append(str(sl.step))
    return ":".join(parts)


def detect_up_axis(positions: NDArray[np.float64]) -> str:
    """Guess whether a clip is Y-up or Z-up from its ``(F, P, 3)`` world positions.

    Only Y and Z compete (X-up files are rare).  First the floor: feet rest on the ground, so along the up axis
    the lowest point of each frame stays nearly level, while along a horizontal axis it follows the steps and
    the travel.  The axis whose lowest point varies clearly less over the frames wins.  When that does not
    decide (a single frame, a motion without ground contact), the body: a person is taller than deep most of
    the time, so Z wins only if the median per-frame extent along Z is 1.3 times that along Y; otherwise Y
    (BVH's usual convention).
    """
    pos = np.asarray(positions, dtype=np.float64)
    extent = np.median(pos.max(axis=1) - pos.min(axis=1), axis=0)
    size = float(extent.max())
    if pos.shape[0] > 1 and size > 0:
        floor_spread = pos.min(axis=1).std(axis=0) / size
        y, z = float(floor_spread[1]), float(floor_spread[2])
        if abs(y - z) > 0.02 and min(y, z) < 0.5 * max(y, z):
            return "y" if y < z else "z"
    return "z" if extent[2] > 1.3 * extent[1] else "y"


def _to_plot(positions: NDArray[np.float64], up: str) -> NDArray[np.float64]:
    """Data coordinates to matplotlib's (x, y, z-up), by a proper rotation (handedness kept)."""
    if up == "z":
        return positions
    if up == "y":  # rotate +90 degrees about X: (x, y, z) -> (x, -z, y)
        return np.stack([positions[..., 0], -positions[..., 2], positions[..., 1]], axis=-1)
    raise ValidationError(f"up axis must be 'y', 'z' or 'auto', got {up!r}")


def align_candidate(reference: Motion, candidate: Motion, ref_name: str = "REF",
                    cand_name: str = "CAND") -> tuple[Motion, str | None]:
    """Check that ``candidate`` can be compared with ``reference`` and put it on the reference's frames.

    Same skeleton structure is required (joint names, parents, end sites; offsets may differ).  Same frame rate:
    the frame counts must match.  Another frame rate: the times of the last frames must agree within one frame
    time of the coarser clip, and the candidate is resampled at the reference's frame times.

    Returns:
        The aligned candidate and a note describing any resampling (``None`` if none was needed).

    Raises:
        ValidationError: naming both files and what differs.
    """
    rs, cs = reference.skeleton, candidate.skeleton
    if not rs.same_structure(cs):
        if rs.num_joints != cs.num_joints:
            what = f"{rs.num_joints} joints in {ref_name} but {cs.num_joints} in {cand_name}"
        elif rs.names != cs.names:
            j = next(i for i, (a, b) in enumerate(zip(rs.names, cs.names)) if a != b)
            what = f"joint {j} is {rs.names[j]!r} in {ref_name} but {cs.names[j]!r} in {cand_name}"
        elif not np.array_equal(rs.parents, cs.parents):
            j = int(np.nonzero(rs.parents != cs.parents)[0][0])
            what = (f"joint {rs.names[j]!r} has parent {rs.names[rs.parents[j]]!r} in {ref_name} but "
                    f"{cs.names[cs.parents[j]]!r} in {cand_name}")
        else:
            what = f"the end sites differ ({rs.num_end_sites} in {ref_name}, {cs.num_end_sites} in {cand_name})"
        raise ValidationError(f"{ref_name} and {cand_name} do not share a skeleton: {what}")
    if math.isclose(reference.fps, candidate.fps, rel_tol=1e-6):
        if reference.num_frames != candidate.num_frames:
            raise ValidationError(
                f"{ref_name} has {reference.num_frames} frames but {cand_name} has {candidate.num_frames} "
                f"(both at {reference.fps:g} fps): compare clips of the same length")
        return candidate, None
    tolerance = 1.0 / min(reference.fps, candidate.fps) + 1e-9
    ref_end = (reference.num_frames - 1) / reference.fps
    cand_end = (candidate.num_frames - 1) / candidate.fps
    if abs(ref_end - cand_end) > tolerance:
        raise ValidationError(
            f"{ref_name} spans {ref_end:.4g} s ({reference.num_frames} frames at {reference.fps:g} fps) but "
            f"{cand_name} spans {cand_end:.4g} s ({candidate.num_frames} frames at {candidate.fps:g} fps): "
            "they must cover the same time")
    note = (f"{cand_name} ({candidate.num_frames} frames at {candidate.fps:g} fps) resampled at {ref_name}'s "
            f"{reference.num_frames} frame times ({reference.fps:g} fps)")
    return resample(candidate, reference.fps, reference.num_frames), note


# ---- frame choice ------------------------------------------------------------------------------------------------

def _pick_by_time(selected: NDArray[np.int64], clip_fps: float, rate: float) -> NDArray[np.int64]:
    """The selected frames nearest to the times ``k / rate`` (``rate`` below the clip's rate)."""
    n = int(math.floor((selected.size - 1) * rate / clip_fps + 1e-9)) + 1
    pick = np.rint(np.arange(n) * (clip_fps / rate)).astype(np.int64)
    return selected[np.minimum(pick, selected.size - 1)]


def _animation_frames(selected: NDArray[np.int64], exact: bool, clip_fps: float, fps: float | None,
                      max_frames: int, kind: str) -> tuple[NDArray[np.int64], float, list[str]]:
    """Frames to show and the playback rate.

    Exact selections (an explicit step) are shown frame by frame at ``fps``.  Otherwise frames are picked by
    time so the animation plays in real time at ``fps``; the rate drops if that would exceed ``max_frames``.
    """
    notes: list[str] = []
    cap = _GIF_DEFAULT_FPS if kind == ".gif" else _MP4_DEFAULT_FPS
    if exact:
        if selected.size > max_frames:
            raise ValidationError(f"the frame selection has {selected.size} frames, more than --max-frames "
                                  f"{max_frames}: use a larger step or raise --max-frames")
        step = int(selected[1] - selected[0]) if selected.size > 1 else 1
        rate = fps if fps is not None else _representable(min(clip_fps / step, cap), kind)
        return selected, rate, notes
    rate = fps if fps is not None else _representable(min(clip_fps, cap), kind)
    if rate >= clip_fps:
        shown = selected
        if rate > clip_fps * (1 + 1e-9):
            notes.append(f"every frame shown at {rate:g} fps: {rate / clip_fps:.3g}x faster than real time")
    else:
        shown = _pick_by_time(selected, clip_fps, rate)
    if shown.size > max_frames:
        rate = _representable(max_frames / (selected.size / clip_fps), kind)
        shown = _pick_by_time(selected, clip_fps, rate)
        notes.append(f"showing {shown.size} of {selected.size} frames at {rate:.3g} fps, in real time "
                     f"(--max-frames {max_frames})")
    return shown, rate, notes


def _representable(rate: float, kind: str) -> float:
    """The largest playback rate <= ``rate`` that the format stores exactly (GIF: 100 / whole centiseconds)."""
    if kind != ".gif":
        return rate
    return 100.0 / math.ceil(100.0 / rate - 1e-9)


def _filmstrip_frames(selected: NDArray[np.int64], exact: bool, count: int, max_frames: int,
                      worst_frame: int | None) -> NDArray[np.int64]:
    if exact:
        if selected.size > max_frames:
            raise ValidationError(f"the frame selection has {selected.size} frames, more than --max-frames "
                                  f"{max_frames}: use a larger step or raise --max-frames")
        return selected
    n = min(count, selected.size)
    pick = selected[np.rint(np.linspace(0, selected.size - 1, n)).astype(np.int64)]
    if worst_frame is not None and selected[0] <= worst_frame <= selected[-1] and worst_frame not in pick:
        # the nearest panel shows the worst frame instead, so the strip always contains it
        pick[int(np.argmin(np.abs(pick - worst_frame)))] = worst_frame
    return np.unique(pick)


# ---- drawing -----------------------------------------------------------------------------------------------------

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


@dataclass(frozen=True)
class _Worst:
    """The error report and the index of its worst point among the ``J + E`` FK points."""

    report: ErrorReport
    point: int

    @property
    def name(self) -> str:
        return self.report.joint

    @property
    def frame(self) -> int:
        return self.report.frame

    @property
    def units(self) -> str | None:
        return self.report.units


def _matplotlib() -> Any:
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise MotionrepError("drawing pictures needs matplotlib, which is not installed: "
                             "pip install 'motionrep[plot]'") from None
    return Figure, FigureCanvasAgg


def _bones(skeleton) -> NDArray[np.int64]:
    """``(B, 2)`` point-index pairs (parent, child): every joint to its parent, every end site to its joint."""
    J = skeleton.num_joints
    pairs = [(int(skeleton.parents[j]), j) for j in range(1, J)]
    pairs += [(int(p), J + e) for e, p in enumerate(skeleton.end_site_parents)]
    return np.array(pairs, dtype=np.int64).reshape(-1, 2)


def _nice_step(length: float) -> float:
    """A round grid spacing (1, 2 or 5 times a power of ten) close to ``length``."""
    if not length > 0:
        return 1.0
    power = 10.0 ** math.floor(math.log10(length))
    return min((1.0, 2.0, 5.0, 10.0), key=lambda m: abs(math.log(m * power / length))) * power


@dataclass
class _Scene:
    """Everything the panels share: screen positions from one fixed camera, the floor, the limits.

    The camera is orthographic, so one screen unit is one file unit everywhere (equal scaling on every axis).
    """

    ref: NDArray[np.float64]  # (F, P, 2) screen positions
    cand: NDArray[np.float64] | None
    ref_shadow: NDArray[np.float64]  # (F, P, 2) the points dropped onto the floor
    bones: NDArray[np.int64]
    floor: NDArray[np.float64]  # (G, 2, 2) grid segments on the floor
    xlim: tuple[float, float]
    ylim: tuple[float, float]

    @property
    def aspect(self) -> float:
        return (self.xlim[1] - self.xlim[0]) / (self.ylim[1] - self.ylim[0])


def _scene(ref_pos: NDArray, cand_pos: NDArray | None, bones: NDArray, up: str, span: NDArray[np.int64],
           height: float) -> _Scene:
    """Fix the camera for frames ``span[0]..span[-1]`` and project both clips.

    The camera looks across the main direction of the root's travel (a walk is seen from the side, as in the
    paper's Fig. 1), turned 25 degrees towards the front and 15 degrees from above; a clip that stays in place
    is seen three-quarter.  The floor is a grid at the lowest point of the clip.
    """
    ref = _to_plot(ref_pos, up)
    cand = None if cand_pos is None else _to_plot(cand_pos, up)
    window = ref[span[0]:span[-1] + 1]
    pts = window.reshape(-1, 3)
    if cand is not None:
        pts = np.concatenate([pts, cand[span[0]:span[-1] + 1].reshape(-1, 3)])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    height = max(height, float(np.max(hi - lo)) * 0.25, 1e-9)
    ground = float(lo[2])

    root = window[:, 0, :2]
    if root.shape[0] > 1 and float(np.ptp(root, axis=0).max()) > 0.25 * height:
        _, _, vt = np.linalg.svd(root - root.mean(axis=0), full_matrices=False)
        along = math.atan2(vt[0, 1], vt[0, 0])
        azim = along - math.pi / 2 + math.radians(25.0)
    else:
        azim = math.radians(-60.0)
    elev = math.radians(15.0)
    right = np.array([-math.sin(azim), math.cos(azim), 0.0])
    upv = np.array([-math.sin(elev) * math.cos(azim), -math.sin(elev) * math.sin(azim), math.cos(elev)])
    screen = np.stack([right, upv], axis=1)  # (3, 2)

    def project(p: NDArray) -> NDArray:
        return p @ screen

    def drop(p: NDArray) -> NDArray:
        q = p.copy()
        q[..., 2] = ground
        return q

    # floor: a rectangle around the travelled area, ruled at a round spacing
    margin = 0.2 * height
    fx0, fx1 = lo[0] - margin, hi[0] + margin
    fy0, fy1 = lo[1] - margin, hi[1] + margin
    step = _nice_step(max(height / 3.0, max(fx1 - fx0, fy1 - fy0) / 40.0))  # at most about 40 lines a side
    gx = np.concatenate([[fx0], np.arange(math.ceil(fx0 / step), math.floor(fx1 / step) + 1) * step, [fx1]])
    gy = np.concatenate([[fy0], np.arange(math.ceil(fy0 / step), math.floor(fy1 / step) + 1) * step, [fy1]])
    segs = [[(x, fy0, ground), (x, fy1, ground)] for x in gx]
    segs += [[(fx0, y, ground), (fx1, y, ground)] for y in gy]
    floor = project(np.array(segs, dtype=np.float64))

    ref2 = project(ref)
    cand2 = None if cand is None else project(cand)
    shown = [ref2[span[0]:span[-1] + 1].reshape(-1, 2), floor.reshape(-1, 2)]
    if cand2 is not None:
        shown.append(cand2[span[0]:span[-1] + 1].reshape(-1, 2))
    # limits: the figures and the floor, with a small margin
    body = np.concatenate(shown[:1] + shown[2:])
    flo = shown[1]
    x0 = min(body[:, 0].min(), flo[:, 0].min()) - 0.03 * height
    x1 = max(body[:, 0].max(), flo[:, 0].max()) + 0.03 * height
    y0 = min(body[:, 1].min(), flo[:, 1].min()) - 0.03 * height
    y1 = body[:, 1].max() + 0.06 * height
    return _Scene(ref2, cand2, project(drop(ref)), bones, floor, (x0, x1), (y0, y1))


class _Panel:
    """The artists of one picture: floor, shadow, both skeletons, the worst-joint marker."""

    def __init__(self, ax, scene: _Scene, worst: _Worst | None, linewidth: float, marker: float):
        from matplotlib.collections import LineCollection

        self.scene, self.worst = scene, worst
        ax.set_axis_off()
        # one file unit is as long across as up: widen the limits along the axes' longer side
        box = ax.get_position()
        fig_w, fig_h = ax.figure.get_size_inches()
        px = box.width * fig_w / (box.height * fig_h)  # the axes' width / height
        (x0, x1), (y0, y1) = scene.xlim, scene.ylim
        if (x1 - x0) / (y1 - y0) < px:
            grow = (px * (y1 - y0) - (x1 - x0)) / 2
            x0, x1 = x0 - grow, x1 + grow
        else:
            grow = ((x1 - x0) / px - (y1 - y0)) / 2
            y0, y1 = y0 - grow, y1 + grow
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        self.floor = LineCollection(scene.floor, colors="#dddddd", linewidths=0.8, zorder=0)
        ax.add_collection(self.floor)
        has_cand = scene.cand is not None
        self.shadow = LineCollection([], colors="#c4c4c4", linewidths=linewidth * 1.2, zorder=1,
                                     capstyle="round")
        # the reference is drawn wider, under the candidate: where they agree it shows as a red edge around blue
        self.ref = LineCollection([], colors=REFERENCE_COLOR, linewidths=linewidth * (2.4 if has_cand else 1.2),
                                  alpha=0.65 if has_cand else 1.0, zorder=2, capstyle="round")
        self.cand = None
        for c in (self.shadow, self.ref):
            ax.add_collection(c)
        if has_cand:
            self.cand = LineCollection([], colors=CANDIDATE_COLOR, linewidths=linewidth, zorder=3,
                                       capstyle="round")
            ax.add_collection(self.cand)
        self.ring = self.link = None
        if worst is not None and has_cand:
            (self.link,) = ax.plot([], [], color=_MARK_COLOR, lw=max(0.8, linewidth * 0.5), zorder=4)
            (self.ring,) = ax.plot([], [], ls="none", marker="o", ms=marker, mfc="none", mec=_MARK_COLOR,
                                   mew=max(1.0, linewidth * 0.6), zorder=5)

    @property
    def moving(self) -> list:
        """The artists that change from frame to frame."""
        return [a for a in (self.shadow, self.ref, self.cand, self.link, self.ring) if a is not None]

    def show(self, frame: int) -> None:
        s, b = self.scene, self.scene.bones
        self.shadow.set_segments(s.ref_shadow[frame][b])
        self.ref.set_segments(s.ref[frame][b])
        if self.cand is not None:
            self.cand.set_segments(s.cand[frame][b])
        if self.ring is not None:
            p = self.worst.point
            pts = np.stack([s.ref[frame, p], s.cand[frame, p]])
            self.link.set_data(pts[:, 0], pts[:, 1])
            mid = pts.mean(axis=0)
            self.ring.set_data([mid[0]], [mid[1]])


def _legend_handles(names: tuple[str, str], has_cand: bool, worst: _Worst | None):
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color=REFERENCE_COLOR, lw=3, alpha=0.8, label=f"{names[0]} (reference)")]
    if has_cand:
        handles.append(Line2D([], [], color=CANDIDATE_COLOR, lw=2, label=f"{names[1]} (decoded)"))
    if worst is not None:
        handles.append(Line2D([], [], ls="none", marker="o", ms=9, mfc="none", mec=_MARK_COLOR, mew=1.5,
                              label=f"worst joint: {worst.name}"))
    return handles


def _headline(names: tuple[str, str], has_cand: bool, worst: _Worst | None) -> str:
    if not has_cand:
        return names[0]
    line = f"{names[0]} (red) vs {names[1]} (blue)"
    if worst is not None:
        line += f"\nworst joint {describe_error(worst.report)}"
    return line


def _frame_error_text(scene: _Scene, worst: _Worst | None, errors: NDArray | None, frame: int) -> str:
    if worst is None or errors is None:
        return ""
    unit = f" {worst.units}" if worst.units else ""
    return f"{worst.name}: {errors[frame]:.3g}{unit}"


def _header_height(font: float, lines: int) -> float:
    """Pixels taken by ``lines`` lines of text at ``font`` points."""
    return lines * font * 1.4 * _DPI / 72.0 + 8.0


def _write_animation(path: Path, kind: str, scene: _Scene, frames: NDArray[np.int64], fps: float,
                     size: tuple[int, int] | None, names: tuple[str, str], worst: _Worst | None,
                     errors: NDArray | None, num_frames: int, clip_fps: float) -> tuple[int, int]:
    Figure, FigureCanvasAgg = _matplotlib()
    from matplotlib import animation

    lines = (2 if worst is not None else 1) + 1 + (1 if worst is not None else 0)  # headline, legend
    if size is None:
        body = 380.0
        width = float(np.clip(scene.aspect * body, 480.0, 800.0))
        size = (2 * round(width / 2), 2 * round((body + _header_height(9.0, lines) + 24.0) / 2))
    w, h = size
    font = float(np.clip(9.0 * min(w / 560.0, h / 480.0), 6.0, 14.0))
    header, footer = _header_height(font, lines), font * 2.0 * _DPI / 72.0
    fig = Figure(figsize=(w / _DPI, h / _DPI), dpi=_DPI)
    FigureCanvasAgg(fig)
    top = 1.0 - header / h
    ax = fig.add_axes((0.01, footer / h, 0.98, max(0.1, top - footer / h)))
    scale = float(np.clip(min(w / scene.aspect, h - header - footer) / 380.0, 0.4, 3.0))
    panel = _Panel(ax, scene, worst, linewidth=2.0 * scale, marker=14.0 * scale)
    headline = fig.text(0.5, 1.0 - 4.0 / h, _headline(names, scene.cand is not None, worst), ha="center",
                        va="top", fontsize=font)
    legend = fig.legend(handles=_legend_handles(names, scene.cand is not None, worst), loc="upper center",
                        bbox_to_anchor=(0.5, 1.0 - _header_height(font, 2 if worst is not None else 1) / h),
                        fontsize=font * 0.9, frameon=False, ncol=2, borderaxespad=0.0, borderpad=0.0,
                        handletextpad=0.5, columnspacing=1.5)
    counter = fig.text(0.01, 0.01, "", ha="left", va="bottom", fontsize=font, family="monospace")
    local = fig.text(0.99, 0.01, "", ha="right", va="bottom", fontsize=font)
    # what does not move (titles, legend, floor) is drawn once and laid under every frame as a bitmap: text is
    # most of matplotlib's drawing time
    moving = panel.moving + [counter, local]
    for artist in moving:
        artist.set_visible(False)
    fig.canvas.draw()
    background = np.asarray(fig.canvas.buffer_rgba()).copy()
    for artist in (headline, legend, panel.floor):
        artist.set_visible(False)
    fig.figimage(background, xo=0, yo=0, origin="upper", zorder=-1)
    for artist in moving:
        artist.set_visible(True)
    if kind == ".gif":
        writer = animation.PillowWriter(fps=fps)
    else:
        writer = animation.FFMpegWriter(fps=fps, codec="h264")  # matplotlib adds yuv420p for players
    digits = len(str(num_frames - 1))
    writer.setup(fig, str(path), dpi=_DPI)
    try:
        for f in frames:
            f = int(f)
            panel.show(f)
            counter.set_text(f"frame {f:>{digits}}/{num_frames - 1} {f / clip_fps:6.2f} s")
            local.set_text(_frame_error_text(scene, worst, errors, f))
            writer.grab_frame()
    except BaseException:
        with contextlib.suppress(Exception):  # stop an ffmpeg process; the partial file is removed by the caller
            writer.finish()
        raise
    writer.finish()
    return w, h


def _grid(n: int, aspect: float, size: tuple[int, int] | None, header: float,
          title: float) -> tuple[int, int, tuple[int, int]]:
    """Rows, columns and image size of a filmstrip of ``n`` panels each showing a picture of ``aspect``.

    Without a size, pictures are about 300 pixels high (less if the strip would exceed 1800 pixels across)
    and the grid is the one closest to a 16:10 image, empty cells counting against it.  With a size, the grid
    that draws the pictures largest wins.
    """
    panel_aspect = float(np.clip(aspect, 0.5, 3.0))
    if size is None:
        def cost(cols: int) -> float:
            rows = math.ceil(n / cols)
            return abs(math.log(cols * panel_aspect / rows / 1.6)) + 0.5 * (rows * cols - n) / n

        cols = min(range(1, n + 1), key=cost)
        rows = math.ceil(n / cols)
        panel_h = min(300.0, 1800.0 / (cols * panel_aspect))
        return rows, cols, (round(cols * panel_h * panel_aspect), round(rows * (panel_h + title) + header))
    w, h = size
    best = None
    for cols in range(1, n + 1):
        rows = math.ceil(n / cols)
        drawn = min(w / cols / panel_aspect, (h - header) / rows - title)  # height of each picture
        if best is None or drawn > best[0] + 1e-9:
            best = (drawn, rows, cols)
    return best[1], best[2], (w, h)


def _write_filmstrip(path: Path, scene: _Scene, frames: NDArray[np.int64], size: tuple[int, int] | None,
                     names: tuple[str, str], worst: _Worst | None, errors: NDArray | None, num_frames: int,
                     clip_fps: float) -> tuple[int, int]:
    Figure, FigureCanvasAgg = _matplotlib()
    head_lines = 2 if worst is not None else 1
    font = 10.0 if size is None else float(np.clip(10.0 * min(size[0] / 1200.0, size[1] / 700.0), 6.0, 12.0))
    title_font = font * 0.85
    title = _header_height(title_font, 2 if worst is not None else 1)
    header = _header_height(font, head_lines + 1)  # the headline, then the legend in a row
    rows, cols, (w, h) = _grid(len(frames), scene.aspect, size, header, title)
    if (h - header) / rows - title < 20 or w / cols < 20:
        raise ValidationError(f"size {w}x{h} is too small for {len(frames)} pictures; make it larger")
    fig = Figure(figsize=(w / _DPI, h / _DPI), dpi=_DPI)
    FigureCanvasAgg(fig)
    top = 1.0 - header / h
    cell_w, cell_h = 1.0 / cols, top / rows
    picture_h = (h - header) / rows - title
    scale = float(np.clip(min(w / cols / scene.aspect, picture_h) / 300.0, 0.3, 3.0))
    for k, f in enumerate(frames):
        f = int(f)
        r, c = divmod(k, cols)
        ax = fig.add_axes((c * cell_w + 0.005 * cell_w, top - (r + 1) * cell_h, 0.99 * cell_w,
                           cell_h - title / h))
        _Panel(ax, scene, worst, linewidth=1.8 * scale, marker=12.0 * scale).show(f)
        is_worst = worst is not None and f == worst.frame
        label = f"frame {f} ({f / clip_fps:.2f} s)" + ("  (worst)" if is_worst else "")
        err = _frame_error_text(scene, worst, errors, f)
        fig.text((c + 0.5) * cell_w, top - r * cell_h, label + (f"\n{err}" if err else ""), ha="center",
                 va="top", fontsize=title_font, fontweight="bold" if is_worst else "normal")
    fig.text(0.5, 1.0 - 4.0 / h, _headline(names, scene.cand is not None, worst), ha="center", va="top",
             fontsize=font)
    fig.legend(handles=_legend_handles(names, scene.cand is not None, worst), loc="upper center",
               bbox_to_anchor=(0.5, 1.0 - _header_height(font, head_lines) / h), fontsize=font * 0.9,
               frameon=False, ncol=3, borderaxespad=0.0, borderpad=0.0, handletextpad=0.5, columnspacing=2.0)
    fig.savefig(str(path), format="png", dpi=_DPI, facecolor="white")
    return w, h


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
    _matplotlib()
    if suffix == ".mp4":
        from matplotlib import animation

        if not animation.writers.is_available("ffmpeg"):
            raise FormatError("writing .mp4 needs ffmpeg, which was not found on PATH; write a .gif instead", path)
    return suffix


def render(path: str | os.PathLike[str], reference: Motion, candidate: Motion | None = None, *,
           names: tuple[str, str] = ("reference", "candidate"), frames: slice | str | None = None,
           fps: float | None = None, count: int = 8, max_frames: int = 150,
           size: tuple[int, int] | None = None, up: str = "auto") -> RenderResult:
    """Draw ``reference`` (red) and ``candidate`` (blue) overlaid, to a GIF/MP4 animation or a PNG filmstrip.

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
            motion, about 480 pixels high and 480 to 800 wide for an animation, pictures about 300 pixels high
            (the strip at most 1800 wide) for a filmstrip.
        up: ``"y"`` or ``"z"`` for the data's up axis, or ``"auto"`` (:func:`detect_up_axis`).

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
        if suffix == ".gif" and fps > _GIF_MAX_FPS:
            raise ValidationError(f"a GIF cannot play faster than {_GIF_MAX_FPS:g} fps, got --fps {fps:g}")
    if size is not None:
        size = _check_size(size)
        if suffix == ".mp4" and (size[0] % 2 or size[1] % 2):
            raise ValidationError(f"an MP4 needs an even width and height, got {size[0]}x{size[1]}")
    if up not in ("auto", "y", "z"):
        raise ValidationError(f"up must be 'auto', 'y' or 'z', got {up!r}")
    names = (str(names[0]), str(names[1]))

    notes: list[str] = []
    if candidate is not None:
        candidate, note = align_candidate(reference, candidate, names[0], names[1])
        if note:
            notes.append(note)
    selected, exact = _select(frames, reference.num_frames, names[0])

    error = worst = errors = None
    if candidate is None:
        ref_pos = global_positions(reference)
        cand_pos = None
    else:
        evaluator = Evaluator(reference)
        ref_pos = evaluator.reference_positions
        cand_pos = global_positions(candidate)
        error = evaluator.positions_error(cand_pos)
        worst = _Worst(error, point_names(reference.skeleton).index(error.joint))
        errors = np.linalg.norm(ref_pos[:, worst.point] - cand_pos[:, worst.point], axis=-1)
    if up == "auto":
        up = detect_up_axis(ref_pos[selected])
    height = character_height(reference.skeleton)
    scene = _scene(ref_pos, cand_pos, _bones(reference.skeleton), up, selected, height)

    rate = None
    if suffix == ".png":
        shown = _filmstrip_frames(selected, exact, int(count), int(max_frames), None if error is None else error.frame)
    else:
        shown, rate, more = _animation_frames(selected, exact, reference.fps, fps, int(max_frames), suffix)
        notes.extend(more)
    with atomic_path(out) as tmp:
        if suffix == ".png":
            size = _write_filmstrip(tmp, scene, shown, size, names, worst, errors, reference.num_frames,
                                    reference.fps)
        else:
            size = _write_animation(tmp, suffix, scene, shown, rate, size, names, worst, errors,
                                    reference.num_frames, reference.fps)
    return RenderResult(out, OUTPUT_SUFFIXES[suffix], tuple(int(f) for f in shown), rate, size, up, error,
                        tuple(notes))
