"""The rate-distortion plot of a benchmark: error (% of character height) against size, by default the payload
bits per bone per frame (:mod:`motionrep.pipeline.figures`: one scale for every codec and representation, ACL's), one
colour per codec and one marker shape per clip, one point per run (Tojo et al. 2022, Fig. 3 style), with lines
through the medians of a sweep, the legends outside the axes and ACL 2.1's strict-bound sizes overlaid where the
project has them for a clip (:mod:`motionrep.present.bench.anchors`).
"""

from __future__ import annotations

import math
import os
import statistics
from pathlib import Path
from typing import Sequence

from ...errors import FormatError, ParameterError
from ..render.draw import require_matplotlib
from .report import BenchRow

__all__ = ["plot_series", "plain_log_ticks", "plot_rate_distortion", "require_matplotlib"]


def _series_label(r: BenchRow, reps: bool) -> str:
    return f"{r.codec} / {r.representation}" if reps else r.codec


_RATIOS = {"payload_bits_per_bone_frame": "payload bits per bone per frame (codec arrays; bones = joints + end sites)",
           "file_bits_per_bone_frame": "file bits per bone per frame (whole .mrc; bones = joints + end sites)",
           "paper_ratio": "compression ratio (Tojo et al.: frames x features / stored parameters)",
           "bytes_ratio": "bytes ratio (BVH channels as float32 / .mrc bytes)"}
#: The horizontal axis unless told otherwise.
DEFAULT_X = "payload_bits_per_bone_frame"


def _x(r: BenchRow, column: str) -> float | None:
    """``r``'s value on the horizontal axis (rows read from older CSVs have the payload's figure only under its
    old name, ``bits_per_bone_frame``)."""
    x = getattr(r, column)
    return r.bits_per_bone_frame if x is None and column == DEFAULT_X else x


def plot_series(rows: Sequence[BenchRow], ratio: str = DEFAULT_X) -> dict[str, list[tuple[float, float]]]:
    """The points :func:`plot_rate_distortion` draws: ``{series: [(x, error_percent), ...]}`` for the runs
    that succeeded, in row order; one series per codec (per codec and representation when the rows have several
    representations).  ``ratio`` is the column on the horizontal axis: ``"payload_bits_per_bone_frame"``
    (default), ``"file_bits_per_bone_frame"``, ``"paper_ratio"`` or ``"bytes_ratio"``."""
    if ratio not in _RATIOS:
        raise ParameterError(f"ratio must be one of {', '.join(_RATIOS)}, got {ratio!r}")
    reps = len({r.representation for r in rows}) > 1
    out: dict[str, list[tuple[float, float]]] = {}
    for r in rows:
        x = _x(r, ratio)
        if r.status == "ok" and x is not None and r.error_percent is not None:
            out.setdefault(_series_label(r, reps), []).append((x, r.error_percent))
    return out


def plain_log_ticks(axis) -> None:
    """Label a log-scaled matplotlib ``axis`` with plain numbers (``2``, ``5``, ``10``, ``20`` ...) rather than
    ``2 x 10^0``: powers of ten and the 2x and 5x minor ticks are labelled, the other minor ticks are not."""
    from matplotlib.ticker import FuncFormatter

    def label(v, _pos, minor=False):
        if v <= 0:
            return ""
        lead = round(v / 10 ** math.floor(math.log10(v) + 1e-9), 6)
        if minor and lead not in (2.0, 5.0):
            return ""
        return f"{v:g}"

    axis.set_major_formatter(FuncFormatter(label))
    axis.set_minor_formatter(FuncFormatter(lambda v, pos: label(v, pos, minor=True)))


def plot_rate_distortion(rows: Sequence[BenchRow], path: str | os.PathLike[str], *, title: str | None = None,
                         log_error: bool | None = None, ratio: str = DEFAULT_X, acl: bool = True
                         ) -> dict[str, list[tuple[float, float]]]:
    """Draw error (% of character height) against payload bits per bone per frame, one colour per codec and one
    marker shape per clip, one point per run (Tojo et al. 2022, Fig. 3 style), and write it to ``path``
    (``.png``, ``.svg`` or ``.pdf``) atomically.  Two legends: the codecs (with their runs, and failed runs) and
    the clips (their shapes repeat after 14 clips, which the legend says).

    Runs of the same parameter values (a sweep) are joined by a line through their medians; a bound given in
    percent is drawn as a dashed horizontal line.  Failed runs are not drawn (they have no ratio); the legend
    counts them.

    Args:
        rows: the runs.
        path: the picture.
        title: a title (default: a summary of the clips).
        log_error: logarithmic error axis; default: when the errors drawn span more than a factor of 20 (the
            ratio axis is logarithmic when the ratios span more than a factor of 20).
        ratio: the horizontal axis (:func:`plot_series`): payload bits per bone per frame by default, the same
            scale for every codec and representation.
        acl: overlay ACL 2.1's strict-bound sizes (black stars) for the clips and percent bounds the project
            has them for (only on a bits-per-bone-per-frame axis).

    Returns:
        The points drawn, as :func:`plot_series`.

    Raises:
        MotionrepError: matplotlib is not installed.
        FormatError: for an unsupported suffix.
    """
    from ...io import atomic_path

    suffix = Path(path).suffix.lower()
    if suffix not in (".png", ".svg", ".pdf"):
        raise FormatError(f"cannot draw a plot as {suffix or '(no suffix)'!r}; use .png, .svg or .pdf", path)
    series = plot_series(rows, ratio)
    Figure, FigureCanvasAgg = require_matplotlib()
    reps = len({r.representation for r in rows}) > 1
    fig = Figure(figsize=(9.5, 5.0), dpi=120)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    colours = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"]
    markers = ["o", "s", "^", "D", "v", "P", "X", "*", "<", ">", "p", "h", "d", "8"]
    labels = list(dict.fromkeys(_series_label(r, reps) for r in rows))
    clips = list(dict.fromkeys(r.clip for r in rows))
    shape = {c: markers[k % len(markers)] for k, c in enumerate(clips)}
    all_y: list[float] = []
    codec_handles = []
    from matplotlib.lines import Line2D

    for i, label in enumerate(labels):
        pts = series.get(label, [])
        members = [r for r in rows if _series_label(r, reps) == label]
        missed = sum(r.status != "ok" for r in members)
        colour = colours[i % len(colours)]
        text = f"{label} ({len(pts)} runs" + (f", {missed} failed" if missed else "") + ")"
        codec_handles.append(Line2D([], [], ls="none", marker="s", ms=7, color=colour, label=text))
        for clip in clips:
            here = [r for r in members if r.clip == clip and r.status == "ok" and _x(r, ratio) is not None
                    and r.error_percent is not None]
            if here:
                xs, ys = [_x(r, ratio) for r in here], [r.error_percent for r in here]
                all_y += ys
                ax.scatter(xs, ys, s=22, alpha=0.6, color=colour, marker=shape[clip], linewidths=0)
        # a line through the medians of each sweep value
        groups: dict[str, list[BenchRow]] = {}
        for r in members:
            if r.status == "ok" and r.params:
                groups.setdefault(f"{r.max_error}|{r.params}", []).append(r)
        if len(groups) > 1:
            med = sorted((statistics.median(_x(r, ratio) for r in g),
                          statistics.median(r.error_percent for r in g)) for g in groups.values())
            ax.plot([m[0] for m in med], [m[1] for m in med], color=colour, linewidth=1.5, alpha=0.9)
    for bound in dict.fromkeys(r.max_error for r in rows):
        if bound is not None and bound.endswith("%"):
            ax.axhline(float(bound[:-1]), color="0.4", linestyle="--", linewidth=0.8)
            ax.annotate(f"bound {bound}", xy=(1.0, float(bound[:-1])), xycoords=("axes fraction", "data"),
                        xytext=(-4, 2), textcoords="offset points", ha="right", fontsize=7, color="0.3")
    positive = [y for y in all_y if y > 0]
    if log_error is None:
        log_error = bool(positive) and max(positive) / min(positive) > 20
    if log_error and positive:
        ax.set_yscale("log")
        plain_log_ticks(ax.yaxis)
    ratios = [x for pts in series.values() for x, _ in pts if x > 0]
    if ratios and max(ratios) / min(ratios) > 20:
        ax.set_xscale("log")
        plain_log_ticks(ax.xaxis)
    anchors = []
    if acl and ratio == DEFAULT_X:
        from .anchors import acl_anchors_for

        percents = [float(b[:-1]) for b in dict.fromkeys(r.max_error for r in rows) if b and b.endswith("%")]
        anchors = acl_anchors_for({r.source for r in rows}, percents) if percents else []
    if anchors:
        ax.scatter([a.payload_bits_per_bone_frame for a in anchors], [a.bound_percent for a in anchors], s=70,
                   marker="*", color="black", zorder=5)
        codec_handles.append(Line2D([], [], ls="none", marker="*", ms=9, color="black",
                                    label=f"ACL 2.1, strict bound ({len(anchors)} clip x bound)"))
    ax.set_xlabel(_RATIOS[ratio])
    ax.set_ylabel("L-inf joint position error (% of character height)")
    clips = list(dict.fromkeys(r.clip for r in rows))
    ax.set_title(title or (clips[0] if len(clips) == 1 else f"{len(clips)} clips"), fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    # the legends outside the axes, on the right, so that they never cover a point
    first = ax.legend(handles=codec_handles, fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0),
                      borderaxespad=0.0, title="codec", title_fontsize=8)
    if len(clips) > 1:
        ax.add_artist(first)
        shown = clips[:14]
        clip_handles = [Line2D([], [], ls="none", marker=shape[c], ms=6, color="0.35", label=c) for c in shown]
        if len(clips) > len(shown):
            clip_handles.append(Line2D([], [], ls="none", label=f"... {len(clips) - len(shown)} more (shapes repeat)"))
        ax.legend(handles=clip_handles, fontsize=7, loc="lower left", bbox_to_anchor=(1.02, 0.0),
                  borderaxespad=0.0, title="clip", title_fontsize=7)
    fig.tight_layout(rect=(0.0, 0.0, 0.72, 1.0))  # the right quarter holds the legends
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=suffix[1:])
    return series
