"""Drawing with matplotlib (imported only here and in :mod:`~motionrep.present.render.strip`, on the non-interactive Agg
canvas): the panels of both stick figures, the zoomed worst joint, titles and legends, the error panel and the
animation writer (GIF, MP4); the filmstrip (PNG) is :mod:`~motionrep.present.render.strip`."""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np
from numpy.typing import NDArray

from ...errors import MotionrepError
from ...pipeline.evaluate import ErrorReport
from .scene import Scene, Worst

__all__ = ["REFERENCE_COLOR", "CANDIDATE_COLOR", "MARK_COLOR", "DPI", "require_matplotlib", "describe_error",
           "Panel", "Curve", "error_panel", "inset_corner", "zoom_inset", "write_animation", "Progress",
           "header_height", "legend_handles", "headline_text"]

#: ``progress(done, total)``: called as pictures are drawn (``done`` of ``total``; the last call, ``done ==
#: total``, comes once the file is written).
Progress = Callable[[int, int], None]

REFERENCE_COLOR = "#d62728"  # red
CANDIDATE_COLOR = "#1f5fd6"  # blue
MARK_COLOR = "#111111"
DPI = 100


def require_matplotlib() -> Any:
    """matplotlib's ``Figure`` and ``FigureCanvasAgg`` (the non-interactive canvas), for every picture motionrep
    draws (renders, benchmark plots).

    Raises:
        MotionrepError: matplotlib is not installed (with the command that installs it).
    """
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise MotionrepError("drawing pictures and plots needs matplotlib, which is not installed: "
                             "pip install matplotlib") from None
    return Figure, FigureCanvasAgg


def describe_error(report: ErrorReport) -> str:
    """The worst joint of a report in a few words: ``"LeftHand 3.21 cm = 1.9% of height, frame 123"``."""
    unit = f" {report.units}" if report.units else " units"
    pct = "" if not math.isfinite(report.max_error_percent) else f" = {report.max_error_percent:.3g}% of height"
    return f"{report.joint} {report.max_error:.3g}{unit}{pct}, frame {report.frame}"


class Panel:
    """The artists of one picture: floor, shadow, both skeletons, the worst-joint marker.

    The marker circles the worst joint *of the frame shown* (``points[frame]``, each frame's largest error) when
    ``points`` is given, else the clip's worst joint.
    """

    def __init__(self, ax, scene: Scene, worst: Worst | None, linewidth: float, marker: float,
                 points: NDArray[np.int64] | None = None):
        from matplotlib.collections import LineCollection

        self.scene, self.worst, self.points = scene, worst, points
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
        # the reference is drawn wider and opaque, the candidate on top of it: where they agree the candidate
        # shows as a blue line with a red edge, never as a mixture of the two colours
        self.ref = LineCollection([], colors=REFERENCE_COLOR, linewidths=linewidth * (3.0 if has_cand else 1.2),
                                  zorder=2, capstyle="round")
        self.cand = None
        for c in (self.shadow, self.ref):
            ax.add_collection(c)
        self.halo = None
        if has_cand:
            # a thin white rim between the two keeps their edges from blending into purple when antialiased
            self.halo = LineCollection([], colors="white", linewidths=linewidth * 1.6, zorder=3, capstyle="round")
            self.cand = LineCollection([], colors=CANDIDATE_COLOR, linewidths=linewidth, zorder=3.5,
                                       capstyle="round")
            ax.add_collection(self.halo)
            ax.add_collection(self.cand)
        self.ring = self.link = None
        if worst is not None and has_cand:
            (self.link,) = ax.plot([], [], color=MARK_COLOR, lw=max(0.8, linewidth * 0.5), zorder=4)
            (self.ring,) = ax.plot([], [], ls="none", marker="o", ms=marker, mfc="none", mec=MARK_COLOR,
                                   mew=max(1.0, linewidth * 0.6), zorder=5)

    @property
    def moving(self) -> list:
        """The artists that change from frame to frame (the floor too, when the picture follows the clip)."""
        artists = [self.shadow, self.ref, self.halo, self.cand, self.link, self.ring]
        if self.scene.follows:
            artists.insert(0, self.floor)
        return [a for a in artists if a is not None]

    def show(self, frame: int) -> None:
        s, b = self.scene, self.scene.bones
        offset = s.shift[frame]
        if s.follows:
            self.floor.set_segments(s.floor - offset)
        self.shadow.set_segments(s.ref_shadow[frame][b] - offset)
        self.ref.set_segments(s.ref[frame][b] - offset)
        if self.cand is not None:
            self.halo.set_segments(s.cand[frame][b] - offset)
            self.cand.set_segments(s.cand[frame][b] - offset)
        if self.ring is not None:
            p = self.worst.point if self.points is None else int(self.points[frame])
            pts = np.stack([s.ref[frame, p], s.cand[frame, p]]) - offset
            self.link.set_data(pts[:, 0], pts[:, 1])
            mid = pts.mean(axis=0)
            self.ring.set_data([mid[0]], [mid[1]])


@dataclass(frozen=True)
class Curve:
    """Each frame's largest joint error (the shared measure, frame by frame) and where it is."""

    values: NDArray[np.float64]  # (F,) file units
    points: NDArray[np.int64]  # (F,) index into names
    names: tuple[str, ...]
    bound: float | None
    units: str | None
    height: float

    def text(self, frame: int, short: bool = False) -> str:
        unit = f" {self.units}" if self.units else ""
        v = float(self.values[frame])
        pct = f" ({100 * v / self.height:.3g}%)" if self.height > 0 else ""
        if short:
            return f"error {v:.3g}{unit}{pct}"
        return f"frame error {v:.3g}{unit}{pct} at {self.names[int(self.points[frame])]}"


def units_text(units: str | None) -> str:
    return f"lengths in {units}" if units else "lengths in file units"


def legend_handles(names: tuple[str, str], has_cand: bool, worst: Worst | None):
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color=REFERENCE_COLOR, lw=4, label=f"{names[0]} (reference)")]
    if has_cand:
        handles.append(Line2D([], [], color=CANDIDATE_COLOR, lw=2, label=f"{names[1]} (decoded)"))
    if worst is not None:
        handles.append(Line2D([], [], ls="none", marker="o", ms=9, mfc="none", mec=MARK_COLOR, mew=1.5,
                              label="each frame's worst joint"))
    return handles


def inset_corner(ax, scene: Scene, frames: NDArray[np.int64], width: float, height: float) -> tuple[int, int]:
    """The corner of ``ax`` (``(1, 1)`` upper right, ``(0, 1)`` upper left, then the lower ones) where an inset of
    ``width`` x ``height`` (axes fractions) covers the fewest drawn points over ``frames``: the inset is drawn
    once, under the moving figures, so it goes where they pass least."""
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    idx = np.asarray(frames, dtype=np.int64)
    pts = [scene.ref[idx] - scene.shift[idx][:, None]]
    if scene.cand is not None:
        pts.append(scene.cand[idx] - scene.shift[idx][:, None])
    p = np.concatenate(pts, axis=1)  # (N, P, 2)
    u, v = (p[..., 0] - x0) / (x1 - x0), (p[..., 1] - y0) / (y1 - y0)
    best, corner = None, (1, 1)
    for cx, cy in ((1, 1), (0, 1), (1, 0), (0, 0)):
        inside_u = (u >= 1 - width) if cx else (u <= width)
        inside_v = (v >= 1 - height) if cy else (v <= height)
        covered = int(np.sum(inside_u & inside_v))
        if best is None or covered < best:
            best, corner = covered, (cx, cy)
    return corner


def zoom_inset(fig, rect: tuple[float, float, float, float], scene: Scene, worst: Worst, linewidth: float,
               font: float, frame_fps: float) -> Any:
    """A picture of the worst frame zoomed on the worst joint (both skeletons around it), in ``rect`` (figure
    fractions), framed and titled with the joint, the frame and the zoom.  Returns its axes."""
    from matplotlib.patches import Rectangle

    ax = fig.add_axes(rect)
    panel = Panel(ax, scene, worst, linewidth=linewidth, marker=linewidth * 9.0)
    f, p = worst.frame, worst.point
    panel.show(f)
    offset = scene.shift[f]
    a, b = scene.ref[f, p] - offset, scene.cand[f, p] - offset
    mid = (a + b) / 2
    full = scene.ylim[1] - scene.ylim[0]
    # the error fills about a third of the inset, but never less than a tenth of the character's picture
    half = max(1.5 * float(np.linalg.norm(a - b)), 0.06 * full)
    box = ax.get_position()
    fig_w, fig_h = fig.get_size_inches()
    px = box.width * fig_w / (box.height * fig_h)
    ax.set_xlim(mid[0] - half * px, mid[0] + half * px)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    zoom = full / (2 * half)
    ax.add_patch(Rectangle((0, 0), 1, 1, transform=ax.transAxes, facecolor="white", edgecolor="none", zorder=-5))
    ax.add_patch(Rectangle((0, 0), 1, 1, transform=ax.transAxes, fill=False, edgecolor="#777777", lw=1.0,
                           zorder=10, clip_on=False))
    ax.text(0.5, 0.98, f"worst: {worst.name}\nframe {f} ({f / frame_fps:.2f} s), zoom x{zoom:.2g}",
            transform=ax.transAxes, ha="center", va="top", fontsize=font, zorder=11,
            bbox={"facecolor": "white", "edgecolor": "none", "alpha": 0.8, "pad": 1.0})
    return ax


def headline_text(names: tuple[str, str], has_cand: bool, worst: Worst | None, units: str | None) -> str:
    if not has_cand:
        return f"{names[0]}, {units_text(units)}"
    line = f"{names[0]} (red) vs {names[1]} (blue), {units_text(units)}"
    if worst is not None:
        line += f"\nworst joint {describe_error(worst.report)}"
    return line


def error_panel(fig, rect: tuple[float, float, float, float], curve: Curve, first: int, last: int, font: float,
                 worst_frame: int | None, marks: NDArray[np.int64] | None = None):
    """The error over time under the pictures: each frame's largest joint error, the bound, the worst frame."""
    ax = fig.add_axes(rect)
    frames = np.arange(first, last + 1)
    values = curve.values[first:last + 1]
    if marks is not None:
        for f in marks:
            ax.axvline(int(f), color="#bbbbbb", lw=0.8, zorder=0)
    ax.plot(frames, values, color=CANDIDATE_COLOR, lw=1.3, zorder=2)
    top = max(float(values.max(initial=0.0)), curve.bound or 0.0) * 1.15 or 1.0
    if curve.bound is not None:
        ax.axhline(curve.bound, color="#b00000", ls="--", lw=1.0, zorder=1)
        ax.text(first, curve.bound, " bound", color="#b00000", fontsize=font * 0.8, va="bottom", ha="left")
    if worst_frame is not None and first <= worst_frame <= last:
        ax.plot([worst_frame], [curve.values[worst_frame]], "o", color=MARK_COLOR, ms=4, zorder=3)
    ax.set_xlim(first, max(last, first + 1))
    ax.set_ylim(0.0, top)
    ax.set_ylabel(f"error ({curve.units or 'file units'})", fontsize=font * 0.85)
    ax.set_xlabel("frame", fontsize=font * 0.85, labelpad=1)
    ax.tick_params(labelsize=font * 0.75, length=2, pad=1)
    if curve.height > 0:
        h = curve.height
        right = ax.secondary_yaxis("right", functions=(lambda v: 100.0 * v / h, lambda p: p * h / 100.0))
        right.set_ylabel("% of height", fontsize=font * 0.85)
        right.tick_params(labelsize=font * 0.75, length=2, pad=1)
    for side in ("top",):
        ax.spines[side].set_visible(False)
    return ax


def header_height(font: float, lines: int) -> float:
    """Pixels taken by ``lines`` lines of text at ``font`` points."""
    return lines * font * 1.4 * DPI / 72.0 + 8.0


def _gif_writer(animation: Any) -> Any:
    """matplotlib's ``PillowWriter``, each frame turned into GIF's palette mode as it is grabbed (as Pillow would
    when saving), so the time goes into the frames, where progress is reported, not into one long final save."""
    from PIL import Image

    class GifWriter(animation.PillowWriter):
        def grab_frame(self, **savefig_kwargs: Any) -> None:
            super().grab_frame(**savefig_kwargs)
            im = self._frames[-1]
            if im.mode == "RGB":
                self._frames[-1] = im.convert("P", palette=Image.Palette.ADAPTIVE)

    return GifWriter


def write_animation(path: Path, kind: str, scene: Scene, frames: NDArray[np.int64], fps: float,
                     size: tuple[int, int] | None, names: tuple[str, str], worst: Worst | None,
                     curve: Curve | None, num_frames: int, clip_fps: float, units: str | None,
                     progress: Progress | None = None) -> tuple[int, int]:
    Figure, FigureCanvasAgg = require_matplotlib()
    from matplotlib import animation

    lines = (2 if worst is not None else 1) + 1 + (1 if worst is not None else 0)  # headline, legend
    if size is None:
        body = 480.0
        width = float(np.clip(scene.aspect * body, 640.0, 960.0))
        extra = 150.0 if curve is not None else 0.0
        size = (2 * round(width / 2), 2 * round((body + extra + header_height(9.0, lines) + 24.0) / 2))
    w, h = size
    font = float(np.clip(9.0 * min(w / 560.0, h / 480.0), 6.0, 14.0))
    handles = legend_handles(names, scene.cand is not None, worst)
    wide = sum(len(hd.get_label()) + 8 for hd in handles) * font * 0.9 * 0.6 * DPI / 72.0 > 0.95 * w
    header, footer = header_height(font, lines + int(wide)), font * 2.0 * DPI / 72.0
    graph = 0.0 if curve is None else min(0.24 * h, 150.0)  # the error panel with its labels
    fig = Figure(figsize=(w / DPI, h / DPI), dpi=DPI)
    FigureCanvasAgg(fig)
    top = 1.0 - header / h
    bottom = (footer + graph) / h
    ax = fig.add_axes((0.01, bottom, 0.98, max(0.1, top - bottom)))
    scale = float(np.clip(min(w / scene.aspect, h - header - footer - graph) / 380.0, 0.4, 3.0))
    panel = Panel(ax, scene, worst, linewidth=2.0 * scale, marker=14.0 * scale,
                  points=None if curve is None else curve.points)
    inset = None
    if worst is not None and scene.cand is not None:
        # the worst joint at the worst frame, zoomed, in the picture's upper right corner (drawn once)
        box = ax.get_position()
        iw, ih = 0.27 * box.width, 0.36 * box.height
        cx, cy = inset_corner(ax, scene, frames, 0.27, 0.36)
        inset = zoom_inset(fig, (box.x0 + 0.005 + cx * (box.width - iw - 0.01),
                                 box.y0 + 0.005 + cy * (box.height - ih - 0.01), iw, ih), scene, worst,
                           linewidth=2.0 * scale, font=font * 0.75, frame_fps=clip_fps)
    cursor = None
    if curve is not None:
        label = font * 2.6 * DPI / 72.0  # x tick labels and the axis label
        rect = (70.0 / w, (footer + label) / h, 1.0 - 140.0 / w, max(0.05, (graph - label - 6.0) / h))
        graph_ax = error_panel(fig, rect, curve, int(frames[0]), int(frames[-1]), font,
                                None if worst is None else worst.frame)
        cursor = graph_ax.axvline(int(frames[0]), color=MARK_COLOR, lw=1.0, zorder=4)
    headline = fig.text(0.5, 1.0 - 4.0 / h, headline_text(names, scene.cand is not None, worst, units), ha="center",
                        va="top", fontsize=font)
    legend = fig.legend(handles=handles, loc="upper center",
                        bbox_to_anchor=(0.5, 1.0 - header_height(font, 2 if worst is not None else 1) / h),
                        fontsize=font * 0.9, frameon=False, ncol=2 if wide else 3, borderaxespad=0.0,
                        borderpad=0.0, handletextpad=0.5, columnspacing=1.5)
    counter = fig.text(0.01, 0.01, "", ha="left", va="bottom", fontsize=font, family="monospace")
    local = fig.text(0.99, 0.01, "", ha="right", va="bottom", fontsize=font)
    # what does not move (titles, legend, the error curve, a fixed floor) is drawn once and laid under every
    # frame as a bitmap: text is most of matplotlib's drawing time
    moving = panel.moving + [counter, local] + ([cursor] if cursor is not None else [])
    for artist in moving:
        artist.set_visible(False)
    fig.canvas.draw()
    background = np.asarray(fig.canvas.buffer_rgba()).copy()
    for artist in [headline, legend] + ([] if scene.follows else [panel.floor]):
        artist.set_visible(False)
    if inset is not None:  # in the bitmap: nothing of it is drawn again
        inset.set_visible(False)
    fig.figimage(background, xo=0, yo=0, origin="upper", zorder=-1)
    if cursor is not None:  # the error panel is in the bitmap: its axes stay only to place the cursor
        graph_ax = cursor.axes
        graph_ax.patch.set_visible(False)
        graph_ax.set_axis_off()
        for artist in graph_ax.lines + graph_ax.texts + graph_ax.collections:
            artist.set_visible(artist is cursor)
        for child in graph_ax.child_axes:
            child.set_visible(False)
    for artist in moving:
        artist.set_visible(True)
    if kind == ".gif":
        writer = _gif_writer(animation)(fps=fps)
    else:
        writer = animation.FFMpegWriter(fps=fps, codec="h264")  # matplotlib adds yuv420p for players
    digits = len(str(num_frames - 1))
    writer.setup(fig, str(path), dpi=DPI)
    total = len(frames) + 1  # the last step: writing the file (Pillow encodes a GIF at the end)
    try:
        for k, f in enumerate(frames):
            f = int(f)
            panel.show(f)
            counter.set_text(f"frame {f:>{digits}}/{num_frames - 1} {f / clip_fps:6.2f} s")
            if curve is not None:
                local.set_text(curve.text(f))
                cursor.set_xdata([f, f])
            writer.grab_frame()
            if progress is not None:
                progress(k + 1, total)
    except BaseException:
        with contextlib.suppress(Exception):  # stop an ffmpeg process; the partial file is removed by the caller
            writer.finish()
        raise
    writer.finish()
    if progress is not None:
        progress(total, total)
    return w, h
