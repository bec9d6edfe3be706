"""The ``svd`` codec: rank-r truncated SVD of the mean-centred, weighted feature matrix.

Encoding: ``Y`` ``(F, D)`` features, ``m`` their column means, ``s`` the loss weights of Tojo et al. eq. 3
(floored at 1e-3 of the largest, so no column is dropped).  ``(Y - m) * s = U S V^T``; the rank-r approximation
is stored as ``coefficients = U_r S_r`` ``(F, r)`` and ``basis = V_r^T / s`` ``(r, D)``, so
``Y ~ mean + coefficients @ basis``.  Weighting makes the truncation minimise the same weighted L2 error as the
Fourier codecs' loss.

Decoding (:class:`SVDDecoder`, ``_c/module.c``): preparing a decoder decodes every frame ``i`` at its time
``t = i / (F - 1)``, the coefficient rows interpolated there, then ``mean + c(t) @ basis``; a time then blends its
two frames linearly.  In float32 (the payload's own precision) for payload version 2, in float64 for version 1,
whose files were measured in float64 when they were written.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep.plugin.codec import (Codec, CompiledDecoder, EncodeContext, Payload, check_decode_work, check_frames,
                             check_info_numbers)
from motionrep.errors import BoundNotMetError, ParameterError, naming

from . import _csvd

__all__ = ["SVDCodec", "SVDParams", "SVDDecoder"]

_DTYPES = {"float32": np.float32, "float16": np.float16}


@dataclass(frozen=True)
class SVDParams:
    """Parameters of the ``svd`` codec."""

    rank: int | None = field(default=None, metadata={
        "help": "number of singular vectors kept (>= 0; 0 stores only the mean); default: the smallest rank that "
                "meets the bound (max_error), found by bisection"})
    dtype: Literal["float32", "float16"] = field(default="float32", metadata={
        "help": "storage type of coefficients and basis (the mean is always float32)"})

    def __post_init__(self) -> None:
        if self.rank is not None and (not isinstance(self.rank, int) or self.rank < 0):
            raise ParameterError(f"svd: rank must be an integer >= 0, got {self.rank!r}")
        if self.dtype not in _DTYPES:
            raise ParameterError(f"svd: dtype must be one of {', '.join(_DTYPES)}, got {self.dtype!r}")


class SVDCodec(Codec):
    """Truncated SVD baseline of Tojo et al. (2022), section 4.1.

    Payload (format version 2): ``mean (D,)`` float32, ``coefficients (F, r)`` and ``basis (r, D)`` in
    ``dtype``, decoded in float32.  Info: ``{"rank": r}``.  Version 1 (the same arrays) is read too and decoded
    in float64, as it was measured when written.
    """

    name = "svd"
    format_version = 2
    readable_versions = (1, 2)
    description = "rank-r truncated SVD of the weighted, mean-centred features (Tojo et al. 2022 baseline)"
    Params = SVDParams

    def encode(self, features: NDArray[np.float64], weights: NDArray[np.float64],
               context: EncodeContext) -> Payload:
        params: SVDParams = context.params
        Y = np.asarray(features, dtype=np.float64)
        F, D = Y.shape
        max_rank = min(F, D)
        if params.rank is not None and params.rank > max_rank:
            raise ParameterError(f"svd: rank {params.rank} exceeds min(frames, features) = {max_rank}")
        if params.rank is None and context.bound is None:
            raise naming(ParameterError("svd: give rank=R when there is no error bound (max_error=None)"), "max_error=None")
        w = np.asarray(weights, dtype=np.float64)
        top = float(w.max()) if w.size else 0.0
        s = np.maximum(w, 1e-3 * top) if top > 0 else np.ones(D)
        mean = Y.mean(axis=0)
        U, S, Vt = np.linalg.svd((Y - mean) * s, full_matrices=False)
        coeff_all = U * S
        basis_all = Vt / s
        dtype = _DTYPES[params.dtype]

        def payload(r: int) -> Payload:
            return Payload({"mean": mean.astype(np.float32), "coefficients": coeff_all[:, :r].astype(dtype),
                            "basis": basis_all[:r].astype(dtype)}, {"rank": int(r)})

        def error(r: int) -> float:
            e = context.evaluate_payload(payload(r)).max_error
            context.progress("search", rank=r, error=e)
            return e

        if params.rank is not None:
            candidate = payload(params.rank)
            if context.bound is not None:
                e = error(params.rank)
                if e > context.bound:
                    raise BoundNotMetError(f"svd: rank {params.rank} reaches an L-inf error of {e:.4g}, above the "
                                           f"bound {context.bound:.4g}; raise rank or leave it unset", e, context.bound)
            return candidate
        bound = context.bound
        errors: dict[int, float] = {max_rank: error(max_rank)}
        if errors[max_rank] > bound:
            raise BoundNotMetError(f"svd: even the full rank {max_rank} ({params.dtype}) reaches an L-inf error of "
                                   f"{errors[max_rank]:.4g}, above the bound {bound:.4g}", errors[max_rank], bound)
        lo, hi = -1, max_rank  # invariant: hi meets the bound; lo is known not to (or is -1)
        while hi - lo > 1:
            mid = (lo + hi) // 2
            errors[mid] = error(mid)
            if errors[mid] <= bound:
                hi = mid
            else:
                lo = mid
        return payload(hi)

    def check_info(self, info: Mapping[str, Any]) -> None:
        """``rank`` is an integer."""
        check_info_numbers(info, "rank", integers=True)

    def describe(self, info: Mapping[str, Any], detail: bool = False) -> str:
        """``rank=9``."""
        return f"rank={info['rank']}" if "rank" in info else super().describe(info, detail)

    def check_payload(self, payload: Payload, num_frames: int) -> None:
        """The payload's coefficient rows (one per frame) must be the clip's frames; the work (frames x (rank + 1) x
        features: every frame decoded when the decoder is prepared, and held) checked like every codec's."""
        coeff = np.asarray(payload.arrays.get("coefficients", np.zeros((0, 0))))
        mean = np.asarray(payload.arrays.get("mean", np.zeros(0)))
        if coeff.ndim == 2:
            check_frames(coeff.shape[0], num_frames, "svd payload (coefficient rows)")
            check_decode_work(int(num_frames) * (int(coeff.shape[1]) + 1) * int(mean.size), payload,
                              f"svd payload of rank {coeff.shape[1]}")

    def decoder(self, payload: Payload) -> "SVDDecoder":
        return SVDDecoder(payload.arrays, dtype=np.float64 if self.payload_version(payload) == 1 else np.float32)

    def decode(self, payload: Payload, times: ArrayLike) -> NDArray[np.float64]:
        return self.decoder(payload)(times).astype(np.float64)


class SVDDecoder(CompiledDecoder):
    """An ``svd`` payload checked and decoded once, ready to sample any number of times (``_c/module.c``), in
    ``dtype`` (float32 for payload version 2, float64 for version 1).  Preparing decodes every frame at its time
    ``i / (F - 1)``: the coefficient rows interpolated linearly there, then ``mean + c(t) @ basis``, each sum in a
    fixed order (the mean first, then the rank components in order), the arithmetic the decoder used at every time
    before 2026-12-07, so each frame has its bits of then (``(F, D)`` values held: ``4 F D`` bytes in float32).  A
    time then blends its two frames, ``R_j (1 - a) + R_(j+1) a`` in ``dtype`` (``a`` rounded to it); a time that is
    a frame's time, or whose fraction rounds to 0 or 1, gives that frame's values, and a feature constant over the
    clip its mean.  A time decodes to the same bits alone or in a batch.

    Attributes:
        width, kernel, kernel_args: the decoder (``Codec.decoder``): ``kernel(times, out, *kernel_args)`` writes
            ``(D, >= T)`` float64 features, feature-major.
        sampler: the same for C callers (``motionrep.open``; ``motionrep/_c/include/motionrep/sampler.h``).

    Raises:
        ValueError: if the arrays' shapes do not fit together.
    """

    def __init__(self, arrays, dtype: type = np.float32):
        mean, coeff, basis = (np.asarray(arrays[k]) for k in ("mean", "coefficients", "basis"))
        if mean.ndim != 1 or coeff.ndim != 2 or basis.shape != (coeff.shape[1], mean.shape[0]) or coeff.shape[0] < 1:
            raise ValueError(f"inconsistent svd payload shapes: mean {mean.shape}, coefficients {coeff.shape}, "
                             f"basis {basis.shape}")
        self.width, self.dtype = mean.shape[0], np.dtype(dtype)
        self._decoder = _csvd.Decoder(np.ascontiguousarray(coeff, dtype=dtype), np.ascontiguousarray(mean, dtype=dtype),
                                      np.ascontiguousarray(basis, dtype=dtype))
        self.kernel = _csvd.sample
        self.kernel_args = (self._decoder,)
        self._constant: NDArray[np.float64] | None = None

    @property
    def sampler(self):
        """The C sampler (a capsule) that ``motionrep.open`` calls for each block of poses."""
        return self._decoder.sampler

    @property
    def constant_features(self) -> NDArray[np.float64]:
        """``(D,)``: each feature's value where it is the same bits at every time (NaN where not): those whose
        basis column is all zeros and whose mean is finite and not -0.0, when every coefficient is finite and far
        from overflowing (``_c/module.c``, ``CONSTANT``: each sum is then its mean, exactly).  The runtime decoder
        converts the joints whose features are all constant once instead of at every pose (``motionrep.open``), and
        the C sampler writes those features' means instead of summing zeros."""
        if self._constant is None:
            self._constant = np.array(self._decoder.constant, dtype=np.float64)
        return self._constant
