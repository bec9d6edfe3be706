"""Windowed Fourier payloads (payload version 2): a clip cut into windows, one network per window.

Window ``s`` covers frames ``edges[s] .. edges[s + 1]`` (inclusive; neighbours share their boundary frame) and
its network sees the local time ``tau = (x - edges[s]) / (edges[s + 1] - edges[s])`` in [0, 1], where
``x = t (F - 1)`` is the frame position of the clip time ``t``. A time is decoded by the window it falls in,
a shared boundary frame by the later window (both windows were measured on it). No torch.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep.plugin.codec import Payload

from ._network import Networks
from ._packed import pack, unpack

__all__ = ["window_edges", "local_times", "window_of", "join_windows", "split_windows", "windows_forward", "Windows"]


def window_edges(num_frames: int, window: int) -> NDArray[np.int64]:
    """``(S + 1,)`` frame boundaries of ``S = ceil((F - 1) / window)`` windows of about equal length (at most
    ``window`` frame steps each); ``[0, F - 1]`` (one window) when ``window`` is 0 or covers the clip."""
    steps = num_frames - 1
    if window <= 0 or steps <= window:
        return np.array([0, max(steps, 0)], dtype=np.int64)
    count = -(-steps // window)
    return (np.arange(count + 1, dtype=np.int64) * steps + count // 2) // count


def window_of(times: NDArray[np.float64], edges: NDArray[np.int64], num_frames: int) -> NDArray[np.int64]:
    """``(T,)`` window index of each clip time (a shared boundary frame belongs to the later window)."""
    x = times * (num_frames - 1)
    return np.searchsorted(edges[1:-1], x, side="right").astype(np.int64)


def local_times(times: NDArray[np.float64], num_frames: int, first: ArrayLike, last: ArrayLike
                ) -> NDArray[np.float64]:
    """``(T,)`` local times ``tau`` of clip ``times`` in windows of frames ``first .. last`` (scalars, or one
    window per time)."""
    first, last = np.asarray(first, np.float64), np.asarray(last, np.float64)
    return (times * (num_frames - 1) - first) / (last - first)


def join_windows(payloads: Sequence[Payload], edges: NDArray[np.int64]) -> Payload:
    """One payload from the per-window payloads: quantised ones (each one window of the quantised layout, sharing the
    output scale) into one quantised ``data`` array (:func:`~._packed.pack`); float ones (each in the
    version-1 layout) into the version-2 windowed layout.

    Float arrays: ``edges (S + 1,)`` int32; ``k (S,)`` int16, frequencies per window; ``omega (sum k,)``
    float32, the windows' frequencies in order; ``weights`` in the weights' dtype, each window's ``W0, b0, W1,
    b1, W2`` flattened (row-major) one after the other; ``b2 (S, D)`` float32.
    """
    arrays = [p.arrays for p in payloads]
    info = {"windows": len(payloads), "K": [p.info["K"] for p in payloads],
            "omega": [p.info["omega"] for p in payloads], "hidden": [p.info["hidden"] for p in payloads],
            "iterations": int(sum(p.info["iterations"] for p in payloads))}
    if all("data" in a for a in arrays):
        unpacked = [unpack(a["data"]) for a in arrays]
        networks = [n for _, _, nets in unpacked for n in nets]
        if len(networks) != len(payloads):
            raise ValueError("join_windows: a quantised window payload holds more than one network")
        info["steps"] = [p.info["steps"] for p in payloads]
        info["parameters"] = int(sum(p.info["parameters"] for p in payloads))
        return Payload({"data": pack(edges, unpacked[0][1], networks)}, info)
    joined = {
        "edges": np.asarray(edges, dtype=np.int32),
        "k": np.array([a["omega"].size for a in arrays], dtype=np.int16),
        "omega": np.concatenate([np.asarray(a["omega"], np.float32) for a in arrays]),
        "weights": np.concatenate([np.asarray(a[n]).ravel() for a in arrays for n in ("W0", "b0", "W1", "b1", "W2")]),
        "b2": np.stack([np.asarray(a["b2"], np.float32) for a in arrays]),
    }
    return Payload(joined, info)


def split_windows(arrays: Mapping[str, ArrayLike]) -> tuple[NDArray[np.int64], list[dict[str, NDArray]]]:
    """The edges and each window's arrays in the version-1 layout (views into ``arrays``).

    Raises:
        ValueError: if the arrays do not fit together.
    """
    edges = np.asarray(arrays["edges"]).astype(np.int64).reshape(-1)
    k = np.asarray(arrays["k"]).astype(np.int64).reshape(-1)
    omega = np.asarray(arrays["omega"]).reshape(-1)
    weights = np.asarray(arrays["weights"]).reshape(-1)
    b2 = np.asarray(arrays["b2"])
    if (edges.size < 2 or edges[0] != 0 or np.any(np.diff(edges) < 1) or k.size != edges.size - 1
            or np.any(k < 0) or b2.ndim != 2 or b2.shape[0] != k.size or omega.size != k.sum()):
        raise ValueError(f"windowed payload: inconsistent edges {edges.shape}, k {k.shape}, omega {omega.shape}, "
                         f"b2 {b2.shape}")
    D = b2.shape[1]
    windows: list[dict[str, NDArray]] = []
    w_at = o_at = 0
    for s, K in enumerate(k.tolist()):
        h = 2 * (2 * K + 1)
        parts = {"W0": (h, 2 * K + 1), "b0": (h,), "W1": (h, h), "b1": (h,), "W2": (D, h)}
        window = {"omega": omega[o_at:o_at + K]}
        o_at += K
        for name, shape in parts.items():
            size = int(np.prod(shape))
            if w_at + size > weights.size:
                raise ValueError(f"windowed payload: weights end in window {s} ({weights.size} values)")
            window[name] = weights[w_at:w_at + size].reshape(shape)
            w_at += size
        window["b2"] = b2[s]
        windows.append(window)
    if w_at != weights.size:
        raise ValueError(f"windowed payload: {weights.size - w_at} weights left over")
    return edges, windows


class Windows(Networks):
    """A windowed payload's networks, checked and converted once, ready to decode any number of clip times: each
    time by the network of the window it falls in, at its local time (one compiled kernel,
    :class:`~._network.Networks`).

    Args:
        arrays: the version-2 windowed layout (:func:`join_windows`), or
        networks: ``(edges, [arrays of each window])`` (a quantised payload, dequantised).
        dtype: the arithmetic (:func:`~._network.network_dtype` of the payload version).

    Raises:
        ValueError: if the arrays do not fit together.
    """

    def __init__(self, arrays: Mapping[str, ArrayLike] | None = None, *,
                 networks: tuple[NDArray[np.int64], Sequence[Mapping[str, ArrayLike]]] | None = None,
                 dtype: type = np.float32):
        edges, windows = split_windows(arrays) if networks is None else networks
        super().__init__(windows, np.asarray(edges, np.int64), dtype=dtype)


def windows_forward(arrays: Mapping[str, ArrayLike], times: ArrayLike, dtype: type = np.float32
                    ) -> NDArray[np.float64]:
    """``(T, D)`` features of a windowed payload at clip ``times`` in [0, 1] (computed in ``dtype`` by
    :class:`Windows`), as float64."""
    return Windows(arrays, dtype=dtype)(times).astype(np.float64)
