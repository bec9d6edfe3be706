"""The network the Fourier codecs train (eq. 2 of Tojo et al.): its parameters as one flat float32 vector, the
training loss and its gradient by variable projection, and its construction and growth by one frequency (warm
start).  Training (:mod:`._train`) moves the first two layers; the output layer is solved for exactly.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.linalg.lapack import dpotrf, dpotrs

__all__ = ["Net", "RIDGE", "solve_output", "initial_net", "net_of", "grow"]


def _elu_slope_(z: NDArray[np.float32], slope: NDArray[np.float32]) -> None:
    """ELU (alpha 1) of ``z`` in place, and its slope into ``slope``: ``exp(min(z, 0))`` is the slope, and
    ``max(z, 0) + slope - 1`` the value (``exp`` has vectorised float32 loops where ``expm1`` may not; the
    cancellation near 0 is below float32 resolution of values of order 1)."""
    np.minimum(z, 0.0, out=slope)
    np.exp(slope, out=slope)
    np.maximum(z, 0.0, out=z)
    z += slope
    z -= 1.0


#: The least weight decay, per unit of the mean squared error: the loss is ``mean((net - target)^2) + decay *
#: (|W0|^2 + |W1|^2 + |W2|^2)`` (biases not penalised) with ``decay >= RIDGE`` (:class:`Net`).  It keeps the output
#: layer's fit unique when hidden units are (nearly) collinear and the weights small enough for float16 and
#: quantised storage, at a cost far below the errors that matter.
RIDGE = 1e-9


def solve_output(a1T: NDArray[np.float32], targetT: NDArray[np.float32], count: int,
                  out: NDArray[np.float32], ridge: float = RIDGE) -> float:
    """``out (d, h + 1) = [W2 | b2]`` minimising ``|[W2 | b2] a1T - target^T|^2 / count + ridge |W2|^2`` for
    activations ``a1T (h + 1, N)`` (last row ones); returns the ridge term.  Normal equations in float64 (the
    right-hand side accumulated in the network's precision), Cholesky through LAPACK directly (the bias is not
    penalised; a singular system falls back to lstsq)."""
    a = a1T.astype(np.float64)
    G = a @ a.T
    h = G.shape[0] - 1
    G.flat[:h * (h + 2):h + 2] += ridge * count
    B = (targetT @ a1T.T).astype(np.float64)  # (d, h + 1): solve G X = B^T, i.e. X^T = B G^-1 (G symmetric)
    factor, info = dpotrf(G, lower=1, clean=0, overwrite_a=1)
    if info == 0:
        solution, info = dpotrs(factor, B.T, lower=1)
    if info != 0:
        solution = np.linalg.lstsq(a @ a.T, B.T, rcond=None)[0]
    out[:] = solution.T
    W2 = out[:, :h]
    return float(ridge * np.vdot(W2, W2))


class Net:
    """The network's parameters as one flat float32 vector (one L-BFGS variable) with shaped views.

    Each layer is stored as one matrix with its bias as the last column (``A0 = [W0 | b0]`` ``(h, i + 1)``,
    ``A1 = [W1 | b1]`` ``(h, h + 1)``, ``A2 = [W2 | b2]`` ``(d, h + 1)``), so that a layer and its gradient are
    one matrix product each; :meth:`views` gives the six arrays of eq. 2.  ``decay``: the weight decay of the
    loss (:data:`RIDGE` and up).
    """

    def __init__(self, inputs: int, hidden: int, width: int, theta: NDArray[np.float32], dtype: type = np.float32,
                 decay: float = RIDGE):
        self.inputs, self.hidden, self.width, self.dtype = inputs, hidden, width, dtype
        self.decay = float(decay)
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
        ``target`` on the second layer's activations (:func:`solve_output`), written into the evaluation
        buffer (:meth:`weights_at` reads it back).  The loss is the mean squared error of that network on
        ``(x (N, i), target (N, d))`` plus the weight decay ``decay (|W0|^2 + |W1|^2 + |W2|^2)``; because ``A2``
        minimises it, its gradient with
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
        penalty = solve_output(a1T, targetT, count, out=A2, ridge=self.decay)
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
        for A, gA in ((A0, gA0), (A1, gA1)):  # the weight decay of the first two layers (not their biases)
            W = A[:, :-1]
            loss += self.decay * float(np.vdot(W, W))
            gA[:, :-1] += np.float32(2.0 * self.decay) * W
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


def _uniform(gen: np.random.Generator, shape: tuple[int, ...], fan_in: int) -> NDArray[np.float32]:
    bound = 1.0 / math.sqrt(fan_in)
    return ((gen.random(shape, dtype=np.float32) * 2.0 - 1.0) * bound).astype(np.float32)


def initial_net(gen: np.random.Generator, i: int, h: int, d: int) -> Net:
    """A fresh network with the usual Linear initialisation (uniform in +-1/sqrt(fan_in), as torch's)."""
    W0, b0 = _uniform(gen, (h, i), i), _uniform(gen, (h,), i)
    W1, b1 = _uniform(gen, (h, h), h), _uniform(gen, (h,), h)
    W2, b2 = _uniform(gen, (d, h), h), _uniform(gen, (d,), h)
    return net_of(W0, b0, W1, b1, W2, b2)


def net_of(W0: NDArray[np.float32], b0: NDArray[np.float32], W1: NDArray[np.float32], b1: NDArray[np.float32],
            W2: NDArray[np.float32], b2: NDArray[np.float32]) -> Net:
    """The network with these weights (copied into one parameter vector)."""
    layers = [np.concatenate([W, b[:, None]], axis=1).reshape(-1) for W, b in ((W0, b0), (W1, b1), (W2, b2))]
    return Net(W0.shape[1], W0.shape[0], W2.shape[0], np.concatenate(layers).astype(np.float32))


def grow(net: Net, gen: np.random.Generator) -> Net:
    """The network for one more frequency (2 more inputs, 4 more hidden units per layer), same function.

    Old units keep their weights and ignore the new inputs and units (zeros); new hidden units get fresh random
    incoming weights; the output ignores the new second-layer units (zeros), so ``F`` is unchanged and training
    resumes where it stopped (warm start, Tojo et al. §3.2).
    """
    i0, h0, d = net.inputs, net.hidden, net.width
    i1 = i0 + 2
    h1 = 2 * i1
    fresh = initial_net(gen, i1, h1, d).views()
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
    grown = net_of(nW0, nb0, nW1, nb1, nW2, nb2)
    grown.decay = net.decay
    return grown
