"""``keyframe``: keep every ``step``-th frame, interpolate linearly in between."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep.plugin.codec import Codec, EncodeContext, Payload
from motionrep.errors import BoundNotMetError, ParameterError

__all__ = ["KeyframeCodec", "KeyframeParams"]


@dataclass(frozen=True)
class KeyframeParams:
    """Parameters of the ``keyframe`` codec."""

    step: int = field(default=8, metadata={"help": "frames between keyframes (the largest tried when a bound "
                                                   "is given); >= 1"})

    def __post_init__(self) -> None:
        if self.step < 1:
            raise ParameterError(f"keyframe: step must be >= 1, got {self.step}")


def _keyframes(num_frames: int, step: int) -> NDArray[np.int64]:
    keys = np.arange(0, num_frames, step)
    return keys if keys[-1] == num_frames - 1 else np.append(keys, num_frames - 1)


class KeyframeCodec(Codec):
    """Stores the features of every ``step``-th frame and of the last frame as float32 (``keys (K, D)``) with
    their normalised times (``times (K,)`` float64); decodes by linear interpolation per feature.

    With an error bound, ``step`` is halved until the bound is met; at ``step`` 1 every frame is stored and
    only float32 rounding remains.
    """

    name = "keyframe"
    format_version = 1
    description = "example plugin: keyframes every `step` frames, linear interpolation"
    Params = KeyframeParams

    def encode(self, features: NDArray[np.float64], weights: NDArray[np.float64],
               context: EncodeContext) -> Payload:
        F = features.shape[0]
        step = min(context.params.step, max(F - 1, 1))
        best = None
        while True:
            keys = _keyframes(F, step)
            payload = Payload({"times": np.asarray(context.times, np.float64)[keys],
                               "keys": features[keys].astype(np.float32)},
                              {"step": int(step), "keyframes": int(keys.size)})
            if context.bound is None:
                return payload
            error = context.evaluate_payload(payload).max_error
            context.progress("search", step=step, error=error)
            best = error if best is None else min(best, error)
            if error <= context.bound:
                return payload
            if step == 1:
                raise BoundNotMetError(f"keyframe: even step 1 (every frame, float32) has error {best:.6g} "
                                       f"above the bound {context.bound:.6g}", best, context.bound)
            step = max(step // 2, 1)

    def describe(self, info: Mapping[str, Any], detail: bool = False) -> str:
        """How the outcome reads in every motionrep command (``bench``, ``info``, ``compress``): ``13 keyframes,
        step 4``."""
        return f"{info['keyframes']} keyframes, step {info['step']}"

    def decode(self, payload: Payload, times: ArrayLike) -> NDArray[np.float64]:
        key_t = np.asarray(payload.arrays["times"], np.float64)
        keys = np.asarray(payload.arrays["keys"], np.float64)
        t = np.clip(np.asarray(times, np.float64).reshape(-1), key_t[0], key_t[-1])
        if key_t.size == 1:
            return np.repeat(keys, t.size, axis=0)
        i = np.clip(np.searchsorted(key_t, t, side="right") - 1, 0, key_t.size - 2)
        a = ((t - key_t[i]) / (key_t[i + 1] - key_t[i]))[:, None]
        return (1.0 - a) * keys[i] + a * keys[i + 1]
