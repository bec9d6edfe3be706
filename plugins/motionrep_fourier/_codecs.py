"""The ``adaptive-fourier`` and ``naive-fourier`` codecs (Tojo et al. 2022, Algorithm 1 and §4.1)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep.codec import Codec, EncodeContext, Payload
from motionrep.errors import ParameterError

from ._network import network_forward

__all__ = ["FourierParams", "AdaptiveFourierCodec", "NaiveFourierCodec"]


@dataclass(frozen=True)
class FourierParams:
    """Parameters shared by ``adaptive-fourier`` and ``naive-fourier``."""

    k: int | None = field(default=None, metadata={
        "help": "number of frequencies K (>= 0); default: the smallest K that meets --max-error, up to max_k"})
    max_k: int = field(default=24, metadata={
        "help": "largest K tried when k is not given; the codec fails cleanly if the bound is not met by then"})
    dtype: Literal["float32", "float16"] = field(default="float32", metadata={
        "help": "storage type of the weights (frequencies and output bias are always float32)"})
    iters: int = field(default=1000, metadata={
        "help": "most L-BFGS iterations per stage (per K)"})
    tol: float = field(default=0.01, metadata={
        "help": "a stage ends when the loss improved by less than this fraction over the last 100 iterations"})

    def __post_init__(self) -> None:
        if self.k is not None and (not isinstance(self.k, int) or self.k < 0):
            raise ParameterError(f"fourier: k must be an integer >= 0, got {self.k!r}")
        if not isinstance(self.max_k, int) or not 0 <= self.max_k <= 512:
            raise ParameterError(f"fourier: max_k must be an integer in [0, 512], got {self.max_k!r}")
        if self.dtype not in ("float32", "float16"):
            raise ParameterError(f"fourier: dtype must be float32 or float16, got {self.dtype!r}")
        if not isinstance(self.iters, int) or self.iters < 25:
            raise ParameterError(f"fourier: iters must be an integer >= 25, got {self.iters!r}")
        if not (0.0 <= self.tol < 1.0):
            raise ParameterError(f"fourier: tol must be in [0, 1), got {self.tol!r}")


class _FourierCodec(Codec):
    """Common encode/decode; subclasses choose the frequency schedule."""

    format_version = 1
    Params = FourierParams
    schedule: str

    def encode(self, features: NDArray[np.float64], weights: NDArray[np.float64],
               context: EncodeContext) -> Payload:
        params: FourierParams = context.params
        if params.k is None and context.bound is None:
            raise ParameterError(f"{self.name}: give k=K when there is no error bound (--max-error none)")
        from ._train import fit  # torch is imported here, never when decoding

        return fit(features, weights, context, schedule=self.schedule, name=self.name)

    def decode(self, payload: Payload, times: ArrayLike) -> NDArray[np.float64]:
        return network_forward(payload.arrays, times)


class AdaptiveFourierCodec(_FourierCodec):
    """Algorithm 1 of Tojo et al. (2022): frequency-adaptive Fourier-feature network.

    Starts with no frequency (``x = t``); after each training stage, if the shared L-infinity error of the stored
    payload is above the bound, the next frequency is the peak of the DCT (type II) of the first principal
    component of the ``w``-weighted residual, among those not yet used; the network grows to
    ``h = 2 (2K + 1)`` with the old weights copied so that its function is unchanged (warm start).

    Payload (format version 1): ``omega (K,)`` float32 (cycles over the clip, multiples of 1/2), ``W0 (h, 2K+1)``,
    ``b0 (h,)``, ``W1 (h, h)``, ``b1 (h,)``, ``W2 (D, h)`` in ``dtype``, ``b2 (D,)`` float32.
    """

    name = "adaptive-fourier"
    description = "Tojo et al. 2022 Algorithm 1: Fourier-feature MLP with DCT-chosen frequencies"
    schedule = "adaptive"


class NaiveFourierCodec(_FourierCodec):
    """The naive-frequency baseline of Tojo et al. (2022), §4.1: ``omega = 1, 2, ..., K`` cycles over the clip.

    Trained exactly like ``adaptive-fourier`` (same network, loss, optimiser, warm start from K - 1), so the two
    differ only in the choice of frequencies.  Payload as for ``adaptive-fourier``.
    """

    name = "naive-fourier"
    description = "Tojo et al. 2022 baseline: Fourier-feature MLP with frequencies 1..K"
    schedule = "naive"
