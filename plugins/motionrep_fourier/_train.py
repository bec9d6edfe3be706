"""Training of the Fourier-feature network with numpy (CPU, full batch, float32, one BLAS thread, deterministic for a seed).

Only ``_FourierCodec.encode`` imports this module.

Per stage (one value of K): L-BFGS (:class:`._lbfgs.LBFGS`) with a strong-Wolfe line search on the loss of eq. 3
plus a weight decay relative to the bound (:func:`weight_decay`), in chunks of :data:`CHUNK` iterations.  After
every chunk the network is written as it would be stored (normalisation folded into the output layer, cast to
the storage dtype) and, when the bound applies at this K, measured with the shared evaluator; the codec returns
as soon as the stored payload meets the bound.  A stage ends when the loss improved by less than ``tol`` over the last :data:`WINDOW` chunks, or after ``iters``
iterations, or after :data:`FAR_ITERS` when the error measured last was above :data:`FAR` times the bound.

Targets are normalised: ``Z = (Y - mean) * s / c`` with ``s`` the weights ``w`` (floored at 1e-3 of the
largest) and ``c`` the RMS of ``(Y - mean) * s``, so the mean squared error of ``Z`` is eq. 3 up to a constant
factor.  The normalisation is folded into ``W2`` and ``b2`` before storing, so it costs no parameters.
"""

from __future__ import annotations

import contextlib
import math
from typing import Callable, Iterator, NamedTuple

import numpy as np
import scipy.fft
from threadpoolctl import threadpool_limits
from numpy.typing import NDArray

from motionrep.plugin.codec import EncodeContext, Payload
from motionrep.plugin.coding import step_scale
from motionrep.errors import BoundNotMetError, CodecError

from ._lbfgs import LBFGS, LossAndGrad
from ._network import fourier_features, network_forward
from ._packed import pack
from ._quantise import output_scale, quantise_network
from ._trainnet import RIDGE, Net, grow, initial_net

__all__ = ["fit", "next_adaptive_frequency", "clip_scale", "weight_decay", "ClipScale", "CHUNK", "WINDOW",
           "EVAL_EVERY", "NEAR", "FAR", "FAR_ITERS", "DECAY"]

#: L-BFGS iterations between two looks at the loss (and, when the bound applies, maybe at the error).
CHUNK = 25
#: Chunks over which the loss must improve by ``tol`` for a stage to go on (100 iterations).
WINDOW = 4
#: Chunks after which the stored payload is measured even when the loss predicts an error far from the bound.
EVAL_EVERY = 4
#: The payload is measured after every chunk while the predicted error is below ``NEAR`` times the bound.
NEAR = 1.5
_DTYPES = {"float32": np.float32, "float16": np.float16}
#: A stage whose last measured error is above ``FAR`` times the bound ends after ``FAR_ITERS`` iterations: far from
#: the bound, training to the plateau only delays the next frequency (the next stage trains every weight again).
FAR = 3.0
FAR_ITERS = 100
#: Weight decay per squared bound in normalised units (:func:`weight_decay`).
DECAY = 3e-5
#: ``dtype=quantised``: the trained network is rounded once its error is below this fraction of the bound (at
#: the last stage's end, once it is below the bound); the rest of the bound is the rounding's.
HEADROOM = 0.95


@contextlib.contextmanager
def _one_blas_thread() -> Iterator[None]:
    """One BLAS thread while training (restored afterwards): the result must not depend on the machine's load or
    core count, and at these matrix sizes a second thread costs more in waiting than it gains (OpenBLAS's idle
    threads spin)."""
    with threadpool_limits(limits=1, user_api="blas"):
        yield


ChunkEnd = Callable[[NDArray[np.float64], float, int, bool], bool]


def _minimise(fg: LossAndGrad, x0: NDArray[np.float64], iterations: int, start: Callable[[float], object],
              chunk_end: ChunkEnd) -> None:
    """Minimise ``fg`` from ``x0`` for up to ``iterations`` L-BFGS iterations, in chunks of :data:`CHUNK`:
    ``start(loss)`` at ``x0``, then ``chunk_end(x, loss, iterations so far, converged)`` after each chunk, until
    it returns True (it does once ``iterations`` are done or the optimiser has converged)."""
    optimizer = LBFGS(fg, x0)
    start(optimizer.f)
    while True:
        loss = optimizer.run(min(CHUNK, iterations - optimizer.iterations))
        if chunk_end(optimizer.x, loss, optimizer.iterations, optimizer.converged):
            return


def next_adaptive_frequency(residual: NDArray[np.float64], weights: NDArray[np.float64],
                            omega: list[float]) -> float | None:
    """Algorithm 1, lines 7-10: the next frequency, in cycles over the clip.

    The residual ``(N, D)`` is weighted by ``w`` per column, its first principal component found (PCA via SVD
    of the centred matrix), and the DCT-II (``scipy.fft.dct``, orthonormal) of that component's time series
    taken; DCT index ``k`` is ``k / 2`` cycles over the clip.  The strongest index other than 0 whose frequency
    is not yet in ``omega`` is returned; None if there is none.
    """
    R = residual * weights[None, :]
    R = R - R.mean(axis=0)
    N = R.shape[0]
    if N < 2 or not np.any(R):
        return None
    # first principal direction: top eigenvector of the D x D scatter matrix (cheaper than an SVD of R)
    _, vectors = np.linalg.eigh(R.T @ R)
    series = R @ vectors[:, -1]
    spectrum = np.abs(scipy.fft.dct(series, type=2, norm="ortho"))
    spectrum[0] = -1.0
    for w in omega:
        k = int(round(2 * w))
        if 0 <= k < N:
            spectrum[k] = -1.0
    k = int(np.argmax(spectrum))
    if spectrum[k] < 0:
        return None
    return k / 2.0


# -----------------------------------------------------------------------------------------------------------------
# Algorithm 1
# -----------------------------------------------------------------------------------------------------------------
class ClipScale(NamedTuple):
    """A clip's output scale: ``indices (D,)``, the output scale indices, and ``rms``, the RMS ``c`` of the
    centred features times the weights (file units of position: one normalised unit is about ``c``)."""

    indices: NDArray[np.int64]
    rms: float


def clip_scale(features: NDArray[np.float64], weights: NDArray[np.float64]) -> ClipScale:
    """The output scale of a clip: ``step_scale`` of its indices is, within 2^(1/16), ``c / s`` with ``s`` the
    weights floored at 1e-3 of the largest and ``c`` the RMS of the centred features times ``s``: the training
    targets ``(Y - mean) / u`` then have unit RMS and errors weighted by ``w`` (eq. 3)."""
    Y = np.asarray(features, np.float64)
    w = np.asarray(weights, np.float64)
    top = float(w.max()) if w.size else 0.0
    s = np.maximum(w, 1e-3 * top) if top > 0 else np.ones(Y.shape[1])
    c = float(np.sqrt(np.mean(((Y - Y.mean(axis=0)) * s) ** 2))) if Y.size else 0.0
    c = c if c > 0 else 1.0
    return ClipScale(output_scale(c / s), c)


def weight_decay(bound: float | None, rms: float) -> float:
    """The training's weight decay (:class:`._trainnet.Net`) for a bound in file units and the clip's ``rms``
    (:class:`ClipScale`): :data:`DECAY` times the squared bound in normalised units ``(bound / rms)^2``, at
    least :data:`._trainnet.RIDGE` (and that without a bound).  So the decay is about the same share of the
    loss at the bound whatever the bound and the clip's units, and the weights stay as small as the bound
    allows: every weight is then coded in fewer bits, and the rounding of the hidden layers is amplified less
    by the output layer."""
    if bound is None:
        return RIDGE
    return max(RIDGE, DECAY * (bound / rms) ** 2)


def fit(features: NDArray[np.float64], weights: NDArray[np.float64], context: EncodeContext, *,
        schedule: str, name: str, scale: ClipScale | None = None) -> Payload:
    """Train the network for the codec ``name`` with the frequency ``schedule`` (``"adaptive"``/``"naive"``).
    ``scale``: the output scale (:func:`clip_scale`; windows share the clip's), else that of these features."""
    Y, w = np.asarray(features, np.float64), np.asarray(weights, np.float64)
    with _one_blas_thread():
        return _fit(Y, w, context, schedule, name, clip_scale(Y, w) if scale is None else scale)


def _fit(Y: NDArray[np.float64], w: NDArray[np.float64], context: EncodeContext, schedule: str,
         name: str, clip: ClipScale) -> Payload:
    params = context.params
    bound = context.bound
    scale = clip.indices
    decay = weight_decay(bound, clip.rms)
    N, D = Y.shape
    times = np.asarray(context.times, dtype=np.float64)
    mean = Y.mean(axis=0)
    unscale = np.asarray(step_scale(scale), np.float64)  # output = mean + unscale * network
    target = ((Y - mean) / unscale).astype(np.float32)
    quantised = params.dtype == "quantised"
    store = np.float32 if quantised else _DTYPES[params.dtype]
    gen = np.random.default_rng(int(context.seed))

    target_k = params.k if params.k is not None else params.max_k
    omega: list[float] = []
    net = initial_net(gen, 1, 2, D)
    net.decay = decay
    best = math.inf
    percent_per_unit = math.nan  # % of the character height per file unit, from the measurements
    total_iters = 0

    def payload_of(net: Net) -> Payload:
        W0, b0, W1, b1, W2, b2 = (v.astype(np.float64) for v in net.views())
        arrays = {
            "omega": np.asarray(omega, dtype=np.float32),
            "W0": W0.astype(store), "b0": b0.astype(store), "W1": W1.astype(store), "b1": b1.astype(store),
            "W2": (W2 * unscale[:, None]).astype(store), "b2": (mean + unscale * b2).astype(np.float32),
        }
        for key, value in arrays.items():
            if not np.all(np.isfinite(value)):
                raise CodecError(f"{name}: weight {key} overflows {params.dtype}; use dtype=float32")
        info = {"K": len(omega), "omega": [float(o) for o in omega], "hidden": net.hidden,
                "iterations": total_iters}
        return Payload(arrays, info)

    def quantised_payload(net: Net, x: NDArray[np.float32], aim: float | None) -> Payload | None:
        """The network rounded under ``aim`` (the quantised payload), or None if it cannot be."""
        xT = np.vstack([x.T.astype(np.float64), np.ones((1, N))])
        found = quantise_network(
            [A.astype(np.float64) for A in net.layers()], xT, target.T.astype(np.float64), mean / unscale,
            np.rint(2.0 * np.asarray(omega, np.float64)).astype(np.int64), scale,
            lambda arrays: context.evaluate_payload(Payload(arrays)).max_error, aim, decay, int(context.seed))
        if found is None:
            return None
        network, _ = found
        info = {"K": len(omega), "omega": [float(o) for o in omega], "hidden": net.hidden,
                "iterations": total_iters, "steps": network.steps.tolist(),
                "parameters": len(omega) + sum(int(q.size) for q in network.layers)}
        return Payload({"data": pack([0, N - 1], scale, [network])}, info)

    def last_chance(K: int, last: bool) -> bool:
        return last and K >= target_k

    payload = payload_of(net)
    ratio = math.nan  # measured error / sqrt(loss) at the last measurement: predicts the error from the loss
    for K in range(0, target_k + 1):
        if K > 0:
            if schedule == "naive":
                new = float(K)
            else:
                residual = Y - network_forward(payload.arrays, times)
                new = next_adaptive_frequency(residual, w, omega)
            if new is None:
                break
            omega.append(new)
            net = grow(net, gen)
        x = fourier_features(times, omega).astype(np.float32)
        check = bound is not None and (params.k is None or K == params.k)

        def loss_and_grad(theta: NDArray[np.float64], net: Net = net,
                          x: NDArray[np.float32] = x) -> tuple[float, NDArray[np.float64]]:
            return net.loss_and_grad(x, target, theta)

        losses: list[float] = []  # the loss at the start and after each chunk
        stage = unmeasured = 0
        met: list[Payload] = []  # the payload that met the bound, once one does

        def chunk_end(theta: NDArray[np.float64], loss: float, iterations: int, converged: bool) -> bool:
            """After a chunk (``iterations`` in this stage so far, at parameters ``theta``): True to end the
            stage, with the payload in ``met`` if it met the bound."""
            nonlocal stage, unmeasured, total_iters, payload, best, percent_per_unit, ratio
            net.theta = net.weights_at(x, target, theta)
            total_iters += iterations - stage
            stage = iterations
            losses.append(loss)
            unmeasured += 1
            if not math.isfinite(loss):
                raise CodecError(f"{name}: training diverged (loss {loss}) at K={K}")
            plateau = len(losses) > WINDOW and loss > losses[-1 - WINDOW] * (1.0 - params.tol)
            last = stage >= params.iters or converged or plateau
            fields = {"K": K, "omega": list(omega), "iteration": stage, "loss": loss,
                      # the share of the most training this fit can take (every K up to target_k, every iteration)
                      "done": min((K + min(stage / params.iters, 1.0)) / (target_k + 1), 1.0)}
            # measure the stored payload at the end of the stage, and during it when the loss predicts an error
            # near the bound or after EVAL_EVERY unmeasured chunks; the decision is always the measured error
            predicted = ratio * math.sqrt(max(loss, 0.0))
            if check and (last or unmeasured >= EVAL_EVERY or not predicted > NEAR * bound):
                payload = payload_of(net)
                report = context.evaluate_payload(payload)
                unmeasured = 0
                best = min(best, report.max_error)
                if report.max_error > 0:
                    percent_per_unit = report.max_error_percent / report.max_error
                ratio = report.max_error / math.sqrt(loss) if loss > 0 else math.nan
                fields.update(error=report.max_error, error_percent=report.max_error_percent)
                context.progress("train", **fields)
                if report.max_error <= bound and not quantised:
                    met.append(payload)
                    return True
                # quantised: rounding adds error, so the network is rounded once it is well inside the bound
                # (or at the last chance: the last stage's end); kept if the rounded one meets the bound
                if report.max_error <= (1.0 if last_chance(K, last) else HEADROOM) * bound:
                    rounded = quantised_payload(net, x, bound)
                    if rounded is not None:
                        context.progress("quantise", K=K, steps=rounded.info["steps"])
                        met.append(rounded)
                        return True
                if report.max_error > FAR * bound and stage >= FAR_ITERS:
                    return True  # far from the bound: on to the next frequency
            else:
                context.progress("train", **fields)
            return last

        _minimise(loss_and_grad, net.theta[:net.nonlinear_size].astype(np.float64), params.iters,
                  losses.append, chunk_end)
        if met:
            return met[0]
        payload = payload_of(net)
    if bound is None:
        return quantised_payload(net, x, None) if quantised else payload
    reached = f"K={len(omega)}" if params.k is not None else f"max_k={params.max_k} (K={len(omega)})"
    def pct(value: float) -> str:
        return f" ({value * percent_per_unit:.3g}% of height)" if math.isfinite(value * percent_per_unit) else ""

    raise BoundNotMetError(f"{name}: the bound {bound:.4g}{pct(bound)} was not met with {reached}; best L-inf error "
                           f"reached {best:.4g}{pct(best)}", best if math.isfinite(best) else None, bound)
