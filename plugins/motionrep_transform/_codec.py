"""The ``transform`` codec: error-bounded wavelet coding of the feature matrix with a range coder.

Encoding (``specs/codecs.md`` has the full description):

1. every feature gets a quantiser step exponent ``b_c`` from its sensitivity: how far a unit change of it moves
   the joints and end sites (``context.feature_sensitivity`` when the context offers it, measured through the
   representation and FK; else the representation's weights ``w``);
2. the features are transformed over frames by the CDF 9/7 wavelet (:mod:`._wavelet`);
3. the clip is cut into regions of ``region`` frames; region ``r`` has its own exponent ``k_r``, and a
   coefficient's step is ``2 ** ((b_c + k) / 8)``, with ``k`` the smallest ``k_r`` over the regions its
   synthesis function reaches, so that each region's error depends mostly on its own exponent;
4. with a feature chain (``context.feature_chain``, :mod:`motionrep.pipeline.chain`; :mod:`._plan`) the features are
   quantised closed loop along the skeleton: depth group by group, each group's targets recomputed from what the
   decoder makes of the groups before it, so that a parent's error does not rotate its subtree, and the
   sensitivities of step 1 are the chain's (about each joint's own bones: larger steps near the root);
5. the ``k_r`` are bisected in lockstep, every region to the largest step that keeps its frames within the
   bound (one shared evaluation of the whole clip per step of the bisection), then settled (regions that a
   neighbour's change pushed over the bound are lowered until all pass);
6. the room the frames still have under the bound is spent: non-zero detail coefficients move one step towards
   zero where that saves bits and every point stays within the bound, move by move, each measured exactly
   through the context's feature edits (:mod:`._greedy`; by thresholds over whole-clip measurements,
   :mod:`._slack`, for a context without them); the same steps, so any decoder of the payload's version reads
   the result;
7. the quantised coefficients are coded by an adaptive binary arithmetic coder with context mixing, in C
   (:mod:`._stream2`, payload version 3: version 2's coder with trained start states; version 2 and version 1,
   static models and a range coder, :mod:`._stream`, are still read).

Decoding (:mod:`._decoder`: :class:`TransformDecoder`, prepared once per payload) is the C library
``_c/mrtransform.h`` / ``.c``.  The encoder measures every candidate with that same decoder (:func:`reconstruct`),
so the bound it measured is the bound of what decodes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from motionrep.plugin.codec import Codec, EncodeContext, Payload, check_decode_work, check_frames
from motionrep.plugin.coding import largest_passing_each, step_scale
from motionrep.errors import BoundNotMetError, MotionrepError, ParameterError, PayloadError, naming

from . import _stream2
from ._decoder import STREAMS, TransformDecoder, interpolate_rows, reconstruct, synthesised, unpack
from ._greedy import MIN_SAVING, spend_slack_exact
from ._plan import _Plan, coefficient_exponents, steps_of, window_minimum  # noqa: F401 (tests import them here)
from ._slack import detail_savings, frame_sensitivity, spend_slack
from ._stream import COEFFICIENT_WORK, MAX_EXPONENT, Quantised
from ._wavelet import coefficient_frames

__all__ = ["TransformCodec", "TransformParams", "TransformDecoder", "interpolate_rows", "reconstruct", "unpack"]

#: Step exponents are in eighths of an octave: step = 2 ** (exponent / 8).
_PER_OCTAVE = 8
#: The bisection of region exponents spans 2 ** -12 .. 2 ** 3 times the bound (in position units).
_SEARCH_BELOW, _SEARCH_ABOVE = 12 * _PER_OCTAVE, 3 * _PER_OCTAVE
#: In closed loop the bisection's window starts this far below the bound's exponent (one octave; the 24 CMU-31
#: payloads of benchmarks/encode_speed.py end 0-7 below it); a region that fails even there is bisected again below
#: it. Its top, taken to fail without a test, is this far above the bound's exponent (one octave: a step of about
#: twice the bound moves a point by more than the bound where a coefficient rounds, so the regions that pass above
#: it are those whose own step barely matters; on the 24 CMU-31 and the 60 tuning encodes -0.08 % / +0.002 % bytes
#: against the full window's top, three octaves up, and one whole-clip step fewer): four steps in all.
_WARM_BELOW = _WARM_ABOVE = _PER_OCTAVE
#: Moves measured by feature edits keep every point this much (relative) within the bound: the edits hold the
#: features as sums of changes, the payload decodes them by the inverse wavelet (the same values but for rounding).
_EDIT_MARGIN = 1e-9
#: The default ``slack``: passes of the move-by-move search, feature groups of the threshold search.
_PASSES, _GROUPS = 5, 3
_SETTLE_ROUNDS = 64  # most rounds of lowering regions over the bound before falling back to one exponent
#: A feature's sensitivity ``s_c`` (its step exponent ``b_c``) is this percentile over frames of the measured one
#: (75 and 99 measured no better on the tuning clips: ``benchmarks/results/rate7.md``).
_SENSITIVITY_PERCENTILE = 90


@dataclass(frozen=True)
class TransformParams:
    """Parameters of the ``transform`` codec."""

    step: float | None = field(default=None, metadata={
        "help": "fixed quality instead of a bound: the quantiser step in position units (file units of joint "
                "movement per step, > 0); default: the largest steps that meet the bound (max_error), region by "
                "region"})
    region: int = field(default=16, metadata={
        "help": "frames per region of the step envelope (4..65536): each region's step is bisected to the bound"})
    slack: int | None = field(default=None, metadata={
        "help": "with a bound: spend the room frames have under it by moving coefficients towards zero, in this "
                "many passes of one step each, every move measured (0..64, default 5; more passes, smaller files, "
                "a longer encode; 0 keeps the rounded integers; a context without feature edits searches "
                "thresholds in this many feature groups instead, default 3)"})
    closed_loop: bool = field(default=True, metadata={
        "help": "quantise closed loop along the skeleton when the representation offers it (root-quat-axis-angle): "
                "depth by depth, each joint's values recomputed from what the decoder makes of its parents, so a "
                "parent's error does not rotate its subtree (about 30 % fewer bytes, 2-3x the encode time); "
                "false: every feature on its own, as before"})
    rounding: float = field(default=0.45, metadata={
        "help": "quantiser rounding offset in [0.05, 0.5]: 0.5 rounds to nearest; smaller values widen the dead "
                "zone around 0, more zeros at a slightly smaller step (the slack search then widens it where "
                "the frames have room)"})

    def __post_init__(self) -> None:
        if self.step is not None and not (isinstance(self.step, (int, float)) and math.isfinite(self.step)
                                          and self.step > 0):
            raise ParameterError(f"transform: step must be a number > 0, got {self.step!r}")
        if isinstance(self.region, bool) or not isinstance(self.region, int) or not 4 <= self.region <= 65536:
            raise ParameterError(f"transform: region must be an integer in 4..65536, got {self.region!r}")
        if self.slack is not None and (isinstance(self.slack, bool) or not isinstance(self.slack, int)
                                       or not 0 <= self.slack <= 64):
            raise ParameterError(f"transform: slack must be an integer in 0..64, got {self.slack!r}")
        if not isinstance(self.closed_loop, bool):
            raise ParameterError(f"transform: closed_loop must be true or false, got {self.closed_loop!r}")
        if not (isinstance(self.rounding, (int, float)) and 0.05 <= self.rounding <= 0.5):
            raise ParameterError(f"transform: rounding must be in [0.05, 0.5], got {self.rounding!r}")


def _spread(values: NDArray[np.int64], where: NDArray[np.bool_]) -> NDArray[np.int64]:
    """``(where.size,)``: ``values`` at the entries of ``where`` (zero elsewhere)."""
    out = np.zeros(where.size, np.int64)
    out[where] = values
    return out


def _log_step(x: NDArray[np.float64] | float) -> NDArray[np.int64]:
    """Nearest step exponent of ``x`` (``round(8 log2 x)``)."""
    return np.rint(_PER_OCTAVE * np.log2(x)).astype(np.int64)


def feature_exponents(sensitivity: NDArray[np.float64]) -> NDArray[np.int64]:
    """``(D,)`` step exponents ``b_c = round(-8 log2 s_c)`` from sensitivities ``s`` (position units per
    feature unit), floored at ``1e-3`` of the largest so that a feature that moves nothing still gets a finite
    step."""
    s = np.asarray(sensitivity, dtype=np.float64)
    top = float(s.max()) if s.size and np.all(np.isfinite(s)) else 0.0
    s = np.maximum(s, 1e-3 * top) if top > 0 else np.ones_like(s)
    return np.clip(_log_step(1.0 / s), -MAX_EXPONENT // 2, MAX_EXPONENT // 2)


def _sensitivity(context: EncodeContext, features: NDArray[np.float64], weights: NDArray[np.float64], chain=None
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(D,)`` position units per feature unit: the 90th percentile over frames of the context's measured
    sensitivity when it offers one (the chain's, in closed loop, with a chain), else the weights ``w`` (Tojo et al.
    eq. 3); and ``(m, D)``, the measured sensitivity of ``m`` frames spread evenly over the clip (the weights,
    ``m = 1``, without a measure)."""
    measure = getattr(context, "feature_sensitivity", None) if chain is None else chain.sensitivity
    if measure is not None:
        per_frame = np.asarray(measure(features), dtype=np.float64)
        if per_frame.ndim == 2 and per_frame.shape[1] == features.shape[1] and per_frame.shape[0] >= 1 \
                and np.all(np.isfinite(per_frame)):
            return np.percentile(per_frame, _SENSITIVITY_PERCENTILE, axis=0), per_frame
    w = np.asarray(weights, dtype=np.float64)
    return w, w[None, :]


def _chain(context: EncodeContext, features: NDArray[np.float64]):
    """The context's feature chain of ``features`` (:meth:`motionrep.pipeline.evaluate.MotionContext.feature_chain`)
    when it offers one and it has more than one group (else None: open loop)."""
    make = getattr(context, "feature_chain", None)
    if make is None:
        return None
    try:
        chain = make(features)
    except MotionrepError:  # features that do not decode
        return None
    return chain if chain is not None and len(chain.groups) > 1 else None


class _RegionErrors:
    """The largest error of each region's frames, for candidate features of the whole clip: one shared
    evaluation (``context.frame_errors``) when the context offers it, else one ``evaluate_frames`` per region."""

    def __init__(self, context: EncodeContext, num_frames: int, region: int):
        self.context, self.num_frames, self.region = context, num_frames, region
        self.regions = -(-num_frames // region)
        self.evaluations = 0

    def __call__(self, features: NDArray[np.float64]) -> NDArray[np.float64]:
        self.evaluations += 1
        frame_errors = getattr(self.context, "frame_errors", None)
        try:
            if frame_errors is not None:
                per_frame = np.asarray(frame_errors(features), dtype=np.float64)
                padded = np.zeros(self.regions * self.region)
                padded[:self.num_frames] = per_frame
                return padded.reshape(self.regions, self.region).max(axis=1)
            out = np.empty(self.regions)
            for r in range(self.regions):
                a, b = r * self.region, min(self.num_frames, (r + 1) * self.region)
                out[r] = self.context.evaluate_frames(features[a:b], a).max_error
            return out
        except MotionrepError:  # a candidate that does not even decode (e.g. a zero-length quaternion)
            return np.full(self.regions, np.inf)


class TransformCodec(Codec):
    """Error-bounded transform coding: CDF 9/7 wavelet over frames, steps from the features' FK sensitivity
    and a per-region envelope bisected to the bound, context-modelled range coding (``motionrep.plugin.coding``).

    Payload (format version 3): ``data`` ``(n,)`` uint8, the stream of :mod:`._stream2` (versions 2, the same
    coder without trained start states, and 1, the range-coded stream of :mod:`._stream`, are still read).
    Info: ``{"bytes": n, "regions": R, "region_frames": region, "step": [smallest, largest]}`` (the position
    steps ``2 ** (k_r / 8)`` of the regions).
    """

    name = "transform"
    format_version = 3
    readable_versions = (1, 2, 3)
    description = "error-bounded wavelet coding with FK-sensitivity steps and a range coder (smallest files)"
    Params = TransformParams

    def encode(self, features: NDArray[np.float64], weights: NDArray[np.float64],
               context: EncodeContext) -> Payload:
        params: TransformParams = context.params
        bound = context.bound
        if params.step is None and bound is None:
            raise naming(ParameterError("transform: give step=S (position units) when there is no error bound "
                                        "(max_error=None)"), "max_error=None")
        Y = np.asarray(features, dtype=np.float64)
        F, D = Y.shape
        chain = _chain(context, Y) if params.closed_loop else None
        summary, sampled = _sensitivity(context, Y, weights, chain)
        feature_exp = feature_exponents(summary)
        plan = _Plan(Y, feature_exp, params.region, chain)
        if params.step is not None:
            k = np.full(plan.regions, int(_log_step(params.step)), np.int64)
        else:
            k = self._search(plan, context, bound, params.rounding)
        if np.any(np.abs(k[:, None] + feature_exp[None, :]) > MAX_EXPONENT):
            raise BoundNotMetError("transform: the steps needed are out of range", None, bound)
        quantised = plan.quantised(k, params.rounding)
        frame_errors = getattr(context, "frame_errors", None)
        if params.step is None and params.slack != 0 and frame_errors is not None and plan.levels:
            quantised = self._spend_slack(plan, quantised, sampled, frame_errors, bound, params.slack, context)
        payload = self._payload(quantised)
        # the search ends on a whole-clip measurement of exactly these values (frame_errors) within the bound; the
        # core measures the stored bytes again in any case. A fixed step, or a context that measures region by
        # region, is measured here
        if bound is not None and (params.step is not None or getattr(context, "frame_errors", None) is None):
            reached = context.evaluate_payload(payload).max_error
            if not reached <= bound:
                raise BoundNotMetError(f"transform: step={params.step:g} reaches an L-inf error of {reached:.4g}, "
                                       f"above the bound {bound:.4g}; lower step or leave it unset"
                                       if params.step is not None else
                                       f"transform: the coded clip reaches an L-inf error of {reached:.4g}, above "
                                       f"the bound {bound:.4g}", reached, bound)
        return payload

    def _search(self, plan: _Plan, context: EncodeContext, bound: float, rounding: float) -> NDArray[np.int64]:
        """Region exponents: each region's largest step that keeps its frames within ``bound``."""
        errors = _RegionErrors(context, plan.num_frames, plan.region)
        R = plan.regions

        last: list = [None, None]  # the last features measured and their errors

        def region_errors(k: NDArray[np.int64]) -> NDArray[np.float64]:
            features = plan.decoded(k, rounding)
            if features is not last[0]:  # the same array: the same values as the last measured (_Plan.decoded)
                last[:] = features, errors(features)
            return last[1].copy()

        def passes(k: NDArray[np.int64]) -> NDArray[np.bool_]:
            return region_errors(k) <= bound

        k0 = int(_log_step(bound))
        plan.incremental = False  # the bisection changes every region's exponent at every step
        low, high = np.full(R, k0 - _SEARCH_BELOW, np.int64), np.full(R, k0 + _SEARCH_ABOVE, np.int64)
        if plan.chain is None:
            k = largest_passing_each(passes, low, high)
        else:  # closed loop: a narrower window first, its ends not tested (its low end is tested by the settling's
            # first measurement, of the bisection's result), below it only for the regions that fail at its low end
            start = np.full(R, k0 - _WARM_BELOW, np.int64)
            k = largest_passing_each(passes, start, np.full(R, k0 + _WARM_ABOVE, np.int64), test_ends=False)
            below = (k == start) & ~passes(k)  # never seen to pass and failing
            if below.any():
                k[below] = largest_passing_each(lambda v: passes(np.where(below, _spread(v, below), k))[below],
                                                low[below], start[below] - 1)
        context.progress("bisect", regions=R, evaluations=errors.evaluations, diagnostic=True)
        plan.incremental = True
        k = self._settle(k, region_errors, bound, low[0] - 1, plan.next_exponent, plan.first_change)
        context.progress("settle", regions=R, evaluations=errors.evaluations,
                         step=[float(step_scale(k.min())), float(step_scale(k.max()))], diagnostic=True)
        return k

    @staticmethod
    def _spend_slack(plan: _Plan, quantised: Quantised, sampled: NDArray[np.float64], frame_errors, bound: float,
                     slack: int | None, context: EncodeContext) -> Quantised:
        """The same steps, with coefficients moved towards zero where the frames have room: move by move, each
        measured exactly, when the context offers feature edits (:mod:`._greedy`), else by thresholds searched
        with whole-clip measurements (:mod:`._slack`)."""
        steps = steps_of(plan.exponents(quantised.region_exponents))

        def errors(features: NDArray[np.float64]) -> NDArray[np.float64]:
            try:
                return np.asarray(frame_errors(features), dtype=np.float64)
            except MotionrepError:  # a candidate that does not even decode
                return np.full(plan.num_frames, np.inf)

        def dequantised(values: list[NDArray[np.int64]]) -> NDArray[np.float64]:
            return synthesised([c * s for c, s in zip(values, steps)], plan.levels)

        make_edits = getattr(context, "feature_edits", None)
        try:
            edits = None if make_edits is None else make_edits(dequantised(quantised.coefficients))
        except MotionrepError:
            edits = None
        if edits is not None:
            coefficients, figures = spend_slack_exact(
                quantised.coefficients, steps, plan.levels, edits, bound * (1.0 - _EDIT_MARGIN),
                lambda values, flat: detail_savings(values, plan.levels, flat), passes=_PASSES if slack is None else slack,
                min_saving=MIN_SAVING)
            # the edits keep the features as a sum of changes; the decoder's are the inverse wavelet's, which
            # differ in the last bits: what the decoder makes of the result is measured again (within the margin,
            # never seen to fail)
            if not float(np.max(errors(reconstruct(replace(quantised, coefficients=coefficients))))) <= bound:
                coefficients, figures["moved"] = quantised.coefficients, 0
        else:
            coefficients, figures = spend_slack(
                quantised.coefficients, steps, plan.levels, frame_sensitivity(sampled, plan.num_frames),
                errors, bound, lambda values: synthesised(values, plan.levels),
                coefficient_frames(plan.num_frames, plan.levels), blocks=_GROUPS if slack is None else slack)
        context.progress("slack", **figures, diagnostic=True)
        return replace(quantised, coefficients=coefficients)

    @staticmethod
    def _settle(k: NDArray[np.int64], region_errors, bound: float, floor: int, next_exponent=None,
                first_change=None) -> NDArray[np.int64]:
        """Lower the exponents of regions over the bound (and, after a region failed three times, its
        neighbours') until every region passes; if that does not converge, one exponent for all. With
        ``next_exponent`` (:meth:`_Plan.next_exponent`), a region whose error did not change at all when it was
        lowered goes straight to the next exponent at which a coefficient it did not yet set would change. With
        ``first_change`` (:meth:`_Plan.first_change`), a region over the bound is lowered at least to the first
        exponent at which it changes any coefficient's step (lowered by one it would change nothing: a round
        spent to fail again with the same error)."""
        k = k.copy()
        fails = np.zeros(k.size, np.int64)
        e_before, bad_before = None, np.zeros(k.size, bool)
        for _ in range(_SETTLE_ROUNDS):
            e = region_errors(k)
            bad = e > bound
            if not bad.any():
                return k
            fails += bad
            lowered = k - 1
            if next_exponent is not None and e_before is not None:
                for r in np.flatnonzero(bad & bad_before & (e == e_before)).tolist():
                    lowered[r] = min(lowered[r], next_exponent(k, r))
            if first_change is not None:
                for r in np.flatnonzero(bad).tolist():
                    lowered[r] = min(lowered[r], first_change(k, r))
            e_before, bad_before = e, bad
            k[bad] = lowered[bad]
            stuck = bad & (fails > 2)
            k[1:][stuck[:-1]] -= 1
            k[:-1][stuck[1:]] -= 1
            k = np.maximum(k, floor)
        best = int(k.min())
        while best >= floor:
            uniform = np.full(k.size, best, np.int64)
            e = region_errors(uniform)
            if not np.any(e > bound):
                return uniform
            best -= _PER_OCTAVE
        raise BoundNotMetError(f"transform: even the finest steps reach an L-inf error of {float(e.max()):.4g}, "
                               f"above the bound {bound:.4g}", float(e.max()), bound)

    @staticmethod
    def _payload(q: Quantised) -> Payload:
        data = np.frombuffer(_stream2.pack(q, _stream2.VERSION), dtype=np.uint8).copy()
        steps = step_scale(q.region_exponents)
        info = {"bytes": int(data.size), "regions": int(q.region_exponents.size), "region_frames": q.region_frames,
                "step": [float(np.min(steps)), float(np.max(steps))]}
        return Payload({"data": data}, info)

    def describe(self, info: Mapping[str, Any], detail: bool = False) -> str:
        """``1668 bytes, 22 regions`` (with ``detail``: the region length and the range of the region steps)."""
        if "bytes" not in info or "regions" not in info:
            return super().describe(info, detail)
        text = f"{info['bytes']} bytes, {info['regions']} regions"
        step = info.get("step")
        if detail and isinstance(step, list) and len(step) == 2:
            text += f" of {info.get('region_frames')} frames, steps {step[0]:.3g}-{step[1]:.3g}"
        return text

    def check_payload(self, payload: Payload, num_frames: int) -> None:
        """The frame count in the payload's head must be the clip's, and its coefficients (``F x D``, each
        :data:`~._stream.COEFFICIENT_WORK` units) within ``max_decode_work`` (``specs/limits.md``)."""
        data = np.asarray(payload.arrays.get("data", np.zeros(0, np.uint8)))
        if data.dtype != np.uint8 or data.ndim != 1:
            raise PayloadError(f"transform payload: data must be a 1-D uint8 array, got {data.dtype} {data.shape}")
        F, D, _ = STREAMS[self.payload_version(payload)].declared(data.tobytes())
        check_frames(F, num_frames, "transform payload")
        check_decode_work(F * D * COEFFICIENT_WORK, payload, f"transform payload of {F} frames x {D} features")

    def decoder(self, payload: Payload) -> TransformDecoder:
        return TransformDecoder(payload, self.payload_version(payload))

    def decode(self, payload: Payload, times: ArrayLike) -> NDArray[np.float64]:
        return self.decoder(payload)(times)
