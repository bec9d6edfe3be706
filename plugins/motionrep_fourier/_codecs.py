"""The ``adaptive-fourier`` and ``naive-fourier`` codecs (Tojo et al. 2022, Algorithm 1 and §4.1)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Literal, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep.codec import Codec, EncodeContext, Payload
from motionrep.errors import BoundNotMetError, ParameterError

from ._network import Network, network_forward
from ._windows import Windows, join_windows, local_times, window_edges

__all__ = ["FourierParams", "AdaptiveFourierCodec", "NaiveFourierCodec", "MIN_SPLIT"]

#: A window that misses the bound is split in two while it spans at least twice this many frame steps.
MIN_SPLIT = 8


@dataclass(frozen=True)
class FourierParams:
    """Parameters shared by ``adaptive-fourier`` and ``naive-fourier``."""

    k: int | None = field(default=None, metadata={
        "help": "number of frequencies K (>= 0); default: the smallest K that meets --max-error, up to max_k"})
    max_k: int = field(default=24, metadata={
        "help": "largest K tried when k is not given; the codec fails cleanly if the bound is not met by then"})
    dtype: Literal["float32", "float16"] = field(default="float32", metadata={
        "help": "storage type of the weights (frequencies and output bias are always float32)"})
    iters: int = field(default=1000, metadata={
        "help": "most L-BFGS iterations per stage (per K)"})
    tol: float = field(default=0.01, metadata={
        "help": "a stage ends when the loss improved by less than this fraction over the last 100 iterations"})
    window: int = field(default=0, metadata={
        "help": "0: one network for the whole clip (the paper's Algorithm 1); N >= 8: the clip is cut into "
                "windows of about N frames (neighbours share a frame), each coded by its own network and "
                "frequencies within the same bound; a window that misses it is split in two (payload version 2)"})

    def __post_init__(self) -> None:
        if self.k is not None and (not isinstance(self.k, int) or self.k < 0):
            raise ParameterError(f"fourier: k must be an integer >= 0, got {self.k!r}")
        if not isinstance(self.max_k, int) or not 0 <= self.max_k <= 512:
            raise ParameterError(f"fourier: max_k must be an integer in [0, 512], got {self.max_k!r}")
        if self.dtype not in ("float32", "float16"):
            raise ParameterError(f"fourier: dtype must be float32 or float16, got {self.dtype!r}")
        if not isinstance(self.iters, int) or self.iters < 25:
            raise ParameterError(f"fourier: iters must be an integer >= 25, got {self.iters!r}")
        if not (0.0 <= self.tol < 1.0):
            raise ParameterError(f"fourier: tol must be in [0, 1), got {self.tol!r}")
        if not isinstance(self.window, int) or not (self.window == 0 or self.window >= 8):
            raise ParameterError(f"fourier: window must be 0 (whole clip) or an integer >= 8, got {self.window!r}")


class _FourierCodec(Codec):
    """Common encode/decode; subclasses choose the frequency schedule."""

    format_version = 2
    readable_versions = (1, 2)
    Params = FourierParams
    schedule: str

    def encode(self, features: NDArray[np.float64], weights: NDArray[np.float64],
               context: EncodeContext) -> Payload:
        params: FourierParams = context.params
        if params.k is None and context.bound is None:
            raise ParameterError(f"{self.name}: give k=K when there is no error bound (--max-error none)")
        from ._train import fit  # torch is imported here, never when decoding

        edges = window_edges(features.shape[0], params.window)
        if edges.size <= 2:
            return fit(features, weights, context, schedule=self.schedule, name=self.name)
        return self._encode_windows(features, weights, context, edges, fit)

    def _encode_windows(self, features: NDArray[np.float64], weights: NDArray[np.float64], context: EncodeContext,
                        edges: NDArray[np.int64], fit: Callable[..., Payload]) -> Payload:
        """Each window in turn; a window that cannot meet the bound is split at its middle frame and its halves
        are coded instead, down to :data:`MIN_SPLIT` frame steps (below that its error is final)."""
        todo = [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]
        done: list[tuple[int, int, Payload]] = []
        while todo:
            first, last = todo.pop(0)
            where = f"{self.name} (window of frames {first}-{last})"
            sub = _WindowContext(context, features, first, last)
            try:
                done.append((first, last, fit(features[first:last + 1], weights, sub, schedule=self.schedule,
                                              name=where)))
            except BoundNotMetError as exc:
                if last - first < 2 * MIN_SPLIT:
                    raise
                middle = (first + last) // 2
                context.progress("split", window=f"{first}-{last}", best_error=exc.best_error)
                todo[0:0] = [(first, middle), (middle, last)]
        joined = np.array([first for first, _, _ in done] + [done[-1][1]], dtype=np.int64)
        return join_windows([payload for _, _, payload in done], joined)

    def describe(self, info: Mapping[str, Any], detail: bool = False) -> str:
        """``K=5`` (with ``detail``: the frequencies and hidden width); in windows ``3 windows, K=4-6`` (with
        ``detail``: K per window)."""
        K = info.get("K")
        if isinstance(K, list):
            if not K:
                return f"{info.get('windows', 0)} windows"
            if detail:
                return f"{info.get('windows', len(K))} windows, K per window [{', '.join(map(str, K))}]"
            span = f"{min(K)}" if min(K) == max(K) else f"{min(K)}-{max(K)}"
            return f"{info.get('windows', len(K))} windows, K={span}"
        if K is None:
            return super().describe(info, detail)
        if not detail:
            return f"K={K}"
        omega = ", ".join(f"{o:g}" for o in info.get("omega", []))
        return f"K={K}, omega=[{omega}] cycles/clip, hidden {info.get('hidden')}"

    def warm_up(self) -> None:
        """Import torch and the adaptive codec's scipy modules: 3-6 s on the first encode of a process, which
        would otherwise be counted in the encode time of whichever clip comes first."""
        import scipy.fft  # noqa: F401  (the adaptive codec's DCT and line search)
        import scipy.optimize  # noqa: F401

        from . import _train  # noqa: F401  (imports torch)

    def decoder(self, payload: Payload) -> Network | Windows:
        """The payload's network (or windows of networks), converted once; decodes in float32."""
        if "edges" in payload.arrays:
            return Windows(payload.arrays)
        return Network(payload.arrays)

    def decode(self, payload: Payload, times: ArrayLike) -> NDArray[np.float64]:
        return self.decoder(payload)(times).astype(np.float64)


class _WindowContext:
    """The :class:`~motionrep.codec.EncodeContext` of one window: its frames' local times, and the shared
    evaluation of a candidate on the window's frames (``context.evaluate_frames``; frames are measured
    independently, so this is the error they have in the whole clip), or, from a context without it, on the
    whole clip with every other frame exact."""

    def __init__(self, context: EncodeContext, features: NDArray[np.float64], first: int, last: int):
        self._context, self._features, self._first, self._last = context, features, first, last
        self.params, self.bound, self.seed = context.params, context.bound, context.seed
        times = np.asarray(context.times, np.float64)[first:last + 1]
        self.times = local_times(times, features.shape[0], first, last)

    def evaluate(self, features: ArrayLike) -> Any:
        measure = getattr(self._context, "evaluate_frames", None)
        if measure is not None:  # only this window's frames
            return measure(np.asarray(features, np.float64), self._first)
        full = self._features.copy()
        full[self._first:self._last + 1] = features
        return self._context.evaluate(full)

    def evaluate_payload(self, payload: Payload) -> Any:
        return self.evaluate(network_forward(payload.arrays, self.times))

    def progress(self, stage: str, **fields: Any) -> None:
        self._context.progress(stage, window=f"{self._first}-{self._last}", **fields)


class AdaptiveFourierCodec(_FourierCodec):
    """Algorithm 1 of Tojo et al. (2022): frequency-adaptive Fourier-feature network.

    Starts with no frequency (``x = t``); after each training stage, if the shared L-infinity error of the stored
    payload is above the bound, the next frequency is the peak of the DCT (type II) of the first principal
    component of the ``w``-weighted residual, among those not yet used; the network grows to
    ``h = 2 (2K + 1)`` with the old weights copied so that its function is unchanged (warm start).

    Payload (format version 2; version 1 is read too): ``omega (K,)`` float32 (cycles over the clip, multiples
    of 1/2), ``W0 (h, 2K+1)``, ``b0 (h,)``, ``W1 (h, h)``, ``b1 (h,)``, ``W2 (D, h)`` in ``dtype``, ``b2 (D,)``
    float32; with ``window=N``, one such network per window of about ``N`` frames, in the layout of
    :func:`motionrep_fourier._windows.join_windows` (``specs/codecs.md``).
    """

    name = "adaptive-fourier"
    description = "Tojo et al. 2022 Algorithm 1: Fourier-feature MLP with DCT-chosen frequencies"
    schedule = "adaptive"


class NaiveFourierCodec(_FourierCodec):
    """The naive-frequency baseline of Tojo et al. (2022), §4.1: ``omega = 1, 2, ..., K`` cycles over the clip.

    Trained exactly like ``adaptive-fourier`` (same network, loss, optimiser, warm start from K - 1), so the two
    differ only in the choice of frequencies.  Payload as for ``adaptive-fourier``.
    """

    name = "naive-fourier"
    description = "Tojo et al. 2022 baseline: Fourier-feature MLP with frequencies 1..K"
    schedule = "naive"
