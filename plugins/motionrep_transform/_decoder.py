"""The ``transform`` codec's decoder: the C library ``_c/mrtransform.h`` / ``.c`` (no Python in it; ``_cdecode`` is
its binding; version 2's integers through ``_c/mrcoder.c``) decodes the integers, multiplies them by the steps and
transforms them back (inverse CDF 9/7 wavelet); then each call samples the decoded frames (linear interpolation for
times between frames, the arithmetic of :func:`interpolate_rows`), for the runtime decoder through its C sampler.
The encoder measures its candidates with these same functions (:func:`reconstruct`, :func:`synthesised`).
"""

from __future__ import annotations

from functools import partial
from types import SimpleNamespace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep.errors import PayloadError
from motionrep.plugin.codec import Payload

from . import _cdecode, _stream, _stream2
from ._stream import Quantised
from ._wavelet import inverse, level_sizes, num_levels

__all__ = ["TransformDecoder", "interpolate_rows", "reconstruct", "synthesised", "unpack", "STREAMS"]


def reconstruct(q: Quantised) -> NDArray[np.float64]:
    """``(F, D)`` features of the frames of a quantised payload: dequantised and transformed back by the C
    decoder (``mrt_reconstruct``), a read-only view.

    Raises:
        PayloadError: for coefficient arrays that do not fit the clip, a step out of range, or values that are
            not finite.
    """
    coefficients = [np.asarray(c, dtype=np.int64) for c in q.coefficients]
    sizes = level_sizes(q.num_frames, num_levels(q.num_frames))
    if [c.shape for c in coefficients] != [(n, q.num_features) for n in sizes]:
        raise PayloadError("transform payload: coefficient arrays do not fit the clip")
    frames = _cdecode.reconstruct(q.num_frames, q.num_features, q.region_frames,
                           np.ascontiguousarray(q.feature_exponents, dtype=np.int64),
                           np.ascontiguousarray(q.region_exponents, dtype=np.int64),
                           np.ascontiguousarray(np.concatenate(coefficients, axis=0)))
    return np.asarray(frames).T


def synthesised(values: list[NDArray[np.float64]], levels: int) -> NDArray[np.float64]:
    """The inverse wavelet of dequantised coefficients (the C decoder's, ``mrt_inverse``, feature by feature, so any
    columns come out with the bits they have in the whole), checked to be finite."""
    out = inverse(values) if levels else values[0]
    if not np.all(np.isfinite(out)):
        raise PayloadError("transform payload: the coefficients decode to values that are not finite")
    return out


def interpolate_rows(rows: NDArray[np.float64], times: ArrayLike, out: NDArray[np.float64] | None = None
                     ) -> NDArray[np.float64]:
    """Rows ``(F, D)`` of the frames (frame ``i`` at ``t = i / (F - 1)``) at ``times`` ``(T,)`` (clipped to
    [0, 1]): a time on a frame gives that frame's row exactly (one gather), a time between two frames
    ``r_i + (r_(i+1) - r_i) a``.  Written into ``out`` ``(T, D)`` float64 when given."""
    t = np.clip(np.asarray(times, dtype=np.float64).reshape(-1), 0.0, 1.0)
    F = rows.shape[0]
    if out is None:
        out = np.empty((t.size,) + rows.shape[1:], dtype=np.float64)
    if F == 1:
        out[...] = rows[0]
        return out
    pos = t * (F - 1)
    i = np.minimum(np.floor(pos).astype(np.int64), F - 1)
    np.take(rows, i, axis=0, out=out)
    a = pos - i
    between = np.flatnonzero(a)
    if between.size:
        j = i[between]
        out[between] += (rows[j + 1] - rows[j]) * a[between, None]
    return out


def _adaptive(version: int) -> SimpleNamespace:
    return SimpleNamespace(pack=partial(_stream2.pack, version=version),
                           unpack=partial(_stream2.unpack, version=version),
                           declared=partial(_stream2.declared, version=version))


#: The stream of each payload format version: ``pack``, ``unpack``, ``declared`` (encoding; the head a payload
#: declares). Versions 2 and 3 are :mod:`._stream2`'s (the adaptive coder, with or without trained start states).
STREAMS = {1: _stream, 2: _adaptive(2), 3: _adaptive(3)}


def unpack(data: bytes, version: int) -> Quantised:
    """The quantised content of payload bytes of format ``version`` (1, 2 or 3)."""
    return STREAMS[version].unpack(data)


class TransformDecoder:
    """A payload prepared for decoding many times: its integers decoded and transformed back once by the C
    decoder, to the ``(F, D)`` features of its frames (:attr:`frames`, read-only); each call only samples them (the
    values of :func:`interpolate_rows`).  ``version``: the payload's format (1, 2 or 3; default the current one).

    Attributes:
        width, kernel, kernel_args: the sampler for the runtime decoder (``Codec.decoder``): ``kernel(times, out,
            *kernel_args)`` writes ``(D, >= T)`` float64 features, feature-major.
        sampler: the same sampler for C callers (``motionrep.open``; ``motionrep/_c/include/motionrep/sampler.h``).
        constant_features: the features constant over the clip (NaN where not), for the runtime decoder.

    Raises:
        PayloadError: for a damaged or inconsistent payload (when it is prepared).
    """

    def __init__(self, payload: Payload, version: int = _stream2.VERSION):
        data = np.asarray(payload.arrays["data"])
        if data.dtype != np.uint8 or data.ndim != 1:
            raise PayloadError(f"transform payload: data must be a 1-D uint8 array, got {data.dtype} {data.shape}")
        self._decoded = _cdecode.decode(np.ascontiguousarray(data), version)
        self.frames = np.asarray(self._decoded).T  # (F, D), stored feature-major for the sampler
        self.width = self.frames.shape[1]
        self.kernel = _cdecode.sample
        self.kernel_args = (self._decoded,)
        self._constant: NDArray[np.float64] | None = None

    @property
    def constant_features(self) -> NDArray[np.float64]:
        """``(D,)``: each feature's value where it is the same at every frame (the same bits, and not -0.0: linear
        interpolation then gives exactly that value at any time), NaN where it varies.  The runtime decoder converts
        the joints whose features are all constant once instead of at every pose (``motionrep.open``)."""
        if self._constant is None:
            first = self.frames[0]
            bits = self.frames.view(np.int64)
            same = np.all(bits == bits[0], axis=0) & ~((first == 0.0) & np.signbit(first))
            self._constant = np.where(same, first, np.nan)
        return self._constant

    @property
    def sampler(self) -> Any:
        """The C sampler (a capsule) that ``motionrep.open`` calls for each block of poses."""
        return self._decoded.sampler

    def __call__(self, times: ArrayLike, out: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """``(T, D)`` float64 features at normalised ``times`` ``(T,)`` (into ``out`` when given)."""
        t = np.ascontiguousarray(times, dtype=np.float64).reshape(-1)
        rows = np.empty((t.size, self.width)) if out is None or not out.flags.c_contiguous else out
        self._decoded.rows(t, rows)
        if out is not None and rows is not out:
            out[...] = rows
        return rows if out is None else out
