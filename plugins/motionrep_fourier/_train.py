"""Training of the Fourier-feature network with numpy (CPU, full batch, float32, one BLAS thread, deterministic for a seed).

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
from typing import Callable, Iterator

import numpy as np
import scipy.fft
from threadpoolctl import threadpool_limits
from scipy.linalg.lapack import dpotrf, dpotrs, dtrtrs
from numpy.typing import NDArray

from motionrep.plugin.codec import EncodeContext, Payload
from motionrep.plugin.coding import step_scale
from motionrep.errors import BoundNotMetError, CodecError

from ._network import fourier_features, network_forward
from ._packed import pack
from ._quantise import output_scale, quantise_network

__all__ = ["fit", "next_adaptive_frequency", "CHUNK", "WINDOW", "EVAL_EVERY", "NEAR"]

#: L-BFGS iterations between two looks at the loss (and, when the bound applies, maybe at the error).
CHUNK = 25
#: Chunks over which the loss must improve by ``tol`` for a stage to go on (100 iterations).
WINDOW = 4
#: Chunks after which the stored payload is measured even when the loss predicts an error far from the bound.
EVAL_EVERY = 4
#: The payload is measured after every chunk while the predicted error is below ``NEAR`` times the bound.
NEAR = 1.5
_HISTORY = 10
_DTYPES = {"float32": np.float32, "float16": np.float16}
#: ``dtype=quantised``: the trained network is rounded once its error is below this fraction of the bound (at
#: the last stage's end, once it is below the bound); the rest of the bound is the rounding's.
HEADROOM = 0.95

LossAndGrad = Callable[[NDArray[np.float64]], "tuple[float, NDArray[np.float64]]"]


@contextlib.contextmanager
def _one_blas_thread() -> Iterator[None]:
    """One BLAS thread while training (restored afterwards): the result must not depend on the machine's load or
    core count, and at these matrix sizes a second thread costs more in waiting than it gains (OpenBLAS's idle
    threads spin)."""
    with threadpool_limits(limits=1, user_api="blas"):
        yield


def _elu_slope_(z: NDArray[np.float32], slope: NDArray[np.float32]) -> None:
    """ELU (alpha 1) of ``z`` in place, and its slope into ``slope``: ``exp(min(z, 0))`` is the slope, and
    ``max(z, 0) + slope - 1`` the value (``exp`` has vectorised float32 loops where ``expm1`` may not; the
    cancellation near 0 is below float32 resolution of values of order 1)."""
    np.minimum(z, 0.0, out=slope)
    np.exp(slope, out=slope)
    np.maximum(z, 0.0, out=z)
    z += slope
    z -= 1.0


#: Ridge weight of the output layer's least-squares fit, per unit of the mean squared error: the loss is
#: ``mean((net - target)^2) + RIDGE * |W2|^2``.  It keeps the fit unique when hidden units are (nearly) collinear
#: and the weights small enough for float16 and quantised storage, at a cost far below the errors that matter.
RIDGE = 1e-9


def _solve_output(a1T: NDArray[np.float32], targetT: NDArray[np.float32], count: int,
                  out: NDArray[np.float32]) -> float:
    """``out (d, h + 1) = [W2 | b2]`` minimising ``|[W2 | b2] a1T - target^T|^2 / count + RIDGE |W2|^2`` for
    activations ``a1T (h + 1, N)`` (last row ones); returns the ridge term.  Normal equations in float64 (the
    right-hand side accumulated in the network's precision), Cholesky through LAPACK directly (the bias is not
    penalised; a singular system falls back to lstsq)."""
    a = a1T.astype(np.float64)
    G = a @ a.T
    h = G.shape[0] - 1
    G.flat[:h * (h + 2):h + 2] += RIDGE * count
    B = (targetT @ a1T.T).astype(np.float64)  # (d, h + 1): solve G X = B^T, i.e. X^T = B G^-1 (G symmetric)
    factor, info = dpotrf(G, lower=1, clean=0, overwrite_a=1)
    if info == 0:
        solution, info = dpotrs(factor, B.T, lower=1)
    if info != 0:
        solution = np.linalg.lstsq(a @ a.T, B.T, rcond=None)[0]
    out[:] = solution.T
    W2 = out[:, :h]
    return float(RIDGE * np.vdot(W2, W2))


class _Net:
    """The network's parameters as one flat float32 vector (one L-BFGS variable) with shaped views.

    Each layer is stored as one matrix with its bias as the last column (``A0 = [W0 | b0]`` ``(h, i + 1)``,
    ``A1 = [W1 | b1]`` ``(h, h + 1)``, ``A2 = [W2 | b2]`` ``(d, h + 1)``), so that a layer and its gradient are
    one matrix product each; :meth:`views` gives the six arrays of eq. 2.
    """

    def __init__(self, inputs: int, hidden: int, width: int, theta: NDArray[np.float32], dtype: type = np.float32):
        self.inputs, self.hidden, self.width, self.dtype = inputs, hidden, width, dtype
        self.theta = np.ascontiguousarray(theta, dtype=dtype)
        self._x = np.empty_like(self.theta)  # evaluation point and gradient buffers with fixed views
        self._g = np.empty_like(self.theta)
        self._x_layers = self.layers(self._x)
        self._g_layers = self.layers(self._g)
        self._batch: tuple | None = None

    @staticmethod
    def shapes(i: int, h: int, d: int) -> list[tuple[int, int]]:
        """Shapes of the three layer matrices ``[W | b]``."""
        return [(h, i + 1), (h, h + 1), (d, h + 1)]

    def layers(self, theta: NDArray[np.float32] | None = None) -> list[NDArray[np.float32]]:
        """The layer matrices ``A0, A1, A2`` (views of ``theta``)."""
        theta = self.theta if theta is None else theta
        out, off = [], 0
        for shape in self.shapes(self.inputs, self.hidden, self.width):
            n = math.prod(shape)
            out.append(theta[off:off + n].reshape(shape))
            off += n
        return out

    def views(self, theta: NDArray[np.float32] | None = None) -> list[NDArray[np.float32]]:
        """``W0 (h, i), b0 (h,), W1 (h, h), b1 (h,), W2 (d, h), b2 (d,)`` (views of ``theta``)."""
        out = []
        for A in self.layers(theta):
            out += [A[:, :-1], A[:, -1]]
        return out

    @property
    def nonlinear_size(self) -> int:
        """Length of the first two layers' part of the parameter vector (what the optimiser moves)."""
        return self.hidden * (self.inputs + 1) + self.hidden * (self.hidden + 1)

    def _buffers(self, x: NDArray[np.float32], target: NDArray[np.float32]) -> tuple[NDArray, ...]:
        """Feature-major inputs and activations with a last row of ones (the bias input), ``target^T``, and
        scratch arrays; made once per ``(x, target)`` pair (once per stage)."""
        if self._batch is None or self._batch[0] is not x or self._batch[1] is not target:
            N, h = x.shape[0], self.hidden
            dtype = self.dtype
            xT = np.ones((self.inputs + 1, N), dtype)
            xT[:-1] = x.T
            a0T = np.ones((h + 1, N), dtype)
            a1T = np.ones((h + 1, N), dtype)
            scratch = [np.empty((h, N), dtype) for _ in range(3)]
            rT = np.empty((self.width, N), dtype)
            targetT = np.ascontiguousarray(target.T, dtype=dtype)
            self._batch = (x, target, xT, a0T, a1T, targetT, rT, *scratch)
        return self._batch[2:]

    def loss_and_grad(self, x: NDArray[np.float32], target: NDArray[np.float32],
                      theta: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
        """The training loss as a function of the first two layers alone, and its gradient (variable
        projection).

        ``theta`` holds ``A0`` and ``A1`` (:attr:`nonlinear_size` values); the output layer ``A2`` is linear in
        the network's output, so for each ``theta`` it is solved for exactly: the ridge least-squares fit of
        ``target`` on the second layer's activations (:func:`_solve_output`), written into the evaluation
        buffer (:meth:`weights_at` reads it back).  The loss is the mean squared error of that network on
        ``(x (N, i), target (N, d))`` plus the ridge term; because ``A2`` minimises it, its gradient with
        respect to ``theta`` is the partial gradient at the solved ``A2`` (Golub and Pereyra 1973), computed by
        backpropagation written out for this fixed network, on feature-major activations ``(h + 1, N)`` whose
        last row is ones so that each layer's product includes its bias.  float32, except the ``(h + 1)^2``
        normal equations (float64).  ``tests/test_codecs.py`` checks it against central differences.
        """
        xT, a0T, a1T, targetT, rT, slope0, slope1, back = self._buffers(x, target)
        h, n0 = self.hidden, self.nonlinear_size
        self._x[:n0] = theta
        A0, A1, A2 = self._x_layers
        gA0, gA1, _ = self._g_layers
        a0 = np.matmul(A0, xT, out=a0T[:h])
        _elu_slope_(a0, slope0)
        a1 = np.matmul(A1, a0T, out=a1T[:h])
        _elu_slope_(a1, slope1)
        count = rT.size
        penalty = _solve_output(a1T, targetT, count, out=A2)
        np.matmul(A2, a1T, out=rT)  # (d, N): network minus target
        rT -= targetT
        flat = rT.reshape(-1)
        loss = float(np.dot(flat, flat)) / count + penalty
        rT *= 2.0 / count
        g1 = np.matmul(A2[:, :h].T, rT, out=back)
        g1 *= slope1
        np.matmul(g1, a0T.T, out=gA1)
        g0 = np.matmul(A1[:, :h].T, g1, out=slope1)  # slope1 is no longer needed
        g0 *= slope0
        np.matmul(g0, xT.T, out=gA0)
        return loss, self._g[:n0].astype(np.float64)

    def weights_at(self, x: NDArray[np.float32], target: NDArray[np.float32],
                   theta: NDArray[np.float64]) -> NDArray[np.float32]:
        """The full parameter vector for first-two-layer parameters ``theta``: those, and the solved output layer."""
        self.loss_and_grad(x, target, theta)
        return self._x.copy()

    def forward(self, x: NDArray[np.float32], theta: NDArray[np.float32] | None = None) -> NDArray[np.float32]:
        """``(N, d)`` outputs at inputs ``x (N, i)`` (float32; for tests and checks)."""
        W0, b0, W1, b1, W2, b2 = self.views(theta)
        a = np.asarray(x, self.dtype) @ W0.T + b0
        a = np.where(a > 0, a, np.expm1(np.minimum(a, 0)))
        a = a @ W1.T + b1
        a = np.where(a > 0, a, np.expm1(np.minimum(a, 0)))
        return a @ W2.T + b2


# -----------------------------------------------------------------------------------------------------------------
# L-BFGS
# -----------------------------------------------------------------------------------------------------------------
_C1, _C2 = 1e-4, 0.9  # sufficient decrease and (strong) curvature constants of the Wolfe conditions
_MAX_EVALS = 25  # most loss evaluations in one line search
_NOISE = 1e-5  # relative rounding noise allowed for in float32 loss values
_UPPER = np.triu(np.ones((64, 64)))


def _cubic_min(t1: float, f1: float, d1: float, t2: float, f2: float, d2: float, lo: float, hi: float) -> float:
    """Minimiser in ``[lo, hi]`` of the cubic through two points with values and slopes (bisection if none)."""
    e = d1 + d2 - 3.0 * (f1 - f2) / (t1 - t2)
    disc = e * e - d1 * d2
    if disc >= 0.0:
        root = math.sqrt(disc) * (1.0 if t2 >= t1 else -1.0)
        denom = d2 - d1 + 2.0 * root
        if denom != 0.0:
            t = t2 - (t2 - t1) * (d2 + root - e) / denom
            if math.isfinite(t):
                return min(max(t, lo), hi)
    return 0.5 * (lo + hi)


class _LBFGS:
    """Limited-memory BFGS with a strong-Wolfe line search, on a float64 numpy vector.

    ``fg(x)`` returns the loss and its gradient (the network itself runs in float32).  The direction uses
    the compact representation of the inverse-Hessian approximation (Byrd, Nocedal and Schnabel 1994): the
    memory is one ``(2 m, n)`` array of the last ``m`` steps ``s`` and gradient changes ``y``, so a direction
    costs two matrix-vector products and a few ``m x m`` solves instead of ``4 m`` vector operations.  It is the
    same matrix as the classic two-loop recursion, with ``H0 = (s.y / y.y) I`` from the newest pair.  Pairs with
    ``s.y <= 1e-10 |s| |y|`` are skipped, which keeps the approximation positive definite.

    The line search (Nocedal and Wright, algorithms 3.5 and 3.6, with cubic interpolation) tries step 1 first
    (after the first iteration), which L-BFGS accepts most of the time: one loss evaluation per iteration.
    When it finds no decrease, the optimiser restarts once from steepest descent; if that fails too, the loss is
    at float32 precision and :attr:`converged` is set.
    """

    def __init__(self, fg: LossAndGrad, x: NDArray[np.float64], history: int | None = None):
        history = _HISTORY if history is None else history
        self.fg = fg
        self.x = np.array(x, dtype=np.float64)
        self.f, self.g = fg(self.x)
        self.evaluations = 1
        self.iterations = 0
        n = self.x.size
        if not 1 <= history <= _UPPER.shape[0]:
            raise ValueError(f"history must be in [1, {_UPPER.shape[0]}], got {history}")
        self.m = history
        # rows [0, m): s slots, [m, 2m): y slots; float32 halves the memory traffic of the products (the
        # small m x m matrices and the curvature tests are float64)
        self._SY = np.zeros((2 * history, n), dtype=np.float32)
        self._StY = np.zeros((history, history))  # slot-indexed s_i . y_j
        self._YtY = np.zeros((history, history))
        self._reset()
        self.first = True
        self.converged = False

    def _reset(self) -> None:
        self._k = self._next = 0
        self._o = np.zeros(0, np.int64)
        self._SY[:] = 0.0

    def _direction(self) -> NDArray[np.float64]:
        """``-H g`` in the compact form: ``H g = gamma g + S p - gamma Y u`` with ``R u = S^T g`` and
        ``R^T p = (D + gamma Y^T Y) u - gamma Y^T g`` (``R`` the upper triangle of ``S^T Y``, ``D`` its diagonal,
        pairs oldest first)."""
        g = self.g
        if not self._k:
            return -g
        o, m, gamma = self._o, self.m, self._gamma
        ab = (self._SY @ g.astype(np.float32)).astype(np.float64)  # [S^T g; Y^T g], slot order
        u = dtrtrs(self._R, ab[o])[0]
        p = dtrtrs(self._R, self._middle @ u - gamma * ab[m + o], trans=1)[0]
        coef = np.zeros(2 * m, dtype=np.float32)
        coef[o] = p
        coef[m + o] = -gamma * u
        d = (coef @ self._SY).astype(np.float64)
        d += gamma * g
        return np.negative(d, out=d)

    def _remember(self, s: NDArray[np.float64], y: NDArray[np.float64]) -> None:
        """Add the pair ``(s, y)`` (replacing the oldest when the memory is full) and prepare the small matrices
        of the compact form: ``R``, ``D + gamma Y^T Y`` and ``gamma = s.y / y.y`` of the newest pair."""
        sy, yy = float(s @ y), float(y @ y)
        if not (yy > 0 and sy > 1e-10 * math.sqrt(float(s @ s) * yy)):
            return  # skipped: the approximation stays positive definite
        m, slot = self.m, self._next
        self._SY[slot] = s
        self._SY[m + slot] = y
        vy = (self._SY @ y.astype(np.float32)).astype(np.float64)  # [S^T y; Y^T y]
        vs = (self._SY[m:] @ s.astype(np.float32)).astype(np.float64)  # Y^T s
        self._StY[:, slot] = vy[:m]
        self._StY[slot, :] = vs
        self._YtY[:, slot] = vy[m:]
        self._YtY[slot, :] = vy[m:]
        k = self._k = min(self._k + 1, m)
        self._next = (slot + 1) % m
        o = self._o = (np.arange(k) + (self._next if k == m else 0)) % m  # slots, oldest first
        sty = self._StY[o[:, None], o]
        self._R = sty * _UPPER[:k, :k]
        self._gamma = sy / yy
        self._middle = self._gamma * self._YtY[o[:, None], o]
        self._middle.flat[::k + 1] += sty.flat[::k + 1]

    def _line_search(self, d: NDArray[np.float64], step: float):
        """A strong-Wolfe step along ``d``, trying ``step`` first: ``(x, f, g)`` of the accepted point, or of the
        best point with sufficient decrease and a descending slope when the curvature condition is not met within
        :data:`_MAX_EVALS` evaluations; None when no such point was found.

        The loss is computed in float32, so its values carry rounding noise of about 1e-6 of the loss (the
        gradient is accurate to its own scale).  Sufficient decrease is therefore tested with the noise allowed
        for (``f <= f0 + c1 t f'(0) + noise``, the "approximate Wolfe" idea of Hager and Zhang), and the bracket
        is narrowed with the slopes where the values cannot tell: near a minimum, where the possible decrease is
        below the float32 resolution of the loss, the search still finds the step where the slope has flattened.
        """
        f0, dg0 = self.f, float(self.g @ d)
        noise = _NOISE * abs(f0)
        lo_t, lo_f, lo_dg, lo = 0.0, f0, dg0, None  # before a minimiser: slope < 0 (None: the start point)
        hi_t = hi_f = hi_dg = None  # beyond a minimiser (value too high or slope >= 0), once there is one
        t = step
        for _ in range(_MAX_EVALS):
            x = self.x + t * d
            f, g = self.fg(x)
            self.evaluations += 1
            if not math.isfinite(f) or f > f0 + _C1 * t * dg0 + noise or f > lo_f + noise:
                hi_t, hi_f, hi_dg = t, f, float(g @ d) if math.isfinite(f) else math.nan
            else:
                dg = float(g @ d)
                if abs(dg) <= -_C2 * dg0:
                    return x, f, g
                if dg > 0:
                    hi_t, hi_f, hi_dg = t, f, dg
                else:
                    lo_t, lo_f, lo_dg, lo = t, f, dg, (x, f, g)
            if hi_t is None:  # still going down: extrapolate
                t = 4.0 * lo_t
                continue
            width = hi_t - lo_t
            if abs(width) * float(np.max(np.abs(d))) < 1e-9:  # the bracket is below float32 resolution
                break
            a, b = lo_t + 0.1 * width, hi_t - 0.1 * width
            a, b = min(a, b), max(a, b)
            if not (math.isfinite(hi_f) and math.isfinite(hi_dg)):
                t = lo_t + 0.25 * width
            elif abs(hi_f - lo_f) > 10.0 * noise:
                t = _cubic_min(lo_t, lo_f, lo_dg, hi_t, hi_f, hi_dg, a, b)
            elif hi_dg > lo_dg:  # values within noise: secant on the slopes
                t = min(max(lo_t - lo_dg * width / (hi_dg - lo_dg), a), b)
            else:
                t = 0.5 * (a + b)
        return lo

    def run(self, iterations: int) -> float:
        """Take up to ``iterations`` steps (fewer if :attr:`converged`); return the loss at the current point."""
        for _ in range(iterations):
            if self.converged:
                break
            d = self._direction()
            slope = float(self.g @ d)
            if not slope < 0:  # not a descent direction: restart from steepest descent
                self._reset()
                d = -self.g
                slope = float(self.g @ d)
                if not slope < 0:
                    self.converged = True
                    break
            step = min(1.0, 1.0 / float(np.abs(self.g).sum())) if self.first else 1.0
            found = self._line_search(d, step)
            if found is None and self._k:  # no decrease along the quasi-Newton direction: steepest descent
                self._reset()
                d = -self.g
                found = self._line_search(d, min(1.0, 1.0 / float(np.abs(self.g).sum())))
            if found is None:
                self.converged = True  # no decrease found: converged to float32 precision
                break
            x_new, f_new, g_new = found
            self._remember(x_new - self.x, g_new - self.g)
            self.x, self.f, self.g = x_new, f_new, g_new
            self.first = False
            self.iterations += 1
        return self.f


ChunkEnd = Callable[[NDArray[np.float64], float, int, bool], bool]


def _minimise(fg: LossAndGrad, x0: NDArray[np.float64], iterations: int, start: Callable[[float], object],
              chunk_end: ChunkEnd) -> None:
    """Minimise ``fg`` from ``x0`` for up to ``iterations`` L-BFGS iterations, in chunks of :data:`CHUNK`:
    ``start(loss)`` at ``x0``, then ``chunk_end(x, loss, iterations so far, converged)`` after each chunk, until
    it returns True (it does once ``iterations`` are done or the optimiser has converged)."""
    optimizer = _LBFGS(fg, x0)
    start(optimizer.f)
    while True:
        loss = optimizer.run(min(CHUNK, iterations - optimizer.iterations))
        if chunk_end(optimizer.x, loss, optimizer.iterations, optimizer.converged):
            return


# -----------------------------------------------------------------------------------------------------------------
# network construction and growth
# -----------------------------------------------------------------------------------------------------------------
def _uniform(gen: np.random.Generator, shape: tuple[int, ...], fan_in: int) -> NDArray[np.float32]:
    bound = 1.0 / math.sqrt(fan_in)
    return ((gen.random(shape, dtype=np.float32) * 2.0 - 1.0) * bound).astype(np.float32)


def _initial(gen: np.random.Generator, i: int, h: int, d: int) -> _Net:
    """A fresh network with the usual Linear initialisation (uniform in +-1/sqrt(fan_in), as torch's)."""
    W0, b0 = _uniform(gen, (h, i), i), _uniform(gen, (h,), i)
    W1, b1 = _uniform(gen, (h, h), h), _uniform(gen, (h,), h)
    W2, b2 = _uniform(gen, (d, h), h), _uniform(gen, (d,), h)
    return _net_of(W0, b0, W1, b1, W2, b2)


def _net_of(W0: NDArray[np.float32], b0: NDArray[np.float32], W1: NDArray[np.float32], b1: NDArray[np.float32],
            W2: NDArray[np.float32], b2: NDArray[np.float32]) -> _Net:
    """The network with these weights (copied into one parameter vector)."""
    layers = [np.concatenate([W, b[:, None]], axis=1).reshape(-1) for W, b in ((W0, b0), (W1, b1), (W2, b2))]
    return _Net(W0.shape[1], W0.shape[0], W2.shape[0], np.concatenate(layers).astype(np.float32))


def _grow(net: _Net, gen: np.random.Generator) -> _Net:
    """The network for one more frequency (2 more inputs, 4 more hidden units per layer), same function.

    Old units keep their weights and ignore the new inputs and units (zeros); new hidden units get fresh random
    incoming weights; the output ignores the new second-layer units (zeros), so ``F`` is unchanged and training
    resumes where it stopped (warm start, Tojo et al. §3.2).
    """
    i0, h0, d = net.inputs, net.hidden, net.width
    i1 = i0 + 2
    h1 = 2 * i1
    fresh = _initial(gen, i1, h1, d).views()
    W0, b0, W1, b1, W2, b2 = net.views()
    nW0, nb0, nW1, nb1, nW2, nb2 = (v.copy() for v in fresh)
    nW0[:h0] = 0.0
    nW0[:h0, :i0] = W0
    nb0[:h0] = b0
    nW1[:h0] = 0.0
    nW1[:h0, :h0] = W1
    nb1[:h0] = b1
    nW2[:] = 0.0
    nW2[:, :h0] = W2
    nb2[:] = b2
    return _net_of(nW0, nb0, nW1, nb1, nW2, nb2)


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
def clip_scale(features: NDArray[np.float64], weights: NDArray[np.float64]) -> NDArray[np.int64]:
    """``(D,)`` output scale indices of a clip: ``step_scale`` of them is, within 2^(1/16), ``c / s`` with ``s``
    the weights floored at 1e-3 of the largest and ``c`` the RMS of the centred features times ``s``: the
    training targets ``(Y - mean) / u`` then have unit RMS and errors weighted by ``w`` (eq. 3)."""
    Y = np.asarray(features, np.float64)
    w = np.asarray(weights, np.float64)
    top = float(w.max()) if w.size else 0.0
    s = np.maximum(w, 1e-3 * top) if top > 0 else np.ones(Y.shape[1])
    c = float(np.sqrt(np.mean(((Y - Y.mean(axis=0)) * s) ** 2))) if Y.size else 0.0
    return output_scale((c if c > 0 else 1.0) / s)


def fit(features: NDArray[np.float64], weights: NDArray[np.float64], context: EncodeContext, *,
        schedule: str, name: str, scale: NDArray[np.int64] | None = None) -> Payload:
    """Train the network for the codec ``name`` with the frequency ``schedule`` (``"adaptive"``/``"naive"``).
    ``scale``: the output scale indices (:func:`clip_scale`; windows share the clip's), else those of these
    features."""
    Y, w = np.asarray(features, np.float64), np.asarray(weights, np.float64)
    with _one_blas_thread():
        return _fit(Y, w, context, schedule, name, clip_scale(Y, w) if scale is None else scale)


def _fit(Y: NDArray[np.float64], w: NDArray[np.float64], context: EncodeContext, schedule: str,
         name: str, scale: NDArray[np.int64]) -> Payload:
    params = context.params
    bound = context.bound
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
    net = _initial(gen, 1, 2, D)
    best = math.inf
    percent_per_unit = math.nan  # % of the character height per file unit, from the measurements
    total_iters = 0

    def payload_of(net: _Net) -> Payload:
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

    def quantised_payload(net: _Net, x: NDArray[np.float32], aim: float | None) -> Payload | None:
        """The network rounded under ``aim`` (the quantised payload), or None if it cannot be."""
        xT = np.vstack([x.T.astype(np.float64), np.ones((1, N))])
        found = quantise_network(
            [A.astype(np.float64) for A in net.layers()], xT, target.T.astype(np.float64), mean / unscale,
            np.rint(2.0 * np.asarray(omega, np.float64)).astype(np.int64), scale,
            lambda arrays: context.evaluate_payload(Payload(arrays)).max_error, aim, RIDGE, int(context.seed))
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
            net = _grow(net, gen)
        x = fourier_features(times, omega).astype(np.float32)
        check = bound is not None and (params.k is None or K == params.k)

        def loss_and_grad(theta: NDArray[np.float64], net: _Net = net,
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
