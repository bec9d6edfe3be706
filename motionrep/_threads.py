"""One BLAS thread around the work whose result must not depend on the thread count (encoding, decoding).

OpenBLAS (and MKL) may split a product's sums differently with 1 and with 2 threads, so the same clip compressed
in a one-thread batch worker and in a many-thread process could give different bytes (it did: svd on a
2,575-frame clip).  :func:`one_blas_thread` limits the BLAS libraries numpy and scipy use to one thread, through
``threadpoolctl``, for the duration of a ``with`` block; the codecs' and representations' numpy work inside it is
then the same on every run of one machine, whatever ``OPENBLAS_NUM_THREADS`` says or how many workers run.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator
from typing import Any

__all__ = ["one_blas_thread"]

_lock = threading.Lock()
_controller: Any = None
_depth = 0


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the block with one BLAS thread (nested blocks and other threads share the one limit)."""
    global _controller, _depth
    with _lock:
        if _controller is None:
            from threadpoolctl import ThreadpoolController

            _controller = ThreadpoolController()  # finds the loaded BLAS libraries once (it takes milliseconds)
        _depth += 1
        limiter = _controller.limit(limits=1, user_api="blas") if _depth == 1 else None
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if limiter is not None:
                limiter.restore_original_limits()
