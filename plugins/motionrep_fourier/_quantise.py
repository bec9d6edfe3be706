"""Quantising a trained Fourier network under the bound (encoder side of payload versions 3 and 4).

The network is trained in normalised units (targets ``(Y - mean) / u``, ``u`` the clip's output scale), with
layer matrices ``A0 = [W0 | b0]``, ``A1 = [W1 | b1]``, ``A2 = [W2 | b2]``.  Each layer gets one step
``d_l = step_scale(i_l)``:

* the steps' proportions come from the layers' sensitivities: with ``G_l`` the summed mean squared derivative
  of the outputs with respect to the layer's ``n_l`` numbers, a step ``d`` adds about ``d^2 / 12 * G_l`` to the
  mean squared output error, and the rate is smallest for a given error when every number adds the same:
  ``d_l ~ sqrt(n_l / G_l)``;
* one offset common to the three is then bisected to the bound (``motionrep.plugin.coding.largest_passing``), each
  candidate measured by the shared evaluator exactly as it would be decoded;
* then each layer's step, largest layer first, is made coarser while the bound holds, in jumps of 16, 8, 4, 2 and
  1 indices, in rounds until a round changes nothing.

In every candidate the first two layers are rounded, and the output layer is fitted again by least squares to
the targets on the rounded layers' activations before it is rounded (the rounding of the earlier layers is
compensated by the later one: the re-fit that makes the rounded network meet the bound).
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from numpy.typing import NDArray

from motionrep.plugin.coding import largest_passing, step_scale
from motionrep.errors import MotionrepError

from ._packed import MAX_INDEX, QuantizedNetwork, dequantized, layer_bits

__all__ = ["quantise_network", "output_scale", "Candidate"]

#: Probes of the Hutchinson estimate of the first layer's sensitivity.
_PROBES = 8
#: Half the range (index steps of 2^(1/8)) over which the output layer's step is bisected for each shift.
_COARSER = 16
#: The final search: each layer's step index is raised by these jumps in turn, each up to ``_REPEATS`` times while
#: the bound holds, in at most ``_ROUNDS`` rounds over the layers.
_JUMPS = (16, 8, 4, 2, 1)
_REPEATS = 4
_ROUNDS = 4
#: Shifts of the hidden layers' step indices tried against the sensitivity-based proportions.
_SHIFTS = (-24, -16, -8, -4, 4, 8, 16)
#: Without a bound: the RMS of the rounding's output error, in normalised units (the targets' RMS is 1).
NOISE = 1e-3
#: Damping of the inputs' Gram matrix in :func:`rounded`, relative to its mean diagonal (the next is tried when the
#: factorisation fails).
_DAMPING = (1e-6, 1e-3, 1e-1)

Measure = Callable[[dict], float]


def output_scale(unscale: NDArray[np.float64]) -> NDArray[np.int64]:
    """Scale indices ``v`` with ``step_scale(v)`` nearest to ``unscale`` in the log domain (per feature)."""
    u = np.asarray(unscale, np.float64)
    return np.clip(np.rint(8.0 * np.log2(u)), -MAX_INDEX, MAX_INDEX).astype(np.int64)


def _elu(z: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    slope = np.exp(np.minimum(z, 0.0))
    return np.maximum(z, 0.0) + slope - 1.0, slope


def _with_ones(a: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.vstack([a, np.ones((1, a.shape[1]))])


def _column_exponents(aT: NDArray[np.float64]) -> NDArray[np.int64]:
    """``(h + 1,)`` column step exponents for a layer fed by activations ``aT (h + 1, N)`` (last row ones):
    ``round(8 log2 RMS)`` of each unit above RMS 1 (0 for the others and the bias): the step of the weights
    that a unit feeds is divided by its RMS, so each weight's rounding moves the output about as much."""
    rms = np.sqrt(np.mean(aT ** 2, axis=1))
    e = np.rint(8.0 * np.log2(np.maximum(rms, 1.0))).astype(np.int64)
    e[-1] = 0
    return np.minimum(e, MAX_INDEX // 2)


def _sensitivities(layers: list[NDArray[np.float64]], xT: NDArray[np.float64], rng: np.random.Generator,
                   column_scale: tuple[NDArray[np.float64], NDArray[np.float64]]) -> NDArray[np.float64]:
    """``(3,)`` each layer's ``G_l / n_l``: the squared derivatives of the outputs (averaged over frames and
    features) with respect to its numbers, summed, per number."""
    A0, A1, A2 = layers
    a0, s0 = _elu(A0 @ xT)
    a0T = _with_ones(a0)
    a1, s1 = _elu(A1 @ a0T)
    a1T = _with_ones(a1)
    D, N = A2.shape[0], xT.shape[1]
    h = A1.shape[0]
    c1, c2 = column_scale  # in units of the column steps
    g2 = float(np.sum((a1T * c2[:, None]) ** 2)) / N  # row d sees only its own weights: sum_d 1/D sum_j E a1_j^2
    g1 = float(np.sum(A2[:, :h] ** 2, axis=0) @ ((s1 ** 2) @ ((a0T * c1[:, None]) ** 2).T / N).sum(axis=1)) / D
    g0 = 0.0
    for _ in range(_PROBES):  # Hutchinson: E_v |J^T v|^2 over Rademacher v is sum of squared derivatives
        v = rng.integers(0, 2, size=(D, N)) * 2.0 - 1.0
        back = (A2[:, :h].T @ v) * s1
        back = (A1[:, :h].T @ back) * s0
        g0 += float(np.sum((back @ xT.T) ** 2))
    g0 /= _PROBES * N * D
    return np.array([g0, g1, g2]) / np.array([A.size for A in layers], np.float64)


def rounded(A: NDArray[np.float64], inputsT: NDArray[np.float64], steps: NDArray[np.float64]) -> NDArray[np.int64]:
    """``(m, n)`` integers ``Q`` with ``Q * steps`` (per column) close to the layer ``A (m, n)`` on its inputs
    ``inputsT (n, N)``: each column is rounded in turn and its rounding error is compensated by the columns not
    yet rounded, in the least-squares sense on the inputs (GPTQ, Frantar et al. 2023, "optimal brain
    quantisation" one column at a time), columns of larger input energy first. With ``H = inputs inputs^T / N``
    and ``U`` the upper Cholesky factor of ``H^-1`` (columns reordered), rounding column ``k`` moves the columns
    after it by ``-(error / U_kk) U_k,k+1:``, which keeps ``|(A - Q steps) inputs|^2`` near its least value."""
    n = A.shape[1]
    gram = inputsT @ inputsT.T / max(inputsT.shape[1], 1)
    order = np.argsort(-np.diag(gram), kind="stable")
    gram = gram[np.ix_(order, order)]
    level = float(np.mean(np.diag(gram))) if n else 0.0
    upper = None
    for damping in _DAMPING:
        try:
            inverse = np.linalg.inv(gram + (damping * level + 1e-300) * np.eye(n))
            upper = np.linalg.cholesky((inverse + inverse.T) / 2.0).T
            break
        except np.linalg.LinAlgError:
            continue
    s = np.asarray(steps, np.float64)[order]
    W = np.array(A[:, order], np.float64)
    Q = np.empty(W.shape, np.int64)
    for k in range(n):
        q = np.rint(W[:, k] / s[k])
        Q[:, order[k]] = q
        if upper is not None and k + 1 < n:
            W[:, k + 1:] -= np.outer((W[:, k] - q * s[k]) / upper[k, k], upper[k, k + 1:])
    return Q


class Candidate:
    """Rounds a trained network with given step indices, re-fitting the output layer on the rounded hidden
    layers; :meth:`network` is the result as a :class:`QuantizedNetwork`, :meth:`arrays` as the decoder sees it."""

    def __init__(self, layers: list[NDArray[np.float64]], xT: NDArray[np.float64], targetT: NDArray[np.float64],
                 omega2: NDArray[np.int64], scale: NDArray[np.int64], ridge: float):
        self.layers, self.xT, self.targetT, self.omega2, self.scale = layers, xT, targetT, omega2, scale
        self.ridge = ridge
        # column steps of layers 1 and 2: finer for a hidden unit of large activations (the trained ones')
        a0T = _with_ones(_elu(layers[0] @ xT)[0])
        a1T = _with_ones(_elu(layers[1] @ a0T)[0])
        self.columns = tuple(_column_exponents(a) for a in (a0T, a1T))
        self.column_scale = tuple(np.asarray(step_scale(-e), np.float64) for e in self.columns)

    def network(self, steps: NDArray[np.int64]) -> QuantizedNetwork:
        d0, d1, d2 = (float(step_scale(int(i))) for i in steps)
        c1, c2 = self.column_scale
        Q0 = rounded(self.layers[0], self.xT, np.full(self.layers[0].shape[1], d0))
        A0 = (Q0 * d0).astype(np.float32).astype(np.float64)
        a0T = _with_ones(_elu(A0 @ self.xT)[0])
        Q1 = rounded(self.layers[1], a0T, d1 * c1)
        # the hidden layers as the decoder has them (float32 weights), the output layer fitted to them
        A1 = (Q1 * (d1 * c1)).astype(np.float32).astype(np.float64)
        a1T = _with_ones(_elu(A1 @ a0T)[0])
        G = a1T @ a1T.T
        h = G.shape[0] - 1
        G.flat[:h * (h + 2):h + 2] += self.ridge * self.targetT.size
        B = self.targetT @ a1T.T
        try:
            A2 = np.linalg.solve(G, B.T).T
        except np.linalg.LinAlgError:
            A2 = np.linalg.lstsq(G, B.T, rcond=None)[0].T
        Q2 = rounded(A2, a1T, d2 * c2)
        return QuantizedNetwork(self.omega2, np.asarray(steps, np.int64), (Q0, Q1, Q2), self.columns)

    def arrays(self, steps: NDArray[np.int64]) -> dict:
        return dequantized(self.network(steps), self.scale)


def quantise_network(layers: list[NDArray[np.float64]], xT: NDArray[np.float64], targetT: NDArray[np.float64],
                     mean_scaled: NDArray[np.float64], omega2: NDArray[np.int64], scale: NDArray[np.int64],
                     measure: Measure, bound: float | None, ridge: float, seed: int
                     ) -> tuple[QuantizedNetwork, float] | None:
    """The rounded network with the coarsest steps found that meets ``bound`` (and its measured error), or
    None when even the finest steps tried do not.

    Args:
        layers: ``A0 (h, i + 1)``, ``A1 (h, h + 1)``, ``A2 (D, h + 1)`` of the trained network, float64, in
            normalised units (the output layer's bias without the mean).
        xT: ``(i + 1, N)`` the inputs at the frames, last row ones.
        targetT: ``(D, N)`` the normalised targets (without the mean).
        mean_scaled: ``(D,)`` the frames' mean over the output scale: added to the output layer's bias.
        omega2, scale: twice the frequencies; the output scale indices.
        measure: the shared error of a candidate's decoder arrays.
        bound: the bound in file units; None: steps for an output error of RMS :data:`NOISE` (not measured).
        ridge: the output layer's ridge weight (as in training).
        seed: for the sensitivity probes.
    """
    rng = np.random.default_rng(seed)
    shifted = [layers[0], layers[1], layers[2].copy()]
    shifted[2][:, -1] += mean_scaled
    target_with_mean = targetT + mean_scaled[:, None]
    candidate = Candidate(shifted, xT, target_with_mean, omega2, scale, ridge)
    per_number = _sensitivities(layers, xT, rng, candidate.column_scale)
    sizes = np.array([A.size for A in layers], np.float64)
    # d_l ~ sqrt(n_l / G_l) = 1 / sqrt(G_l / n_l); as step indices (8 per octave), relative to the output layer
    relative = np.rint(-4.0 * np.log2(np.maximum(per_number, 1e-300) / max(per_number[2], 1e-300)))
    relative = np.clip(relative, -MAX_INDEX // 2, MAX_INDEX // 2).astype(np.int64)
    cache: dict[tuple[int, ...], float] = {}

    def error(steps: NDArray[np.int64]) -> float:
        key = tuple(int(i) for i in steps)
        if key not in cache:
            if max(abs(i) for i in key) > MAX_INDEX:
                cache[key] = math.inf
            else:
                arrays = candidate.arrays(steps)
                try:
                    finite = all(np.all(np.isfinite(a)) for a in arrays.values())
                    cache[key] = measure(arrays) if finite else math.inf
                except (MotionrepError, ValueError):  # too coarse to decode (say, a zero-length quaternion)
                    cache[key] = math.inf
        return cache[key]

    # the common offset: the output layer's step index; noise RMS about 2^(i/8) sqrt(n/12) in normalised units
    if bound is None:  # no bound: output noise of RMS NOISE (normalised units), MSE = 2^(i/4) g_2 n / 12
        base = int(np.rint(4.0 * np.log2(12.0 * NOISE ** 2 / (max(per_number[2], 1e-300) * sizes.sum()))))
        steps = relative + base
        return candidate.network(steps), math.nan
    top = MAX_INDEX // 2 - int(relative.max(initial=0))
    bottom = -MAX_INDEX // 2 - int(relative.min(initial=0))
    base = largest_passing(lambda i: error(relative + i) <= bound, bottom, top)
    if base is None:
        return None

    def bits(steps: NDArray[np.int64]) -> float:  # as the payload codes them
        return layer_bits(candidate.network(steps).layers)

    # the error is an L-inf one, which the mean-squared proportions only approximate: the hidden layers' steps
    # are also tried from three octaves finer to two coarser, the output layer's bisected for each, and the
    # steps of fewest coded bits kept
    best = relative + base
    best_bits = bits(best)
    for shift in _SHIFTS:
        hidden = relative[:2] + base + shift
        low, high = int(relative[2] + base - 2 * _COARSER), int(relative[2] + base + 2 * _COARSER)
        out = largest_passing(lambda i: error(np.array([*hidden, i])) <= bound, low, high)
        if out is None:
            continue
        trial = np.array([*hidden, out], np.int64)
        trial_bits = bits(trial)
        if trial_bits < best_bits:
            best, best_bits = trial, trial_bits
    # then each layer coarser while the bound holds, largest layer first, in jumps of two octaves down to one
    # index (the error is not monotonic in the steps: a coarser step can pass beyond one that fails), in rounds
    # until a round changes nothing
    steps = best
    for _ in range(_ROUNDS):
        before = steps.copy()
        for layer in np.argsort(-sizes, kind="stable").tolist():
            for jump in _JUMPS:
                for _ in range(_REPEATS):
                    trial = steps.copy()
                    trial[layer] += jump
                    if error(trial) > bound:
                        break
                    steps = trial
        if np.array_equal(before, steps):
            break
    return candidate.network(steps), error(steps)
