"""Frame rates, frame times and durations as people read them: one definition of a clip's duration and one way of
writing rates, used by ``motionrep info``, the reports of the commands, the viewer and the renders.

Duration: a clip of ``F`` frames at ``fps`` lasts ``F / fps`` seconds (:func:`duration`): each frame is shown for
one frame time, so 120 frames at 30 fps last 4 s, as :attr:`motionrep.Motion.duration` says.  The time *of* frame
``i`` is ``i / fps``, so the last frame starts one frame time before the end.  (A decoded runtime
:class:`motionrep.pipeline.runtime.Clip` samples poses from ``0`` to the time of its last frame, ``(F - 1) / fps``: that is
its playable *span*, not the clip's duration.)

Rates: a BVH file states a frame time (``Frame Time: 0.008333``), not a rate, so a motion read from it holds
``fps = 1 / 0.008333 = 120.0048...``.  :func:`frame_time_text` gives back the frame time as the file wrote it (the
shortest decimal that reads back to the same number) and :func:`fps_text` the rate with the fewest decimals that
this frame time allows (``120``: every rate in ``[1 / 0.0083335, 1 / 0.0083325]`` is what the file says), so no
report shows ``120.005`` for a file that means 120.  A rate stored as a number (NPZ, HDF5, glTF) is treated the same
way: ``30.0`` is ``30`` and ``29.97`` stays ``29.97``.
"""

from __future__ import annotations

import math

from ..errors import ValidationError

__all__ = ["duration", "frame_time_text", "fps_text", "rate_text", "seconds_text", "duration_text", "frame_time"]


def _check(fps: float) -> float:
    try:
        value = float(fps)
    except (TypeError, ValueError):
        raise ValidationError(f"a frame rate must be a number, got {fps!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise ValidationError(f"a frame rate must be a positive number, got {fps!r}")
    return value


def duration(num_frames: int, fps: float) -> float:
    """Seconds a clip of ``num_frames`` frames at ``fps`` lasts: ``num_frames / fps`` (each frame lasts one frame
    time; 0 for no frames)."""
    return max(0, int(num_frames)) / _check(fps)


def _shortest(value: float, digits: int = 15) -> tuple[str, int]:
    """The shortest ``%g`` text (at most ``digits`` significant digits) that reads back to ``value`` within a
    few ulps, and its number of significant digits."""
    for d in range(1, digits + 1):
        text = f"{value:.{d}g}"
        if abs(float(text) - value) <= 8 * math.ulp(value):
            return text, d
    return f"{value:.{digits}g}", digits


def frame_time(fps: float) -> float:
    """The frame time ``1 / fps`` in seconds as a file would state it: the shortest decimal that gives ``fps``
    back (``120.0048...`` from ``Frame Time: 0.008333`` gives ``0.008333``)."""
    return float(_shortest(1.0 / _check(fps))[0])


def frame_time_text(fps: float) -> str:
    """The frame time in seconds, as the file states it (``"0.008333"``), at most 7 significant digits
    (``"0.03333333"`` for a rate stored as 30)."""
    text, _ = _shortest(1.0 / _check(fps), 7)
    if "e" in text:  # never 8.333e-03 for a frame time
        text = f"{float(text):.15f}".rstrip("0").rstrip(".")
    return text


def fps_text(fps: float) -> str:
    """The frame rate with the fewest decimals the stated frame time allows: ``"120"`` for a frame time of
    0.008333 s, ``"30"``, ``"29.97"``, ``"23.976"``; at most 3 decimals."""
    value = _check(fps)
    ft, digits = _shortest(1.0 / value)
    t = float(ft)
    # the frame times that print as `ft`: half a unit of its last significant digit either side
    half = 0.5 * 10.0 ** (math.floor(math.log10(t)) - digits + 1)
    low, high = 1.0 / (t + half), 1.0 / (t - half) if t > half else math.inf
    for decimals in range(0, 4):
        candidate = round(value, decimals)
        if low <= candidate <= high:
            return f"{candidate:.{decimals}f}"
    return f"{value:.3f}".rstrip("0").rstrip(".")


def rate_text(fps: float) -> str:
    """``"120 fps (frame time 0.008333 s)"``."""
    return f"{fps_text(fps)} fps (frame time {frame_time_text(fps)} s)"


def seconds_text(seconds: float) -> str:
    """Seconds to the millisecond, trailing zeros dropped: ``"7.375 s"``, ``"4 s"``, ``"0.5 s"``; long spans
    from 100 s on also in minutes: ``"754.2 s (12 min 34.2 s)"``."""
    s = float(seconds)
    if not math.isfinite(s):
        raise ValidationError(f"a time must be a finite number of seconds, got {seconds!r}")
    text = f"{s:.3f}".rstrip("0").rstrip(".")
    if text == "-0":
        text = "0"
    if s >= 100:
        minutes, rest = divmod(round(s, 3), 60)
        text += f" s ({int(minutes)} min {f'{rest:.3f}'.rstrip('0').rstrip('.')}"
    return text + " s" + (")" if s >= 100 else "")


def duration_text(num_frames: int, fps: float) -> str:
    """The duration of a clip (:func:`duration`) as :func:`seconds_text` writes it."""
    return seconds_text(duration(num_frames, fps))
