"""The one way motionrep compiles its hot loops: numba's ``njit`` with a fixed set of options, loaded lazily.

``jit`` compiles on first call and keeps the machine code in numba's on-disk cache (``cache=True``: the
``__pycache__`` beside the source, or numba's user-wide cache directory when that is not writable), so a process
pays the compilation once per machine and afterwards only numba's start-up (``benchmarks/README.md`` gives the
times).  The options:

* ``nogil``: kernels release the GIL, so threads can decode in parallel;
* ``error_model="numpy"``: division by zero gives inf/nan like numpy instead of raising (kernels check what they
  need themselves), which keeps divisions vectorisable;
* no ``fastmath``: every operation is IEEE, so a value does not depend on whether it was computed in a vector
  or a scalar lane, i.e. one pose decodes to the same bits alone or inside a batch, on one machine.

**numba is imported when a compiled function is first called**, not when a module that defines one is imported:
``jit`` returns a :class:`LazyKernel`, which builds the numba dispatcher on its first call (or when a compiled
caller is typed: numba sees the dispatcher through the kernel).  Importing numba and loading its registries takes
about as long as importing numpy several times over, so commands that never run a compiled loop (``motionrep
--help``, ``motionrep plugins``, describing a file) do not pay it.

**The first compilation says so**: when a kernel is about to be compiled because numba's cache has no machine
code for it (the first run on a machine, after an upgrade, or with a fresh ``NUMBA_CACHE_DIR``), the process
prints :data:`COMPILE_NOTICE` on stderr, once, before the several seconds it takes; a run that loads cached code
prints nothing, and nor does a process whose environment sets :data:`NOTICE_ENV` to ``0`` (``--quiet``).

Kernels are private (``_``-prefixed) and called from the public numpy-level functions that validate the input.
motionrep's own core (reading and writing BVH, FK, the rotation conversions) no longer compiles anything at run
time: it is C, compiled when motionrep is installed (``motionrep._ccore``, ``motionrep/_c/``), and imports no
numba.  What still runs through this module: the pose plan (``motionrep.model.poseplan``) and the shipped codecs'
decoders, until they move to C too (issue 24).
Plugins (shipped or third-party) may compile their own hot loops with the same decorator: ``from motionrep.jit import jit`` (a function compiled with numba's own
``njit`` may call motionrep's helpers such as :func:`sincos` once numba is imported).  Code that calls a kernel very often
from Python (the runtime decoder, block after block, for a third-party codec's kernel) can take
:attr:`LazyKernel.dispatcher` once and call it directly, which saves the proxy's function call.  The shipped
decoders and the pose plan are C (``motionrep/_c``, the plugins' ``_c``) and never import numba.
"""

from __future__ import annotations

import functools
import threading
from typing import Any, Callable

import numpy as np

__all__ = ["jit", "jit_inline", "LazyKernel", "numba_loaded", "sincos", "affine_block", "affine_one",
           "COMPILE_NOTICE", "NOTICE_ENV"]

_OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}
_lock = threading.Lock()
_typeof_registered = False

#: the one line said on stderr, once per process, when a kernel is about to be compiled because numba's on-disk
#: cache has nothing for it (the first run on a machine, after an upgrade, or with a fresh ``NUMBA_CACHE_DIR``)
COMPILE_NOTICE = ("motionrep: preparing compiled kernels (first run on this machine, about 10 s; "
                  "cached afterwards)")
_noticed = False
#: set to ``0`` to keep the notice back (``--quiet`` does, for its process and the workers it starts)
NOTICE_ENV = "MOTIONREP_COMPILE_NOTICE"


def _cache_is_empty(dispatcher: Any) -> bool:
    """Whether numba's on-disk cache holds no machine code of ``dispatcher``'s current source (no index, or one
    written by another numba or for an older version of the source): its first call compiles.  Reads one small
    index file; False when numba's cache internals cannot tell (never a wrong notice)."""
    try:
        return not dispatcher._cache._cache_file._load_index()
    except Exception:  # numba's private cache API changed or the index is unreadable: say nothing
        return False


def _notice_compile(dispatcher: Any) -> None:
    """Say :data:`COMPILE_NOTICE` on stderr (once per process) if ``dispatcher`` will compile on first call."""
    global _noticed
    import os
    import sys

    if _noticed or os.environ.get(NOTICE_ENV) == "0" or not _cache_is_empty(dispatcher):
        return
    _noticed = True

    try:
        print(COMPILE_NOTICE, file=sys.stderr, flush=True)
    except (OSError, ValueError):  # stderr closed
        pass


def numba_loaded() -> bool:
    """Whether this process has imported numba (a compiled function has run or been typed)."""
    import sys

    return "numba" in sys.modules


def _register_typeof() -> None:
    """Teach numba's typing to see a :class:`LazyKernel` as its dispatcher, so compiled code can call kernels
    defined with :func:`jit` (and inline those defined with :func:`jit_inline`)."""
    global _typeof_registered
    if _typeof_registered:
        return
    from numba.core.typing.typeof import typeof_impl

    @typeof_impl.register(LazyKernel)
    def _typeof_lazy_kernel(value: LazyKernel, context: Any) -> Any:
        return typeof_impl(value.dispatcher, context)

    _typeof_registered = True


class LazyKernel:
    """A function compiled by numba on first use (what :func:`jit` and :func:`jit_inline` return).

    Calling it calls the compiled function; ``py_func`` is the Python source function; :attr:`dispatcher` is
    numba's dispatcher (built, and numba imported, on first access).
    """

    def __init__(self, func: Callable, options: dict[str, Any]):
        self.py_func = func
        self._options = options
        self._dispatcher = None
        functools.update_wrapper(self, func)

    @property
    def dispatcher(self) -> Any:
        """numba's dispatcher of this function (numba is imported on first access)."""
        d = self._dispatcher
        if d is None:
            with _lock:
                if self._dispatcher is None:
                    import numba

                    _register_typeof()
                    dispatcher = numba.njit(**self._options)(self.py_func)
                    if "inline" not in self._options:  # inlined helpers compile into their callers, never alone
                        _notice_compile(dispatcher)
                    self._dispatcher = dispatcher
                d = self._dispatcher
        return d

    def __call__(self, *args: Any) -> Any:
        return self.dispatcher(*args)

    def __repr__(self) -> str:
        return f"<compiled function {self.py_func.__module__}.{self.py_func.__qualname__}>"


if numba_loaded():  # numba's own njit functions may call motionrep's helpers too
    _register_typeof()


def jit(func: Callable) -> LazyKernel:
    """Decorator for motionrep's compiled kernels (see the module docstring)."""
    return LazyKernel(func, dict(_OPTIONS))


def jit_inline(func: Callable) -> LazyKernel:
    """The same for small helpers that kernels call: inlined into each caller, so the loops around them
    vectorise."""
    return LazyKernel(func, dict(_OPTIONS, inline="always"))


@jit_inline
def _sincos_reduced(x):
    """``(quadrant, sin r, cos r)`` for ``x = r + quadrant pi / 2`` (quadrant 0-3), the reduction and kernels of
    :func:`sincos`; ``motionrep/_c/mr_rotconv.h`` is the same arithmetic in C."""
    n = np.floor(x * 0.6366197723675814 + 0.5)
    r = ((x - n * 1.57079632673412561417e+00) - n * 6.07710050630396597660e-11) - n * 2.02226624871116645580e-21
    z = r * r
    s = r + r * z * (-1.66666666666666324348e-01 + z * (8.33333333332248946124e-03 + z * (
        -1.98412698298579493134e-04 + z * (2.75573137070700676789e-06 + z * (
            -2.50507602534068634195e-08 + z * 1.58969099521155010221e-10)))))
    tail = z * z * (4.16666666666666019037e-02 + z * (-1.38888888888741095749e-03 + z * (
        2.48015872894767294178e-05 + z * (-2.75573143513906633035e-07 + z * (
            2.08757232129817482790e-09 + z * -1.13596475577881948265e-11)))))
    hz = 0.5 * z
    w = 1.0 - hz
    c = w + (((1.0 - w) - hz) + tail)
    return n - 4.0 * np.floor(n * 0.25), s, c


@jit_inline
def sincos(x):
    """``(sin x, cos x)`` of a float64 ``x`` to within an ulp, for compiled code (numba's ``np.sin`` calls libm
    and keeps loops scalar): Cody-Waite reduction by pi / 2 (three parts, exact products for ``|x| < 2^20 pi /
    2``; beyond, the reduction and so the result lose accuracy gracefully but stay bounded), then fdlibm's
    kernels on [-pi/4, pi/4]; branch-free, so loops over it vectorise."""
    quadrant, s, c = _sincos_reduced(x)
    odd = (quadrant == 1.0) | (quadrant == 3.0)
    s1 = c if odd else s
    c1 = -s if odd else c
    if quadrant >= 2.0:
        return -s1, -c1
    return s1, c1


@jit_inline
def affine_block(W, b, X, Z, m):
    """``Z[u, :m] = b[u] + sum_k W[u, k] X[k, :m]`` for compiled decoders: a dense layer on a block of ``m``
    inputs stored as columns (``X (K, >= m)``, ``Z (U, >= m)``), each sum in a fixed order (bias first, then
    ``k = 0, 1, ...``, one multiply and one add at a time) and vectorised over the block's columns, never over
    the sum: an input gives the same bits in any block, at any position (compare :func:`affine_one`), and on any
    x86-64 CPU.  Four units at a time, so each input row is loaded once for four independent sums, and two
    inputs per pass (``(z + w0 x0) + w1 x1``, the same operations in the same order), so each partial sum is
    stored once per two inputs: the stores bound this loop (about 10-20 % faster than one input per pass)."""
    U, K = W.shape[0], W.shape[1]
    u = 0
    while u + 4 <= U:
        b0, b1, b2, b3 = b[u], b[u + 1], b[u + 2], b[u + 3]
        for i in range(m):
            Z[u, i] = b0
            Z[u + 1, i] = b1
            Z[u + 2, i] = b2
            Z[u + 3, i] = b3
        k = 0
        while k + 2 <= K:
            w00, w01, w10, w11 = W[u, k], W[u, k + 1], W[u + 1, k], W[u + 1, k + 1]
            w20, w21, w30, w31 = W[u + 2, k], W[u + 2, k + 1], W[u + 3, k], W[u + 3, k + 1]
            for i in range(m):
                x0, x1 = X[k, i], X[k + 1, i]
                Z[u, i] = (Z[u, i] + w00 * x0) + w01 * x1
                Z[u + 1, i] = (Z[u + 1, i] + w10 * x0) + w11 * x1
                Z[u + 2, i] = (Z[u + 2, i] + w20 * x0) + w21 * x1
                Z[u + 3, i] = (Z[u + 3, i] + w30 * x0) + w31 * x1
            k += 2
        if k < K:
            w0, w1, w2, w3 = W[u, k], W[u + 1, k], W[u + 2, k], W[u + 3, k]
            for i in range(m):
                x = X[k, i]
                Z[u, i] += w0 * x
                Z[u + 1, i] += w1 * x
                Z[u + 2, i] += w2 * x
                Z[u + 3, i] += w3 * x
        u += 4
    while u < U:
        bias = b[u]
        for i in range(m):
            Z[u, i] = bias
        for k in range(K):
            w = W[u, k]
            for i in range(m):
                Z[u, i] += w * X[k, i]
        u += 1


@jit_inline
def affine_one(WT, b, x, z):
    """``z[u] = b[u] + sum_k WT[k, u] x[k]``: :func:`affine_block` for one input (the same sums, the same
    order), vectorised over the units instead, with the transposed weights ``WT (K, U)``."""
    n = b.shape[0]
    for u in range(n):
        z[u] = b[u]
    for k in range(WT.shape[0]):
        xk = x[k]
        for u in range(n):
            z[u] += WT[k, u] * xk
