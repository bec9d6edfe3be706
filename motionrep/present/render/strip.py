"""The filmstrip (PNG): a grid of pictures that leaves no cell empty, the worst joint zoomed in the last cell, the
error panel under them (matplotlib, through :mod:`~motionrep.present.render.draw`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ...errors import ValidationError
from .draw import (DPI, Curve, Panel, Progress, error_panel, header_height, headline_text, legend_handles,
                   require_matplotlib, zoom_inset)
from .scene import Scene, Worst

__all__ = ["grid", "write_filmstrip"]


def grid(n: int, aspect: float, size: tuple[int, int] | None, header: float,
          title: float) -> tuple[int, int, tuple[int, int]]:
    """Rows, columns and image size of a filmstrip of ``n`` panels each showing a picture of ``aspect``.

    Without a size, pictures are about 300 pixels high (less if the strip would exceed 1800 pixels across)
    and the grid is the one closest to a 16:10 image, empty cells counting against it (the writer widens the
    last cell over any left, so none shows empty).  With a size, the grid
    that draws the pictures largest wins.
    """
    panel_aspect = float(np.clip(aspect, 0.8, 3.0))
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


def write_filmstrip(path: Path, scene: Scene, frames: NDArray[np.int64], size: tuple[int, int] | None,
                     names: tuple[str, str], worst: Worst | None, curve: Curve | None, num_frames: int,
                     clip_fps: float, units: str | None, span: tuple[int, int],
                     progress: Progress | None = None) -> tuple[int, int]:
    Figure, FigureCanvasAgg = require_matplotlib()
    head_lines = 2 if worst is not None else 1
    font = 10.0 if size is None else float(np.clip(10.0 * min(size[0] / 1200.0, size[1] / 700.0), 6.0, 12.0))
    title_font = font * 0.85
    title = header_height(title_font, 2 if curve is not None else 1)
    header = header_height(font, head_lines + 1)  # the headline, then the legend in a row
    graph = 0.0 if curve is None else 130.0
    zoomed = worst is not None and scene.cand is not None
    cells = len(frames) + int(zoomed)  # with a candidate, one more cell: the worst joint zoomed
    rows, cols, (w, h) = grid(cells, scene.aspect, size, header + graph, title)
    if curve is not None and size is not None:
        graph = min(graph, 0.25 * h)
    if (h - header - graph) / rows - title < 20 or w / cols < 20:
        raise ValidationError(f"size {w}x{h} is too small for {len(frames)} pictures; make it larger")
    fig = Figure(figsize=(w / DPI, h / DPI), dpi=DPI)
    FigureCanvasAgg(fig)
    top = 1.0 - header / h
    bottom = graph / h
    cell_w, cell_h = 1.0 / cols, (top - bottom) / rows
    picture_h = (h - header - graph) / rows - title
    scale = float(np.clip(min(w / cols / scene.aspect, picture_h) / 300.0, 0.3, 3.0))
    # no empty cell: the last cell (the zoom, or the last picture) spans what the last row leaves over
    spans = [1] * cells
    spans[-1] += rows * cols - cells
    for k, f in enumerate(frames):
        f = int(f)
        r, c = divmod(k, cols)
        ax = fig.add_axes((c * cell_w + 0.005 * cell_w, top - (r + 1) * cell_h, (spans[k] - 0.01) * cell_w,
                           cell_h - title / h))
        Panel(ax, scene, worst, linewidth=1.8 * scale, marker=12.0 * scale,
              points=None if curve is None else curve.points).show(f)
        if progress is not None:
            progress(k + 1, len(frames) + 1)
        is_worst = worst is not None and f == worst.frame
        label = f"frame {f} ({f / clip_fps:.2f} s)" + ("  (worst)" if is_worst else "")
        err = "" if curve is None else curve.text(f, short=True)
        fig.text((c + 0.5 * spans[k]) * cell_w, top - r * cell_h, label + (f"\n{err}" if err else ""),
                 ha="center", va="top", fontsize=title_font, fontweight="bold" if is_worst else "normal")
    if zoomed:
        r, c = divmod(len(frames), cols)
        zoom_inset(fig, (c * cell_w + 0.02 * cell_w, top - (r + 1) * cell_h + 0.02 * cell_h,
                         (spans[-1] - 0.04) * cell_w, cell_h - title / h - 0.02 * cell_h), scene, worst,
                   linewidth=1.8 * scale, font=title_font, frame_fps=clip_fps)
    if curve is not None:
        label = font * 2.6 * DPI / 72.0
        rect = (70.0 / w, label / h, 1.0 - 140.0 / w, max(0.03, (graph - label - 8.0) / h))
        error_panel(fig, rect, curve, span[0], span[1], font, None if worst is None else worst.frame, frames)
    fig.text(0.5, 1.0 - 4.0 / h, headline_text(names, scene.cand is not None, worst, units), ha="center", va="top",
             fontsize=font)
    fig.legend(handles=legend_handles(names, scene.cand is not None, worst), loc="upper center",
               bbox_to_anchor=(0.5, 1.0 - header_height(font, head_lines) / h), fontsize=font * 0.9,
               frameon=False, ncol=3, borderaxespad=0.0, borderpad=0.0, handletextpad=0.5, columnspacing=2.0)
    fig.savefig(str(path), format="png", dpi=DPI, facecolor="white")
    if progress is not None:
        progress(len(frames) + 1, len(frames) + 1)
    return w, h
