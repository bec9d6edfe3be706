"""The ``adaptive-fourier`` and ``naive-fourier`` codecs (Tojo et al. 2022, Algorithm 1 and §4.1)."""

from __future__ import annotations

import contextlib
from functools import partial
from dataclasses import dataclass, field
from typing import Any, Callable, Literal, Mapping, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep.plugin.codec import Codec, EncodeContext, Payload, check_decode_work, check_info_numbers
from motionrep.errors import BoundNotMetError, ParameterError, PayloadError, naming

from ._network import Network, network_dtype
from ._packed import declared, dequantized, unpack
from ._windows import Windows, join_windows, window_edges
from ._workers import Runner, Task, WindowJob, worker_count

__all__ = ["FourierParams", "AdaptiveFourierCodec", "NaiveFourierCodec", "MIN_SPLIT", "AUTO_WINDOW",
           "AUTO_LONGEST", "AUTO_MAX_K"]

#: A window that misses the bound is split in two while it spans at least twice this many frame steps.
MIN_SPLIT = 8
#: ``window`` unset: a clip of up to ``2 AUTO_LONGEST`` frame steps is coded as one window, a longer one in
#: windows of at most ``AUTO_LONGEST`` steps...
AUTO_LONGEST = 250
#: ... each with at most ``AUTO_MAX_K`` frequencies while it is longer than ``AUTO_WINDOW`` steps (a window
#: that needs more is split in two; one of up to ``AUTO_WINDOW`` steps may use up to ``max_k``).
AUTO_MAX_K = 10
AUTO_WINDOW = 125

_SVD_HINT = "or use codec=svd (it meets any bound)"
#: Integer outcome keys and the levels of arrays each may have (per window in windows): ``Codec.check_info``.
_INFO_INTEGERS = {"K": (0, 1), "hidden": (0, 1), "windows": (0, 0), "iterations": (0, 0), "parameters": (0, 0),
                  "steps": (1, 2)}


@dataclass(frozen=True)
class FourierParams:
    """Parameters shared by ``adaptive-fourier`` and ``naive-fourier``."""

    k: int | None = field(default=None, metadata={
        "help": "number of frequencies K (>= 0); default: the smallest K that meets the bound (max_error), up to max_k"})
    max_k: int = field(default=24, metadata={
        "help": "largest K tried when k is not given; the codec fails cleanly if the bound is not met by then"})
    dtype: Literal["quantised", "float32", "float16"] = field(default="quantised", metadata={
        "help": "storage of the weights: quantised (integers times a step per layer, the steps chosen under the "
                "bound, range-coded, one probability model per layer or per row or column of a layer; payload version "
                "4) or the paper's raw layout, float32 or float16 weights "
                "(frequencies and output bias float32)"})
    iters: int = field(default=1000, metadata={
        "help": "most L-BFGS iterations per stage (per K)"})
    tol: float = field(default=0.01, metadata={
        "help": "a stage ends when the loss improved by less than this fraction over the last 100 iterations"})
    window: int | None = field(default=None, metadata={
        "help": "none: chosen by measurement (a clip of up to 500 frames whole, a longer one in windows of "
                "about 250; a window that needs more than 10 frequencies is split in two, down to 125 frames); "
                "0: one network for the whole clip (the paper's Algorithm 1); N >= 8: windows of about N frames "
                "(neighbours share a frame), each coded by its own network and frequencies within the same bound; "
                "a window that misses it is split in two (payload version 2)"})
    jobs: int = field(default=0, metadata={
        "help": "processes that code windows side by side (the result is the same for any number); 0: one per "
                "CPU this process may use (1 inside a worker process of a batch)"})

    def __post_init__(self) -> None:
        if self.k is not None and (not isinstance(self.k, int) or self.k < 0):
            raise ParameterError(f"fourier: k must be an integer >= 0, got {self.k!r}")
        if not isinstance(self.max_k, int) or not 0 <= self.max_k <= 512:
            raise ParameterError(f"fourier: max_k must be an integer in [0, 512], got {self.max_k!r}")
        if self.dtype not in ("quantised", "float32", "float16"):
            raise ParameterError(f"fourier: dtype must be quantised, float32 or float16, got {self.dtype!r}")
        if not isinstance(self.iters, int) or self.iters < 25:
            raise ParameterError(f"fourier: iters must be an integer >= 25, got {self.iters!r}")
        if not (0.0 <= self.tol < 1.0):
            raise ParameterError(f"fourier: tol must be in [0, 1), got {self.tol!r}")
        if self.window is not None and (not isinstance(self.window, int) or not (self.window == 0
                                                                                 or self.window >= 8)):
            raise ParameterError(f"fourier: window must be none (chosen by measurement), 0 (whole clip) or an "
                                 f"integer >= 8, got {self.window!r}")
        if not isinstance(self.jobs, int) or not 0 <= self.jobs <= 256:
            raise ParameterError(f"fourier: jobs must be an integer in [0, 256], got {self.jobs!r}")


class _FourierCodec(Codec):
    """Common encode/decode; subclasses choose the frequency schedule."""

    format_version = 4
    readable_versions = (1, 2, 3, 4)
    min_frames = 2  # a function of time fitted to one frame has no time axis (the times normalise by frames - 1)
    Params = FourierParams
    schedule: str

    def encode(self, features: NDArray[np.float64], weights: NDArray[np.float64],
               context: EncodeContext) -> Payload:
        params: FourierParams = context.params
        if params.k is None and context.bound is None:
            raise naming(ParameterError(f"{self.name}: give k=K when there is no error bound (max_error=None)"),
                         "max_error=None")
        from ._train import clip_scale, fit  # the training code is imported here, never when decoding

        scale = clip_scale(features, weights)  # one output scale for every window

        if params.window == 0:  # the paper's Algorithm 1: one network
            try:
                return fit(features, weights, context, schedule=self.schedule, name=self.name, scale=scale)
            except BoundNotMetError as exc:
                if params.k is not None:
                    raise
                raise naming(BoundNotMetError(
                    f"{exc}; raise max_k, or code the clip in windows (leave window unset to let the codec choose, "
                    f"or params window={AUTO_WINDOW}), {_SVD_HINT}", exc.best_error, exc.bound),
                    "params window=", "codec=") from None
        if params.window is None:  # chosen by measurement: long windows where few frequencies do, else halves
            steps = features.shape[0] - 1
            edges = window_edges(features.shape[0], steps if steps <= 2 * AUTO_LONGEST else AUTO_LONGEST)

            def max_k(first: int, last: int) -> int:
                return min(params.max_k, AUTO_MAX_K) if last - first > AUTO_WINDOW else params.max_k
        else:
            edges = window_edges(features.shape[0], params.window)

            def max_k(first: int, last: int) -> int:
                return params.max_k
        plan = _Plan(self, features, weights, context, partial(fit, scale=scale), max_k)
        pieces = plan.code([(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])])
        if len(pieces) == 1:
            return pieces[0].payload
        edges = np.array([p.first for p in pieces] + [pieces[-1].last], dtype=np.int64)
        return join_windows([p.payload for p in pieces], edges)

    def check_info(self, info: Mapping[str, Any]) -> None:
        """The outcome of one network or, in windows, of each (``specs/codecs.md``): integer counts, one per
        window for ``K`` and ``hidden``; ``omega`` an array of numbers, per window in windows; ``steps`` an
        array of integers, per window in windows."""
        for key, arrays in _INFO_INTEGERS.items():
            check_info_numbers(info, key, integers=True, arrays=arrays)
        check_info_numbers(info, "omega", arrays=(1, 2))

    def check_payload(self, payload: Payload, num_frames: int) -> None:
        """The window edges a payload declares (the quantised head, or the float ``edges``) must start at 0,
        increase and end at the clip's last frame ``num_frames - 1``; the declared work, frames x network size
        per window (``h (2K + 2) + h (h + 1) + D (h + 1)`` multiply-adds per frame, ``h = 2 (2K + 1)``), within
        ``max_decode_work`` (``specs/limits.md``).  Reads the head only."""
        arrays = payload.arrays
        if "data" in arrays:
            edges, K, D = declared(np.asarray(arrays["data"]), self.payload_version(payload))
            hidden = 2 * (2 * K + 1)
        elif "edges" in arrays:
            edges = np.asarray(arrays["edges"]).astype(np.int64).reshape(-1)
            K = np.asarray(arrays["k"]).astype(np.int64).reshape(-1)
            b2 = np.asarray(arrays["b2"])
            if edges.size < 2 or K.size != edges.size - 1 or b2.ndim != 2 or np.any(K < 0) or np.any(K > 1 << 16):
                raise PayloadError(f"windowed payload: {edges.size} edges for {K.size} windows")
            D, hidden = int(b2.shape[1]), 2 * (2 * K + 1)
        else:  # one float network: no frame count stored; the work is the clip's frames x its size
            K = np.array([np.asarray(arrays["omega"]).size], np.int64)
            hidden = np.array([np.asarray(arrays["b0"]).shape[0] if np.asarray(arrays["b0"]).ndim else 0])
            D = int(np.asarray(arrays["b2"]).size)
            edges = np.array([0, max(num_frames - 1, 1)], np.int64)
        if edges[0] != 0 or np.any(np.diff(edges) < 1):
            raise PayloadError(f"window edges must start at frame 0 and increase, got {edges[:8].tolist()}"
                               + (" ..." if edges.size > 8 else ""))
        last = int(edges[-1])
        if last != num_frames - 1 and not (num_frames == 1 and edges.size == 2):
            raise PayloadError(f"window edges end at frame {last} ({last + 1} frames), the clip (metadata "
                               f"num_frames) has {num_frames} frames")
        frames = np.diff(edges) + 1  # Python integers below: no overflow
        per_frame = [int(h) * (2 * int(k) + 2) + int(h) * (int(h) + 1) + int(D) * (int(h) + 1)
                     for h, k in zip(hidden.tolist(), K.tolist())]
        work = sum(int(f) * c for f, c in zip(frames.tolist(), per_frame))
        check_decode_work(work, payload, f"a payload of {edges.size - 1} window(s) over {num_frames} frames")

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
        """Import the training code and the scipy and threadpoolctl modules it uses, so that the first encode of
        a process is not charged for them."""
        from . import _train  # noqa: F401  (scipy.fft, scipy.linalg.lapack, threadpoolctl)

    def decoder(self, payload: Payload) -> Network | Windows:
        """The payload's network (or windows of networks), converted once (a quantised payload range-decoded
        and dequantised once; versions 3 and 4 alike); decodes in float32, or in float64 for payload versions 1 and 2
        (``_network.network_dtype``: what those files were measured in when they were written)."""
        version = self.payload_version(payload)
        dtype = network_dtype(version)
        if "data" in payload.arrays:
            edges, scale, networks = unpack(payload.arrays["data"], version)
            arrays = [dequantized(n, scale) for n in networks]
            if len(arrays) == 1:
                return Network(arrays[0], dtype=dtype)
            return Windows(networks=(edges, arrays), dtype=dtype)
        if "edges" in payload.arrays:
            return Windows(payload.arrays, dtype=dtype)
        return Network(payload.arrays, dtype=dtype)

    def decode(self, payload: Payload, times: ArrayLike) -> NDArray[np.float64]:
        return self.decoder(payload)(times).astype(np.float64)


class _Piece(NamedTuple):
    """A coded window: frames ``first .. last`` and their payload."""

    first: int
    last: int
    payload: Payload


class _Plan:
    """Codes a clip in windows, in worker processes; a window that misses the bound is split in two."""

    def __init__(self, codec: _FourierCodec, features: NDArray[np.float64], weights: NDArray[np.float64],
                 context: EncodeContext, fit: Callable[..., Payload], max_k: Callable[[int, int], int]):
        self.codec, self.features, self.weights, self.context, self.fit = codec, features, weights, context, fit
        self.max_k = max_k

    def task(self, first: int, last: int) -> Task:
        return Task(first, last, self.max_k(first, last))

    def code(self, spans: list[tuple[int, int]]) -> list[_Piece]:
        """Each window coded; one that cannot meet the bound is split at its middle frame and its halves are
        coded instead, down to :data:`MIN_SPLIT` frame steps (below that its error is final and the earliest
        such window is raised, once every window before it is coded or failed too, so that it is the same
        window for any number of processes).  Returns the coded windows in order."""
        done: dict[int, _Piece] = {}
        final: dict[int, BoundNotMetError] = {}
        run = Runner(WindowJob(self.codec.name, self.codec.schedule, self.features, self.weights, self.context,
                               self.fit), worker_count(self.context.params.jobs, len(spans)))
        with contextlib.closing(run([self.task(a, b) for a, b in spans])) as outcomes:
            for task, outcome in outcomes:
                first, last = task.first, task.last
                if isinstance(outcome.result, Payload):
                    done[first] = _Piece(first, last, outcome.result)
                    self.context.progress("window", window=f"{first}-{last}", K=outcome.result.info["K"],
                                          windows_done=len(done))
                elif last - first < 2 * MIN_SPLIT:
                    final[first] = outcome.result
                    run.drop_from(first)  # the encoding fails: only earlier windows are still coded
                else:
                    middle = (first + last) // 2
                    self.context.progress("split", window=f"{first}-{last}", best_error=outcome.result.best_error)
                    run.submit([self.task(first, middle), self.task(middle, last)])
        if final:
            exc = final[min(final)]
            raise naming(BoundNotMetError(f"{exc}; raise max_k or the bound, {_SVD_HINT}", exc.best_error,
                                          exc.bound), "codec=") from None
        return [done[first] for first in sorted(done)]


class AdaptiveFourierCodec(_FourierCodec):
    """Algorithm 1 of Tojo et al. (2022): frequency-adaptive Fourier-feature network.

    Starts with no frequency (``x = t``); after each training stage, if the shared L-infinity error of the stored
    payload is above the bound, the next frequency is the peak of the DCT (type II) of the first principal
    component of the ``w``-weighted residual, among those not yet used; the network grows to
    ``h = 2 (2K + 1)`` with the old weights copied so that its function is unchanged (warm start).

    Payload (format version 4; versions 1 to 3 are read too): with ``dtype=quantised`` (the default) one
    ``data`` array of range-coded integer networks (:mod:`motionrep_fourier._packed`); with ``float32`` or
    ``float16`` the paper's raw layout, ``omega (K,)`` float32 (cycles over the clip, multiples of 1/2),
    ``W0 (h, 2K+1)``, ``b0 (h,)``, ``W1 (h, h)``, ``b1 (h,)``, ``W2 (D, h)`` in ``dtype``, ``b2 (D,)`` float32;
    in windows, one network per window, in the layout of :func:`motionrep_fourier._windows.join_windows`
    (``specs/codecs.md``).
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
