"""The quantised Fourier payload (payload versions 3 and 4, ``dtype=quantised``): integer networks, range-coded.

One or more windows (one for a whole clip), each a network of eq. 2 whose weights are integers times a step:
``[W0 | b0] = Q0 * d0``, ``[W1 | b1] = Q1 * d1 * c1`` and ``[W2 | b2] = Q2 * d2 * u * c2``: ``d = step_scale(i)``
for an integer step index ``i`` per layer and window; column ``k`` of layers 1 and 2 also times
``step_scale(-e_k)``, ``e_k`` an integer per column (about ``8 log2`` of the RMS of the hidden unit feeding it,
so that a unit of large activations gets a finer step); row ``j`` of the output layer times ``u_j =
step_scale(v_j)``, the clip's per-feature output scale (its weights' reciprocal, so one step means about the
same joint-position error for every feature); ``omega = o / 2`` for integers ``o``.  All of it is one
``uint8`` array of range-coded integers (``motionrep.plugin.coding``), laid out in ``specs/codecs.md``: version 3 codes
each layer's weights under one model; version 4 (written today) codes each layer as a matrix under one model or
one per row or column, whichever is smaller (``motionrep.plugin.coding.fit_matrix_model``: the output layer's rows, one
per feature, differ in magnitude by orders of magnitude, and a feature that never moves has a row of zeros).

:func:`pack` writes it, :func:`unpack` reads it back to the float32 arrays the decoder evaluates
(:func:`dequantized`, shared with the encoder so that what it measures is what is decoded).  Numpy only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.typing import NDArray

from motionrep.plugin.coding import IntegerDecoder, IntegerEncoder, fit_matrix_model, fit_model, step_scale
from motionrep.errors import PayloadError

__all__ = ["QuantizedNetwork", "pack", "unpack", "declared", "dequantized", "layer_bits", "MAX_K", "MAX_WIDTH", "MAX_INDEX",
           "VERSION", "VERSIONS"]

#: Largest number of frequencies of one network (as the codecs' ``max_k``).
MAX_K = 512
#: Largest feature width a payload may declare.
MAX_WIDTH = 1 << 16
#: Largest magnitude of a step or scale index (``step_scale(512) = 2 ** 64``).
MAX_INDEX = 512
_BITS_WIDTH, _BITS_WINDOWS = 16, 24
#: The payload version :func:`pack` writes, and those :func:`unpack` reads.
VERSION = 4
VERSIONS = (3, 4)


@dataclass(frozen=True)
class QuantizedNetwork:
    """One window's network in integers.

    Attributes:
        omega2: ``(K,)`` twice the frequencies (cycles over the window).
        steps: ``(3,)`` step indices ``i0, i1, i2`` of the three layers.
        columns: ``e1 (h + 1,)``, ``e2 (h + 1,)``: the column step exponents of layers 1 and 2 (the last, the
            bias column, is 0).
        layers: ``Q0 (h, 2K + 2)``, ``Q1 (h, h + 1)``, ``Q2 (D, h + 1)``: each layer's weights with its bias as
            the last column, ``h = 2 (2K + 1)``.
    """

    omega2: NDArray[np.int64]
    steps: NDArray[np.int64]
    layers: tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]
    columns: tuple[NDArray[np.int64], NDArray[np.int64]]

    @property
    def K(self) -> int:
        return int(self.omega2.size)


def _shapes(K: int, width: int) -> list[tuple[int, int]]:
    h = 2 * (2 * K + 1)
    return [(h, 2 * K + 2), (h, h + 1), (width, h + 1)]


def dequantized(net: QuantizedNetwork, scale: NDArray[np.int64]) -> dict[str, NDArray]:
    """The network's arrays as the decoder evaluates them (``omega`` float64, weights and biases float32), from
    its integers and the clip's output scale indices ``scale (D,)``."""
    d0, d1, d2 = (float(step_scale(int(i))) for i in net.steps)
    u = np.asarray(step_scale(np.asarray(scale, np.int64)), np.float64)
    c1, c2 = (np.asarray(step_scale(-np.asarray(e, np.int64)), np.float64) for e in net.columns)
    A0 = net.layers[0] * d0
    A1 = net.layers[1] * (d1 * c1)[None, :]
    A2 = net.layers[2] * (d2 * u)[:, None] * c2[None, :]
    return {"omega": net.omega2.astype(np.float64) / 2.0,
            "W0": A0[:, :-1].astype(np.float32), "b0": A0[:, -1].astype(np.float32),
            "W1": A1[:, :-1].astype(np.float32), "b1": A1[:, -1].astype(np.float32),
            "W2": A2[:, :-1].astype(np.float32), "b2": A2[:, -1].astype(np.float32)}


def layer_bits(layers: Sequence[NDArray[np.int64]], version: int = VERSION) -> float:
    """Ideal coded bits of one network's ``Q0, Q1, Q2`` as payload ``version`` codes them (models included)."""
    Q0, Q1, Q2 = layers
    if version == 3:
        return sum(fit_model(q).cost(q) + 16.0 for q in (Q0, Q1, Q2[:, :-1], Q2[:, -1]))
    return sum(fit_matrix_model(q).cost(q) for q in (Q0, Q1, Q2[:, :-1], Q2[:, -1:].T))


def pack(edges: Sequence[int], scale: NDArray[np.int64], networks: Sequence[QuantizedNetwork],
         version: int = VERSION) -> NDArray[np.uint8]:
    """The payload's ``data`` array: window ``s`` covers frames ``edges[s] .. edges[s + 1]`` (one window: the
    whole clip), ``scale (D,)`` the output scale indices, one network per window; in the layout of payload
    ``version`` (3 is kept to write old files in tests)."""
    if version not in VERSIONS:
        raise ValueError(f"pack: payload version {version} is not one of {VERSIONS}")
    edges = np.asarray(edges, np.int64)
    scale = np.asarray(scale, np.int64).reshape(-1)
    S, D = len(networks), scale.size
    if edges.size != S + 1 or S < 1 or np.any(np.diff(edges) < 1) or edges[0] != 0:
        raise ValueError(f"pack: {S} networks need {S + 1} increasing edges from 0, got {edges.tolist()}")
    enc = IntegerEncoder()
    enc.encode_raw([D], _BITS_WIDTH)
    enc.encode_raw([S], _BITS_WINDOWS)
    head = [np.diff(edges) - 1, np.array([n.K for n in networks], np.int64), scale,
            np.concatenate([n.steps for n in networks])]
    models = [fit_model(g) for g in head]
    enc.encode_models(models)
    for g, m in zip(head, models):
        enc.encode(g, m)
    for n in networks:
        for layer, shape in zip(n.layers, _shapes(n.K, D)):
            if layer.shape != shape:
                raise ValueError(f"pack: layer of shape {layer.shape}, expected {shape}")
    omega2 = np.concatenate([n.omega2 for n in networks]).astype(np.int64)
    if version == 3:
        body = [omega2]
        for n in networks:
            Q2 = n.layers[2]
            body += [np.concatenate(n.columns), n.layers[0], n.layers[1], Q2[:, :-1], Q2[:, -1]]
        models = [fit_model(g) for g in body]
        enc.encode_models(models)
        for g, m in zip(body, models):
            enc.encode(g, m)
    else:  # version 4: every window's column exponents, layers and output biases as matrices, in few coder calls
        matrices = [omega2[None, :]]
        for n in networks:
            matrices += [np.concatenate(n.columns)[None, :], n.layers[0], n.layers[1], n.layers[2][:, :-1],
                         n.layers[2][:, -1][None, :]]
        enc.encode_matrices(matrices)
    return np.frombuffer(enc.to_bytes(), np.uint8).copy()


def _header(data: NDArray[np.uint8], version: int):
    """The checked head of a payload: the decoder positioned after it, the width, window count, window lengths,
    frequency counts, output scale, steps, layer shapes and the value budget."""
    if version not in VERSIONS:
        raise PayloadError(f"quantised Fourier payload: version {version} is not one of {VERSIONS}")
    raw = np.asarray(data, np.uint8).reshape(-1)
    dec = IntegerDecoder(raw.tobytes())
    D = int(dec.decode_raw(1, _BITS_WIDTH)[0])
    S = int(dec.decode_raw(1, _BITS_WINDOWS)[0])
    # a range coder can code many integers in few bytes; no payload we write holds more than a few numbers per
    # byte, so a declared size far beyond that is damage, refused before anything is allocated for it
    budget = 64 * raw.size + 4096
    if not 1 <= D <= MAX_WIDTH or not 1 <= S or 2 * S + D > budget:
        raise PayloadError(f"quantised Fourier payload: invalid width {D} or window count {S}")
    models = dec.decode_models(4)
    lengths = dec.decode(S, models[0]) + 1
    K = dec.decode(S, models[1])
    scale = dec.decode(D, models[2])
    steps = dec.decode(3 * S, models[3]).reshape(S, 3)
    if np.any(lengths < 1) or np.any(K < 0) or np.any(K > MAX_K) or np.any(np.abs(scale) > MAX_INDEX) \
            or np.any(np.abs(steps) > MAX_INDEX):
        raise PayloadError("quantised Fourier payload: window lengths, frequency counts or steps out of range")
    shapes = [_shapes(int(k), D) for k in K]
    total = int(K.sum()) + sum(a * b for s in shapes for a, b in s) + sum(2 * s[1][1] for s in shapes)
    if total > budget:
        raise PayloadError(f"quantised Fourier payload: {total} weights declared in {raw.size} bytes")
    return raw, dec, D, S, lengths, K, scale, steps, shapes, budget


def declared(data: NDArray[np.uint8], version: int = VERSION) -> tuple[NDArray[np.int64], NDArray[np.int64], int]:
    """``edges (S + 1,)``, frequency counts ``K (S,)`` and width ``D`` a payload's ``data`` declares, read from its
    head only (checked as :func:`unpack` checks it), for ``Codec.check_payload``.

    Raises:
        PayloadError: as :func:`unpack`, for a damaged head.
    """
    _, _, D, _, lengths, K, _, _, _, _ = _header(data, version)
    return np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64), K.astype(np.int64), D


def unpack(data: NDArray[np.uint8], version: int = VERSION
           ) -> tuple[NDArray[np.int64], NDArray[np.int64], list[QuantizedNetwork]]:
    """``edges``, the output scale indices and the networks of a payload's ``data`` array of payload ``version``.

    Raises:
        PayloadError: for data that does not decode to a consistent payload (declared sizes out of range or
            beyond what the data can hold, data left over).
    """
    raw, dec, D, S, lengths, K, scale, steps, shapes, budget = _header(data, version)
    if version == 3:
        models = dec.decode_models(1 + 5 * S)
        omega2 = dec.decode(int(K.sum()), models[0])
    else:
        shapes4 = [(1, int(K.sum()))]
        for (h, i0), (_, i1), (_, i2) in shapes:
            shapes4 += [(1, 2 * i1), (h, i0), (h, i1), (D, h), (1, D)]
        matrices = dec.decode_matrices(shapes4)
        omega2 = matrices[0][0]
    networks, at = [], 0
    for s in range(S):
        (h, i0), (_, i1), (_, i2) = shapes[s]
        Q2 = np.empty((D, i2), np.int64)
        if version == 3:
            m = models[1 + 5 * s:6 + 5 * s]
            columns = dec.decode(2 * i1, m[0])
            Q0 = dec.decode(h * i0, m[1]).reshape(h, i0)
            Q1 = dec.decode(h * i1, m[2]).reshape(h, i1)
            Q2[:, :-1] = dec.decode(D * h, m[3]).reshape(D, h)
            Q2[:, -1] = dec.decode(D, m[4])
        else:
            columns, Q0, Q1, Q2[:, :-1], Q2[:, -1] = matrices[1 + 5 * s:6 + 5 * s]
            columns = columns[0]
        if np.any(np.abs(columns) > MAX_INDEX):
            raise PayloadError("quantised Fourier payload: column step out of range")
        k = int(K[s])
        networks.append(QuantizedNetwork(omega2[at:at + k], steps[s], (Q0, Q1, Q2), (columns[:i1], columns[i1:])))
        at += k
    dec.finish()
    if np.any(omega2 < 0):
        raise PayloadError("quantised Fourier payload: negative frequency")
    edges = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    return edges, scale, networks
