"""glTF reading, part 2: animations.  Which animations make a clip, their translation / rotation / scale channels,
the frame rate and frame times of a clip, and each channel sampled at them (STEP, LINEAR, CUBICSPLINE)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterable, Iterator

import numpy as np
from numpy.typing import NDArray

from .. import limits
from ..errors import MotionrepError
from ._gltf_doc import Doc, get, is_int, number, short

__all__ = ["Track", "clips", "tracks", "sample", "frame_times", "Unique"]

_KEYFRAME_RATES = (24.0, 25.0, 30.0, 48.0, 50.0, 60.0, 100.0, 120.0)
_PATHS = {"translation": 3, "rotation": 4, "scale": 3}


class Unique:
    """Names made unique in linear time: ``name``, or ``name.001``, ``name.002``... the first not taken.

    Each base name remembers the next number to try, so 100,000 nodes all named ``a`` take 100,000 steps, not
    5 x 10^9 (a name taken by the file itself, ``a.001`` beside ``a``, is skipped once).
    """

    def __init__(self, taken: Iterable[str] = ()):
        self.taken: set[str] = set(taken)
        self._next: dict[str, int] = {}

    def __call__(self, name: str) -> str:
        out, k = name, self._next.get(name, 1)
        if out in self.taken:
            out = f"{name}.{k:03d}"
            while out in self.taken:
                k += 1
                out = f"{name}.{k:03d}"
            self._next[name] = k + 1
        self.taken.add(out)
        return out


@dataclass
class Track:
    """One animation channel: key times, values, interpolation."""

    times: NDArray[np.float64]
    values: NDArray[np.float64]  # (K, width), or (3K, width) for CUBICSPLINE
    interpolation: str


def clips(doc: Doc) -> list[tuple[str, list[int]]]:
    """The clips of a file: ``(name, animation indices)``.

    Each named animation is a clip (unnamed ones are ``animation0``, ``animation1``...), except that unnamed
    animations that animate different nodes are parts of one clip, ``animation`` (COLLADA2GLTF and other
    converters write one animation per joint).
    """
    unnamed: list[int] = []
    for k, anim in enumerate(doc.animations):
        doc.item(doc.animations, k, "animation")
        raw = get(anim, "name")
        if not (isinstance(raw, str) and raw.strip()):
            unnamed.append(k)
    if len(unnamed) > 1 and len(unnamed) == len(doc.animations):
        targets: list[int] = []
        for k in unnamed:
            for channel in doc.list(doc.animations[k], "channels"):
                node = get(get(channel, "target"), "node")
                targets.append(node if is_int(node) else -1 - len(targets))
        if len(set(targets)) == len(targets):
            return [("animation", unnamed)]
    names: list[tuple[str, list[int]]] = []
    unique_name = Unique()
    for k, anim in enumerate(doc.animations):
        raw = get(anim, "name")
        base = raw.strip() if isinstance(raw, str) and raw.strip() else f"animation{k}"
        names.append((unique_name(base), [k]))
    return names


def _channels(doc: Doc, indices: list[int]) -> Iterator[tuple[int, int, Any, list]]:
    for index in indices:
        anim = doc.item(doc.animations, index, "animation")
        samplers = doc.list(anim, "samplers")
        for c, channel in enumerate(doc.list(anim, "channels")):
            yield index, c, channel, samplers


def tracks(doc: Doc, indices: list[int]) -> dict[tuple[int, str], Track]:
    """The translation, rotation and scale channels of the animations ``indices``, by (node, path)."""
    out: dict[tuple[int, str], Track] = {}
    made: dict[tuple[int, int, str], Track] = {}  # channels sharing a sampler share its track
    increasing: set[int] = set()  # input accessors whose key times were checked
    for index, c, channel, samplers in _channels(doc, indices):
        what = f"animation {index}, channel {c}"
        target = get(channel, "target")
        if not isinstance(target, dict):
            raise doc.fail(f"{what} has no target")
        path, node = get(target, "path"), get(target, "node")
        if not isinstance(path, str):
            if path is None:
                continue
            raise doc.fail(f"{what}: target path must be a string, got {short(path)}")
        if path not in _PATHS or node is None:
            continue  # morph weights, KHR_animation_pointer: not skeleton motion
        if not is_int(node) or not 0 <= node < len(doc.nodes):
            raise doc.fail(f"{what} targets node {short(node)}, which does not exist")
        s = get(channel, "sampler")
        sampler = doc.item(samplers, s, f"{what}: sampler")
        track = made.get((index, s, path))
        if track is None:
            interpolation = get(sampler, "interpolation", "LINEAR")
            if not isinstance(interpolation, str) or interpolation not in ("LINEAR", "STEP", "CUBICSPLINE"):
                raise doc.fail(f"{what}: unknown interpolation {short(interpolation)}")
            source = get(sampler, "input")
            times = doc.accessor(source, f"{what} input", (1,))[:, 0]
            if source not in increasing:
                if np.any(np.diff(times) < 0):
                    raise doc.fail(f"{what}: key times decrease (they must increase)")
                increasing.add(source)
            width = _PATHS[path]
            values = doc.accessor(get(sampler, "output"), f"{what} output", (width,),
                                  normalized_ok=path == "rotation")
            need = times.size * (3 if interpolation == "CUBICSPLINE" else 1)
            if values.shape[0] != need:
                raise doc.fail(f"{what}: {times.size} key times but {values.shape[0]} values (expected {need})")
            track = made[(index, s, path)] = Track(times, values, interpolation)
        out[(int(node), path)] = track
    return out


def sample(track: Track, times: NDArray[np.float64], rotation: bool, snap: float) -> NDArray[np.float64]:
    """The track's values at ``times`` (held before the first and after the last key)."""
    from ..model.rotations import quat_slerp

    keys, cubic = track.times, track.interpolation == "CUBICSPLINE"
    values = track.values[1::3] if cubic else track.values
    K = keys.size
    k = np.clip(np.searchsorted(keys, times, side="right") - 1, 0, K - 1)
    nxt = np.minimum(k + 1, K - 1)
    span = keys[nxt] - keys[k]
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.where(span > 0, (times - keys[k]) / np.where(span > 0, span, 1.0), 0.0)
    s = np.clip(s, 0.0, 1.0)
    s = np.where(np.abs(times - keys[k]) <= snap, 0.0, s)  # a frame time on a key takes the key exactly
    s = np.where(np.abs(times - keys[nxt]) <= snap, 1.0, s)
    on_keys = bool(np.all((s == 0.0) | (s == 1.0)))  # baked files: every frame is a key, nothing to interpolate
    if track.interpolation == "STEP" or on_keys:
        out = values[np.where(s >= 1.0, nxt, k)]
    elif cubic:
        a, b = track.values[0::3], track.values[2::3]  # in- and out-tangents
        s2, s3 = s * s, s * s * s
        w = [2 * s3 - 3 * s2 + 1, (s3 - 2 * s2 + s) * span, -2 * s3 + 3 * s2, (s3 - s2) * span]
        out = (w[0][:, None] * values[k] + w[1][:, None] * b[k] + w[2][:, None] * values[nxt]
               + w[3][:, None] * a[nxt])
    elif rotation:
        out = quat_slerp(values[k], values[nxt], s)
    else:
        out = (1 - s)[:, None] * values[k] + s[:, None] * values[nxt]
    if rotation:
        norm = np.linalg.norm(out, axis=-1, keepdims=True)
        if np.any(norm < 1e-6):
            raise MotionrepError("zero quaternion")
        out = out / norm
    return out


def frame_times(doc: Doc, tracks: list[Track], fps_hint: Any, where: str, joints: int = 0
                ) -> tuple[float, NDArray[np.float64]]:
    """The clip's frame rate and frame times.

    motionrep's own files say their rate.  Otherwise the densest channel's median key step gives it (exporters
    bake one key per frame), rounded to a whole rate within 0.1 %; keys sparser than 24 per second are an
    animator's keyframes, sampled at the first of 24, 25, 30, 48, 50, 60, 100, 120 fps on whose frames every key
    falls (30 fps if none).
    """
    t0 = float(min(t.times[0] for t in tracks))
    t1 = float(max(t.times[-1] for t in tracks))
    distinct = list({id(t.times): t.times for t in tracks}.values())  # channels may share one input
    densest = max(distinct, key=lambda t: t.size)
    if fps_hint is not None:  # motionrep's own file: one key per frame on every channel it wrote
        fps = number(fps_hint)
        if fps is None or not fps > 0 or not math.isfinite(1.0 / fps):
            raise doc.fail(f"{where}: extras.motionrep.fps {short(fps_hint)} is not a frame rate (a positive "
                           "number with a finite frame time)")
        span = (t1 - t0) * fps
        frames = int(round(span)) + 1 if math.isfinite(span) else None
        if densest.size > 1 and frames != densest.size:
            raise doc.fail(f"{where}: extras.motionrep.fps {fps:g} gives {frames or 'too many'} frames over "
                           f"{t1 - t0:.6g} s, but its channels hold {densest.size} keys (one per frame)")
    else:
        steps = np.diff(densest)
        steps = steps[steps > 0]
        fps = 30.0
        if steps.size:
            fps = 1.0 / float(np.median(steps))
            near = round(fps)
            fps = float(near) if near > 0 and abs(fps - near) <= 1e-3 * fps else float(f"{fps:.6g}")
            if fps < 24.0:
                keys = np.concatenate(distinct) - t0
                fps = next((r for r in _KEYFRAME_RATES if np.all(np.abs(keys * r - np.rint(keys * r)) <= 1e-3)),
                           30.0)
    lim = limits.current()
    span = (t1 - t0) * fps
    keys = sum(t.size for t in distinct)
    if not math.isfinite(span) or span > 256 * keys + 16:
        raise doc.fail(f"{where}: {t1 - t0:.6g} s at {fps:g} fps would be {span:.6g} frames from {keys} keys; "
                       "the key times are too sparse or uneven to sample")
    frames = int(round(span)) + 1
    if frames > lim.max_frames:
        raise doc.fail(f"{where}: {t1 - t0:.6g} s at {fps:g} fps is {frames} frames, more than the limit of "
                       f"{lim.max_frames} (raise {limits.ENVIRONMENT['max_frames']} to read it)")
    reason = limits.check_clip(frames, where, joints=joints, translated=joints)
    if reason:
        raise doc.fail(reason)
    return fps, t0 + np.arange(frames) / fps
