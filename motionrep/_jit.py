"""The one way motionrep compiles its hot loops: numba's ``njit`` with a fixed set of options.

``jit`` compiles on first call and keeps the machine code in numba's on-disk cache (``cache=True``: the
``__pycache__`` beside the source, or numba's user-wide cache directory when that is not writable), so a process
pays the compilation once per machine and afterwards only numba's start-up (``benchmarks/README.md`` gives the
times).  The options:

* ``nogil``: kernels release the GIL, so threads can decode in parallel;
* ``error_model="numpy"``: division by zero gives inf/nan like numpy instead of raising (kernels check what they
  need themselves), which keeps divisions vectorisable;
* no ``fastmath``: every operation is IEEE, so a value does not depend on whether it was computed in a vector
  or a scalar lane, i.e. one pose decodes to the same bits alone or inside a batch, on one machine.

Kernels are private (``_``-prefixed) and called from the public numpy-level functions that validate the input;
there is no second, pure-numpy copy of the same computation.
"""

from __future__ import annotations

import numba

__all__ = ["jit"]

#: Decorator for motionrep's compiled kernels (see the module docstring).
jit = numba.njit(cache=True, nogil=True, error_model="numpy")
