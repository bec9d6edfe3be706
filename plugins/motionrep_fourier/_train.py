"""Training of the Fourier-feature network with torch (CPU, full batch, float32, deterministic for a seed).

Only ``_FourierCodec.encode`` imports this module.

Per stage (one value of K): L-BFGS (:class:`_LBFGS`) with a strong-Wolfe line search on the loss of eq. 3, in
chunks of :data:`CHUNK` iterations.  After every chunk the network is written as it would be stored
(normalisation folded into the output layer, cast to the storage dtype) and, when the bound applies at this K,
measured with the shared evaluator; the codec returns as soon as the stored payload meets the bound.  A stage
ends when the loss improved by less than ``tol`` over the last :data:`WINDOW` chunks, or after ``iters``
iterations.

Targets are normalised: ``Z = (Y - mean) * s / c`` with ``s`` the weights ``w`` (floored at 1e-3 of the
largest) and ``c`` the RMS of ``(Y - mean) * s``, so the mean squared error of ``Z`` is eq. 3 up to a constant
factor.  The normalisation is folded into ``W2`` and ``b2`` before storing, so it costs no parameters.
"""

from __future__ import annotations

import contextlib
import math
import warnings
from typing import Iterator

import numpy as np
import scipy.fft
import scipy.optimize
import torch
from numpy.typing import NDArray

from motionrep.codec import EncodeContext, Payload
from motionrep.errors import BoundNotMetError, CodecError

from ._network import fourier_features, network_forward

__all__ = ["fit", "next_adaptive_frequency", "CHUNK", "WINDOW"]

#: L-BFGS iterations between two checks of the loss and of the stored payload's error.
CHUNK = 25
#: Chunks over which the loss must improve by ``tol`` for a stage to go on.
WINDOW = 4
_HISTORY = 10
_DTYPES = {"float32": np.float32, "float16": np.float16}


@contextlib.contextmanager
def _torch_settings() -> Iterator[None]:
    """One intra-op thread and deterministic algorithms while training; restored afterwards."""
    threads = torch.get_num_threads()
    deterministic = torch.are_deterministic_algorithms_enabled()
    torch.set_num_threads(1)
    torch.use_deterministic_algorithms(True)
    try:
        yield
    finally:
        torch.set_num_threads(threads)
        torch.use_deterministic_algorithms(deterministic)


class _Net:
    """The network's parameters as one flat float32 vector (one L-BFGS variable) with shaped views."""

    def __init__(self, inputs: int, hidden: int, width: int, theta: torch.Tensor):
        self.inputs, self.hidden, self.width = inputs, hidden, width
        self.theta = theta
        self._x = torch.empty_like(theta)  # evaluation point and gradient buffers with fixed views
        self._g = torch.empty_like(theta)
        self._x_views = self.views(self._x)
        self._g_views = self.views(self._g)

    @staticmethod
    def shapes(i: int, h: int, d: int) -> list[tuple[int, ...]]:
        return [(h, i), (h,), (h, h), (h,), (d, h), (d,)]

    def views(self, theta: torch.Tensor | None = None) -> list[torch.Tensor]:
        theta = self.theta if theta is None else theta
        out, off = [], 0
        for shape in self.shapes(self.inputs, self.hidden, self.width):
            n = math.prod(shape)
            out.append(theta[off:off + n].view(shape))
            off += n
        return out

    def loss_and_grad(self, x: torch.Tensor, target: torch.Tensor,
                      theta: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
        """Mean squared error of the network on ``(x, target)`` and its gradient with respect to ``theta``.

        Backpropagation written out for this fixed three-layer network (autograd's per-call overhead is larger than
        the whole computation at these sizes); ``tests/test_codecs.py`` checks it against autograd.
        """
        with torch.no_grad():
            self._x.copy_(torch.from_numpy(theta))
            W0, b0, W1, b1, W2, b2 = self._x_views
            z0 = torch.addmm(b0, x, W0.T)
            a0, d0 = _elu_and_slope(z0)
            z1 = torch.addmm(b1, a0, W1.T)
            a1, d1 = _elu_and_slope(z1)
            r = torch.addmm(b2, a1, W2.T)
            r -= target
            count = r.numel()
            loss = float(torch.dot(r.reshape(-1), r.reshape(-1))) / count
            r *= 2.0 / count
            gW0, gb0, gW1, gb1, gW2, gb2 = self._g_views
            torch.mm(r.T, a1, out=gW2)
            torch.sum(r, 0, out=gb2)
            g1 = torch.mm(r, W2)
            g1 *= d1
            torch.mm(g1.T, a0, out=gW1)
            torch.sum(g1, 0, out=gb1)
            g0 = torch.mm(g1, W1)
            g0 *= d0
            torch.mm(g0.T, x, out=gW0)
            torch.sum(g0, 0, out=gb0)
        return loss, self._g.numpy().astype(np.float64)

    def forward(self, x: torch.Tensor, theta: torch.Tensor | None = None) -> torch.Tensor:
        W0, b0, W1, b1, W2, b2 = self.views(theta)
        a = torch.nn.functional.elu(torch.addmm(b0, x, W0.T))
        a = torch.nn.functional.elu(torch.addmm(b1, a, W1.T))
        return torch.addmm(b2, a, W2.T)


class _LBFGS:
    """Limited-memory BFGS with a strong-Wolfe line search (``scipy.optimize.line_search``; Armijo backtracking if
    it fails), on a float64 numpy vector.

    ``fg(x)`` returns the loss and its gradient (the network itself runs in torch, float32).  torch's
    ``torch.optim.LBFGS`` works on torch tensors with a strong-Wolfe search, but its per-iteration Python and
    small-tensor work costs more than the tiny network's forward and backward pass; here the two-loop recursion
    is a few numpy dot products.  Curvature pairs with ``s.y <= 1e-10 |s| |y|`` are skipped, which keeps the
    inverse-Hessian approximation positive definite.
    """

    def __init__(self, fg, x: NDArray[np.float64], history: int = _HISTORY):
        self.fg = fg
        self.x = x
        self.f, self.g = fg(x)
        self.s: list[NDArray[np.float64]] = []
        self.y: list[NDArray[np.float64]] = []
        self.rho: list[float] = []
        self.history = history
        self.first = True
        self._cache: list = []

    def _direction(self) -> NDArray[np.float64]:
        q = -self.g
        alphas = []
        for s, y, rho in zip(reversed(self.s), reversed(self.y), reversed(self.rho)):
            a = rho * float(s @ q)
            q = q - a * y
            alphas.append(a)
        if self.s:
            s, y = self.s[-1], self.y[-1]
            q = q * (float(s @ y) / float(y @ y))
        for s, y, rho, a in zip(self.s, self.y, self.rho, reversed(alphas)):
            b = rho * float(y @ q)
            q = q + (a - b) * s
        return q

    def _evaluate(self, x: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
        """``fg(x)``, remembering the last few points (the line search asks for f and f' separately)."""
        for cx, cf, cg in self._cache:
            if np.array_equal(cx, x):
                return cf, cg
        f, g = self.fg(x)
        self._cache = [(x.copy(), f, g)] + self._cache[:2]
        return f, g

    def _wolfe(self, d: NDArray[np.float64], step0: float):
        """Strong-Wolfe step along ``step0 * d`` (``scipy.optimize.line_search``, first trial step 1); None if it
        fails."""
        d = d * step0
        self._cache = [(self.x, self.f, self.g)]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # scipy warns when the search fails; we fall back to backtracking
            alpha = scipy.optimize.line_search(lambda z: self._evaluate(z)[0], lambda z: self._evaluate(z)[1],
                                               self.x, d, gfk=self.g, old_fval=self.f, c1=1e-4, c2=0.9,
                                               maxiter=20)[0]
        if alpha is None or not np.isfinite(alpha) or alpha <= 0:
            return None
        x_new = self.x + alpha * d
        f_new, g_new = self._evaluate(x_new)
        if not (math.isfinite(f_new) and f_new < self.f):
            return None
        return x_new, f_new, g_new

    def _backtrack(self, d: NDArray[np.float64], slope: float, step: float):
        """Armijo backtracking along ``d``; None if no decrease is found."""
        for _ in range(30):
            x_new = self.x + step * d
            f_new, g_new = self.fg(x_new)
            if math.isfinite(f_new) and f_new <= self.f + 1e-4 * step * slope:
                return x_new, f_new, g_new
            step *= 0.5
        return None

    def run(self, iterations: int) -> float:
        """Take up to ``iterations`` steps; return the loss at the current point."""
        for _ in range(iterations):
            d = self._direction()
            slope = float(self.g @ d)
            if not slope < 0:  # not a descent direction: restart from steepest descent
                self.s, self.y, self.rho = [], [], []
                d = -self.g
                slope = float(self.g @ d)
                if slope == 0:
                    return self.f
            step0 = min(1.0, 1.0 / float(np.abs(self.g).sum())) if self.first else 1.0
            found = self._wolfe(d, step0)
            if found is None:
                found = self._backtrack(d, slope, step0)
            if found is None:
                return self.f  # no decrease found: converged to float32 precision
            x_new, f_new, g_new = found
            s_vec, y_vec = x_new - self.x, g_new - self.g
            sy = float(s_vec @ y_vec)
            if sy > 1e-10 * float(np.linalg.norm(s_vec)) * float(np.linalg.norm(y_vec)):
                self.s.append(s_vec)
                self.y.append(y_vec)
                self.rho.append(1.0 / sy)
                if len(self.s) > self.history:
                    del self.s[0], self.y[0], self.rho[0]
            self.x, self.f, self.g = x_new, f_new, g_new
            self.first = False
        return self.f


def _elu_and_slope(z: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """ELU of ``z`` and its derivative (1 where ``z > 0``, ``exp(z) = ELU(z) + 1`` elsewhere)."""
    a = torch.nn.functional.elu(z)
    return a, torch.where(z > 0, 1.0, a + 1.0)


def _uniform(gen: torch.Generator, shape: tuple[int, ...], fan_in: int) -> torch.Tensor:
    bound = 1.0 / math.sqrt(fan_in)
    return (torch.rand(shape, generator=gen, dtype=torch.float32) * 2.0 - 1.0) * bound


def _initial(gen: torch.Generator, i: int, h: int, d: int) -> _Net:
    """A fresh network with torch's default Linear initialisation (uniform in +-1/sqrt(fan_in))."""
    parts = [_uniform(gen, (h, i), i), _uniform(gen, (h,), i), _uniform(gen, (h, h), h), _uniform(gen, (h,), h),
             _uniform(gen, (d, h), h), _uniform(gen, (d,), h)]
    return _Net(i, h, d, torch.cat([p.reshape(-1) for p in parts]))


def _grow(net: _Net, gen: torch.Generator) -> _Net:
    """The network for one more frequency (2 more inputs, 4 more hidden units per layer), same function.

    Old units keep their weights and ignore the new inputs and units (zeros); new hidden units get fresh random
    incoming weights; the output ignores the new second-layer units (zeros), so ``F`` is unchanged and training
    resumes where it stopped (warm start, Tojo et al. §3.2).
    """
    i0, h0, d = net.inputs, net.hidden, net.width
    i1 = i0 + 2
    h1 = 2 * i1
    fresh = _initial(gen, i1, h1, d).views()
    W0, b0, W1, b1, W2, b2 = (v.detach() for v in net.views())
    nW0, nb0, nW1, nb1, nW2, nb2 = (v.detach().clone() for v in fresh)
    nW0[:h0] = 0.0
    nW0[:h0, :i0] = W0
    nb0[:h0] = b0
    nW1[:h0] = 0.0
    nW1[:h0, :h0] = W1
    nb1[:h0] = b1
    nW2.zero_()
    nW2[:, :h0] = W2
    nb2.copy_(b2)
    return _Net(i1, h1, d, torch.cat([p.reshape(-1) for p in (nW0, nb0, nW1, nb1, nW2, nb2)]))


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


def fit(features: NDArray[np.float64], weights: NDArray[np.float64], context: EncodeContext, *,
        schedule: str, name: str) -> Payload:
    """Train the network for the codec ``name`` with the frequency ``schedule`` (``"adaptive"``/``"naive"``)."""
    with _torch_settings():
        return _fit(np.asarray(features, np.float64), np.asarray(weights, np.float64), context, schedule, name)


def _fit(Y: NDArray[np.float64], w: NDArray[np.float64], context: EncodeContext, schedule: str,
         name: str) -> Payload:
    params = context.params
    bound = context.bound
    N, D = Y.shape
    times = np.asarray(context.times, dtype=np.float64)
    top = float(w.max()) if w.size else 0.0
    s = np.maximum(w, 1e-3 * top) if top > 0 else np.ones(D)
    mean = Y.mean(axis=0)
    centred = (Y - mean) * s
    c = float(np.sqrt(np.mean(centred ** 2)))
    c = c if c > 0 else 1.0
    target = torch.tensor(centred / c, dtype=torch.float32)
    unscale = c / s  # output = mean + unscale * network
    store = _DTYPES[params.dtype]
    gen = torch.Generator().manual_seed(int(context.seed))

    target_k = params.k if params.k is not None else params.max_k
    omega: list[float] = []
    net = _initial(gen, 1, 2, D)
    best = math.inf
    total_iters = 0

    def payload_of(net: _Net) -> Payload:
        W0, b0, W1, b1, W2, b2 = (v.detach().double().numpy() for v in net.views())
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

    payload = payload_of(net)
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
            net = _grow(net, gen)
        x = torch.tensor(fourier_features(times, omega), dtype=torch.float32)
        check = bound is not None and (params.k is None or K == params.k)

        def loss_and_grad(theta: NDArray[np.float64], net: _Net = net,
                          x: torch.Tensor = x) -> tuple[float, NDArray[np.float64]]:
            return net.loss_and_grad(x, target, theta)

        optimizer = _LBFGS(loss_and_grad, net.theta.numpy().astype(np.float64))

        losses: list[float] = []
        stage = 0
        while stage < params.iters:
            loss = optimizer.run(CHUNK)
            net.theta = torch.from_numpy(optimizer.x.astype(np.float32))
            stage += CHUNK
            total_iters += CHUNK
            losses.append(loss)
            payload = payload_of(net)
            fields = {"K": K, "omega": list(omega), "iteration": stage, "loss": loss}
            if check:
                report = context.evaluate_payload(payload)
                best = min(best, report.max_error)
                fields.update(error=report.max_error, error_percent=report.max_error_percent)
                context.progress("train", **fields)
                if report.max_error <= bound:
                    return payload
            else:
                context.progress("train", **fields)
            if not math.isfinite(loss):
                raise CodecError(f"{name}: training diverged (loss {loss}) at K={K}")
            if len(losses) > WINDOW and loss > losses[-1 - WINDOW] * (1.0 - params.tol):
                break
    if bound is None:
        return payload
    reached = f"K={len(omega)}" if params.k is not None else f"max_k={params.max_k} (K={len(omega)})"
    raise BoundNotMetError(f"{name}: the bound {bound:.4g} was not met with {reached}; best L-inf error reached "
                           f"{best:.4g}" + ("" if params.k is not None else "; raise max_k or the bound"),
                           best if math.isfinite(best) else None, bound)
