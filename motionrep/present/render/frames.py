"""Which frames a rendering shows, and at what rate: frame selections and sizes as given on the command line,
frames picked by time so an animation plays in real time, evenly spaced filmstrip panels (the worst frame
always among them)."""

from __future__ import annotations

import math
import re
from typing import Sequence

import numpy as np
from numpy.typing import NDArray

from ...errors import Note, ValidationError, naming

__all__ = ["GIF_DEFAULT_FPS", "GIF_MAX_FPS", "MP4_DEFAULT_FPS", "MIN_SIDE", "MAX_SIDE", "parse_frames", "parse_size",
           "check_size", "select_frames", "animation_frames", "filmstrip_frames"]

#: Default playback-rate cap: GIF delays are whole centiseconds and browsers slow down anything under 2 cs,
#: so 25 fps (4 cs) is exact and plays everywhere.
GIF_DEFAULT_FPS = 25.0
GIF_MAX_FPS = 50.0
MP4_DEFAULT_FPS = 30.0
MIN_SIDE, MAX_SIDE = 64, 8192


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
    check_size((w, h))
    return w, h


def check_size(size: Sequence[int]) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in size)
    except (TypeError, ValueError):
        raise ValidationError(f"size must be (width, height) in pixels, got {size!r}") from None
    if not (MIN_SIDE <= w <= MAX_SIDE and MIN_SIDE <= h <= MAX_SIDE):
        raise ValidationError(f"size {w}x{h} is out of range: width and height must be {MIN_SIDE}..{MAX_SIDE} "
                              "pixels")
    return w, h


def select_frames(frames: slice | str | None, num_frames: int, name: str) -> tuple[NDArray[np.int64], bool]:
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
        shown = slice_text(sl)
        raise ValidationError(f"frame selection {shown!r} selects no frames of the {num_frames} in {name} "
                              f"(valid frames 0..{num_frames - 1})")
    return idx.astype(np.int64), sl.step is not None


def slice_text(sl: slice) -> str:
    parts = ["" if sl.start is None else str(sl.start), "" if sl.stop is None else str(sl.stop)]
    if sl.step is not None:
        parts.append(str(sl.step))
    return ":".join(parts)


def pick_by_time(selected: NDArray[np.int64], clip_fps: float, rate: float) -> NDArray[np.int64]:
    """The selected frames nearest to the times ``k / rate`` (``rate`` below the clip's rate)."""
    n = int(math.floor((selected.size - 1) * rate / clip_fps + 1e-9)) + 1
    pick = np.rint(np.arange(n) * (clip_fps / rate)).astype(np.int64)
    return selected[np.minimum(pick, selected.size - 1)]


def animation_frames(selected: NDArray[np.int64], exact: bool, clip_fps: float, fps: float | None,
                     max_frames: int, kind: str, worst_frame: int | None = None
                     ) -> tuple[NDArray[np.int64], float, list[str]]:
    """Frames to show and the playback rate.

    Exact selections (an explicit step) are shown frame by frame at ``fps``.  Otherwise frames are picked by
    time so the animation plays in real time at ``fps``; the rate drops if that would exceed ``max_frames``; the
    worst frame, when it is in the selection, always replaces the frame picked nearest to it (an exact selection
    that leaves it out says so in a note).
    """
    shown, rate, notes = frames_and_rate(selected, exact, clip_fps, fps, max_frames, kind)
    if worst_frame is not None and selected[0] <= worst_frame <= selected[-1] and worst_frame not in shown:
        if exact:
            notes.append(Note(f"the worst frame, {worst_frame}, is not among the frames that frames= selects",
                              "frames="))
        else:
            shown = shown.copy()
            shown[int(np.argmin(np.abs(shown - worst_frame)))] = worst_frame
            shown = np.unique(shown)
    return shown, rate, notes


def frames_and_rate(selected: NDArray[np.int64], exact: bool, clip_fps: float, fps: float | None,
                    max_frames: int, kind: str) -> tuple[NDArray[np.int64], float, list[str]]:
    """Frames picked by time (or exactly, with a step) and the playback rate, without the worst-frame rule."""
    notes: list[str] = []
    cap = GIF_DEFAULT_FPS if kind == ".gif" else MP4_DEFAULT_FPS
    if exact:
        if selected.size > max_frames:
            raise naming(ValidationError(f"the frame selection has {selected.size} frames, more than "
                                         f"max_frames={max_frames}: use a larger step or raise max_frames"),
                         "max_frames=", "max_frames")
        step = int(selected[1] - selected[0]) if selected.size > 1 else 1
        rate = fps if fps is not None else representable(min(clip_fps / step, cap), kind)
        return selected, rate, notes
    rate = fps if fps is not None else representable(min(clip_fps, cap), kind)
    if rate >= clip_fps:
        shown = selected
        if rate > clip_fps * (1 + 1e-9):
            notes.append(f"every frame shown at {rate:g} fps: {rate / clip_fps:.3g}x faster than real time")
    else:
        shown = pick_by_time(selected, clip_fps, rate)
    if shown.size > max_frames:
        rate = representable(max_frames / (selected.size / clip_fps), kind)
        shown = pick_by_time(selected, clip_fps, rate)
        notes.append(Note(f"showing {shown.size} of {selected.size} frames at {rate:.3g} fps, in real time "
                          f"(max_frames={max_frames})", "max_frames="))
    return shown, rate, notes


def representable(rate: float, kind: str) -> float:
    """The largest playback rate <= ``rate`` that the format stores exactly (GIF: 100 / whole centiseconds)."""
    if kind != ".gif":
        return rate
    return 100.0 / math.ceil(100.0 / rate - 1e-9)


def filmstrip_frames(selected: NDArray[np.int64], exact: bool, count: int, max_frames: int,
                      worst_frame: int | None) -> NDArray[np.int64]:
    if exact:
        if selected.size > max_frames:
            raise naming(ValidationError(f"the frame selection has {selected.size} frames, more than "
                                         f"max_frames={max_frames}: use a larger step or raise max_frames"),
                         "max_frames=", "max_frames")
        return selected
    n = min(count, selected.size)
    pick = selected[np.rint(np.linspace(0, selected.size - 1, n)).astype(np.int64)]
    if worst_frame is not None and selected[0] <= worst_frame <= selected[-1] and worst_frame not in pick:
        # the nearest panel shows the worst frame instead, so the strip always contains it
        pick[int(np.argmin(np.abs(pick - worst_frame)))] = worst_frame
    return np.unique(pick)
