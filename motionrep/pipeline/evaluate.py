"""The shared evaluation: one FK-based L-infinity joint-position error.

Every codec, shipped or third-party, is judged by these functions and by nothing else: codecs never measure
their own error (nor their compression ratio: :func:`motionrep.pipeline.figures.compression_figures`).

Error
    Both motions are run through forward kinematics (:func:`motionrep.model.kinematics.global_positions`); the error
    of a point in a frame is the Euclidean distance between its two positions, over every joint **and every end
    site**.  The reported error is the largest over all points and frames (the L-infinity norm of Tojo et al.
    2022), in file units and in percent of the reference's character height
    (:func:`motionrep.model.kinematics.character_height`), together with the mean over points and frames and where the
    worst error is (frame index, point name).

Codecs ask for this error while they search, through the :class:`MotionContext` they are given (the
:class:`~motionrep.plugin.codec.EncodeContext` of ``motionrep compress`` and of the conformance suite alike).

The compression figures reported beside it are :mod:`motionrep.pipeline.figures`'s.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any, Callable, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..model._pose import Motion, Skeleton
from ..model.poseplan import decode_feature_major, decode_planned
from ..plugin.codec import Payload, frame_times
from ..plugin.representation import empty_poses
from ..errors import ValidationError, naming
from .._ccore import max_distances
from ..model.kinematics import character_height, fk_arrays, global_positions, point_names
from ..model.ops import fixed_axes, fixed_axes_restored
from .chain import (SENSITIVITY_BUDGET, SENSITIVITY_FRAMES, FeatureChain, moved_positions,  # noqa: F401 (public
                    sensitivity_samples, sensitivity_steps)  # here too)
from .edits import FeatureEdits
from .pairing import STRICT, MatchOptions, compared_points, skeleton_difference  # skeleton_difference: public here too

if TYPE_CHECKING:
    from ..plugin.codec import Codec
    from ..plugin.representation import Representation

__all__ = ["ErrorReport", "Evaluator", "max_joint_error", "compare", "skeleton_difference", "MotionContext",
           "ProgressCallback"]


@dataclass(frozen=True)
class ErrorReport:
    """The shared L-infinity measure between a reference and a candidate motion.

    Attributes:
        max_error: largest joint or end-site position error over all frames, in file units.
        max_error_percent: ``max_error`` in percent of the character height (``inf`` if the height is 0 and the
            error is not).
        mean_error: mean position error over all points and frames, in file units.
        mean_error_percent: ``mean_error`` in percent of the character height.
        frame: index of the frame with the largest error.
        joint: name of the point with the largest error (a joint name, or ``"<joint>/End Site"``).
        height: character height of the reference (file units).
        units: length unit of the reference skeleton when known, else None.
        num_frames: frames compared.
        num_points: points compared per frame (joints + end sites).
        comparison: what was compared and left out (a :class:`motionrep.pipeline.pairing.Comparison`), or None for a
            strict comparison of every point and frame made without :mod:`motionrep.pipeline.pairing`.
    """

    max_error: float
    max_error_percent: float
    mean_error: float
    mean_error_percent: float
    frame: int
    joint: str
    height: float
    units: str | None
    num_frames: int
    num_points: int
    comparison: Any = None

    def as_dict(self) -> dict[str, Any]:
        """A JSON-serialisable dict of every field (``comparison`` as a dict, or None)."""
        d = asdict(self)
        d["comparison"] = None if self.comparison is None else self.comparison.as_dict()
        return d

    def summary(self) -> str:
        """One line: ``L-inf 0.49 (1.89% of height 26.2), mean 0.08 (0.31%), worst at frame 0, LeftHand``."""
        unit = f" {self.units}" if self.units else ""
        return (f"L-inf error {self.max_error:.4g}{unit} ({self.max_error_percent:.3g}% of height "
                f"{self.height:.4g}{unit}), mean {self.mean_error:.3g}{unit} ({self.mean_error_percent:.3g}%), "
                f"worst at frame {self.frame}, {self.joint}")


def _percent(value: float, height: float) -> float:
    if height > 0:
        return 100.0 * value / height
    return 0.0 if value == 0 else math.inf


class Evaluator:
    """Measures candidates against one reference motion; FK of the reference is computed once.

    Args:
        reference: the motion every candidate is compared with.

    Use it when many candidates are compared with the same reference (a codec's search); for a single
    comparison :func:`max_joint_error` is simpler.
    """

    def __init__(self, reference: Motion):
        self.reference = reference
        self.skeleton: Skeleton = reference.skeleton
        self.height = character_height(reference.skeleton)
        self.names = point_names(reference.skeleton)
        self._positions = global_positions(reference)

    @property
    def reference_positions(self) -> NDArray[np.float64]:
        """``(F, J + E, 3)`` FK positions of the reference (read-only view)."""
        view = self._positions.view()
        view.flags.writeable = False
        return view

    def __call__(self, candidate: Motion, options: Any = None) -> ErrorReport:
        """Compare ``candidate`` with the reference.

        Args:
            candidate: the motion to measure.
            options: a :class:`motionrep.pipeline.pairing.MatchOptions` saying what may differ (joint order and names,
                extra joints, end sites, frame rate); default strict. With options the report's ``comparison``
                says what was compared and left out.

        Raises:
            ValidationError: if the skeletons differ in joints, parents or end sites, or the frame counts or
                frame rates differ (strict), or cannot be paired under ``options``; the message names the
                option that would compare them.
        """
        if options is not None:
            return self.points_error(*compared_points(self.reference, candidate, options))
        ref = self.reference
        what = skeleton_difference(self.skeleton, candidate.skeleton)
        if what is not None:
            raise naming(ValidationError(f"cannot compare motions of different skeletons: {what} (match='names' "
                                         "compares joints by name, and the points both have)"), "match='names'")
        if candidate.num_frames != ref.num_frames:
            rates = ("" if math.isclose(candidate.fps, ref.fps, rel_tol=1e-6) else
                     f" at {ref.fps:g} vs {candidate.fps:g} fps (a .mrc decompresses at any rate: fps={ref.fps:g})")
            raise naming(ValidationError(f"cannot compare motions with different frame counts: {ref.num_frames} vs "
                                         f"{candidate.num_frames}{rates} (resample=True samples the candidate at the "
                                         "reference's frame times)"), "fps=", "resample=True")
        if not math.isclose(candidate.fps, ref.fps, rel_tol=1e-6):
            raise naming(ValidationError(f"cannot compare motions with different frame rates: {ref.fps:g} vs "
                                         f"{candidate.fps:g} fps (resample=True samples the candidate at the "
                                         "reference's frame times)"), "resample=True")
        return self.positions_error(global_positions(candidate))

    def positions_error(self, positions: NDArray[np.float64], first: int | None = None) -> ErrorReport:
        """Compare ``(F, J + E, 3)`` candidate FK positions with the reference's; with ``first``, ``(n, J + E, 3)``
        positions of the reference frames ``first .. first + n - 1`` only (the report's frame is then a frame of
        the clip, its mean and ``num_frames`` those of these frames)."""
        dist = self._distances(positions, first)
        flat = int(np.argmax(dist))
        frame, point = divmod(flat, dist.shape[1])
        frame += first or 0
        max_error = float(dist.reshape(-1)[flat])
        mean_error = float(dist.mean())
        return ErrorReport(
            max_error=max_error,
            max_error_percent=_percent(max_error, self.height),
            mean_error=mean_error,
            mean_error_percent=_percent(mean_error, self.height),
            frame=frame,
            joint=self.names[point],
            height=self.height,
            units=self.skeleton.units,
            num_frames=int(dist.shape[0]),
            num_points=int(dist.shape[1]),
        )


    def points_error(self, positions: NDArray[np.float64], points: Any, comparison: Any) -> ErrorReport:
        """Compare ``(n, P, 3)`` candidate positions with the reference's points ``points`` (``P`` indices into the
        ``J + E`` FK points) of the frames ``0 .. n - 1``; the report carries ``comparison``
        (:func:`motionrep.pipeline.pairing.compared_points` gives all three)."""
        positions = np.asarray(positions, dtype=np.float64)
        idx = np.asarray(points, dtype=np.int64)
        reference = self._positions[:positions.shape[0]][:, idx] if positions.ndim == 3 else None
        if reference is None or positions.shape != reference.shape or positions.shape[0] < 1 or idx.size < 1:
            raise ValidationError(f"candidate positions must have shape (n, {idx.size}, 3) with 1 <= n <= "
                                  f"{self._positions.shape[0]}, got {positions.shape}")
        dist = np.sqrt(np.sum((positions - reference) ** 2, axis=-1))
        if not np.all(np.isfinite(dist)):
            raise ValidationError("candidate positions contain NaN or infinity")
        flat = int(np.argmax(dist))
        frame, point = divmod(flat, dist.shape[1])
        max_error = float(dist.reshape(-1)[flat])
        mean_error = float(dist.mean())
        return ErrorReport(max_error=max_error, max_error_percent=_percent(max_error, self.height),
                           mean_error=mean_error, mean_error_percent=_percent(mean_error, self.height),
                           frame=frame, joint=self.names[int(idx[point])], height=self.height,
                           units=self.skeleton.units, num_frames=int(dist.shape[0]), num_points=int(idx.size),
                           comparison=comparison)

    def frame_errors(self, positions: NDArray[np.float64], first: int | None = None) -> NDArray[np.float64]:
        """``(n,)`` largest distance of each frame (over joints and end sites), with the arguments of
        :meth:`positions_error`: one evaluation for a codec that measures many stretches of a clip at once.

        One compiled pass (``motionrep._ccore``): each distance is ``sqrt((dx dx + dy dy) + dz dz)``, the sum in
        the order :meth:`positions_error`'s numpy takes, so the two give the same bits."""
        positions = np.ascontiguousarray(positions, dtype=np.float64)
        reference = self._positions
        n = positions.shape[0] if positions.ndim == 3 else -1
        if first is not None:
            if not 0 <= first or n < 1 or first + n > reference.shape[0]:
                raise ValidationError(f"frames {first}..{first + n - 1} are not frames of the reference "
                                      f"(0..{reference.shape[0] - 1})")
            reference = reference[first:first + n]
        return self._max_distances(positions, reference)

    @staticmethod
    def _max_distances(positions: NDArray[np.float64], reference: NDArray[np.float64]) -> NDArray[np.float64]:
        """``(N,)`` largest distance of each of ``positions``' frames to the reference frame ``k % M`` of the ``M``
        in ``reference`` (checked shapes, finite)."""
        if positions.ndim != 3 or positions.shape[1:] != reference.shape[1:] or (
                positions.shape[0] % max(reference.shape[0], 1)):
            raise ValidationError(f"candidate positions must have shape {reference.shape}, got {positions.shape}")
        out = np.empty(positions.shape[0])
        if not max_distances(positions, np.ascontiguousarray(reference), out):
            raise ValidationError("candidate positions contain NaN or infinity")
        return out

    def _distances(self, positions: NDArray[np.float64], first: int | None) -> NDArray[np.float64]:
        """``(n, J + E)`` distances of candidate positions to the reference's (checked shapes, finite)."""
        positions = np.asarray(positions, dtype=np.float64)
        reference = self._positions
        if first is not None:
            n = positions.shape[0] if positions.ndim == 3 else -1
            if not 0 <= first or n < 1 or first + n > reference.shape[0]:
                raise ValidationError(f"frames {first}..{first + n - 1} are not frames of the reference "
                                      f"(0..{reference.shape[0] - 1})")
            reference = reference[first:first + n]
        if positions.shape != reference.shape:
            raise ValidationError(f"candidate positions must have shape {reference.shape}, got {positions.shape}")
        dist = np.sqrt(np.sum((positions - reference) ** 2, axis=-1))
        if not np.all(np.isfinite(dist)):
            raise ValidationError("candidate positions contain NaN or infinity")
        return dist



#: ``progress(stage, fields)``: what :meth:`MotionContext.progress` calls.
ProgressCallback = Callable[[str, Mapping[str, Any]], None]


class MotionContext:
    """The :class:`~motionrep.plugin.codec.EncodeContext` that measures candidates against one reference motion: decode
    the features through the representation, restore fixed translation axes, run FK and take the shared
    L-infinity error over every joint and end site (:class:`~motionrep.pipeline.evaluate.Evaluator`).

    :meth:`motionrep.pipeline.compress.Pipeline.compress` hands one to ``codec.encode``; the conformance suite
    (:class:`motionrep.testing.ConformanceContext`) is this class too.

    Args:
        motion: the reference clip.
        representation: the representation the features come from.
        codec: the codec being encoded with (used by :meth:`evaluate_payload`).
        params: the codec's validated ``Params``.
        bound: the bound handed to the codec, in file units, or None.
        seed: random seed.
        progress: called as ``progress(stage, fields)`` by :meth:`progress`.
        evaluator: the shared evaluator of ``motion`` (default: a new one).

    Attributes:
        times: ``(F,)`` normalised frame times (read-only).
        evaluations: how many candidates were measured.
    """

    def __init__(self, motion: Motion, representation: Representation, codec: Codec, params: Any,
                 bound: float | None = None, seed: int = 0, progress: ProgressCallback | None = None,
                 evaluator: Evaluator | None = None):
        self.motion = motion
        self.representation = representation
        self.codec = codec
        self.params = params
        self.bound = bound
        self.seed = int(seed)
        self.times = frame_times(motion.num_frames)
        self.times.flags.writeable = False
        self.evaluations = 0
        self.evaluator = evaluator if evaluator is not None else Evaluator(motion)
        self._progress = progress
        plan = representation.pose_plan(motion.skeleton)
        self._plan = None if plan is None else plan.with_fixed_axes(*fixed_axes(motion.skeleton))

    def evaluate(self, features: ArrayLike) -> ErrorReport:
        """The error of candidate ``(F, D)`` features."""
        return self.evaluator(self._decoded(features))

    def evaluate_payload(self, payload: Payload) -> ErrorReport:
        """The error of a candidate payload, decoded at the frame times."""
        return self.evaluate(self.codec.decode(payload, self.times))

    def evaluate_frames(self, features: ArrayLike, first: int) -> ErrorReport:
        """The error of candidate ``(n, D)`` features of the frames ``first .. first + n - 1`` only."""
        return self.evaluator.positions_error(global_positions(self._decoded(features)), first=int(first))

    def frame_errors(self, features: ArrayLike, first: int = 0) -> NDArray[np.float64]:
        """``(n,)`` error of each frame of candidate ``(n, D)`` features of the frames ``first ..
        first + n - 1``, in one evaluation."""
        return self.evaluator.frame_errors(self._positions(features), first=int(first))

    def feature_edits(self, features: ArrayLike) -> FeatureEdits | None:
        """Candidate ``(F, D)`` features held for editing (:class:`~motionrep.pipeline.edits.FeatureEdits`): the
        error of a change to one feature over a stretch of frames, computed only where it moves something, and
        the distance of every point in every frame.  None for a representation without a pose plan."""
        if self._plan is None:
            return None
        self.evaluations += 1
        return FeatureEdits(features, self.motion.skeleton, self._plan, self.evaluator.reference_positions)

    def feature_chain(self, features: ArrayLike) -> FeatureChain | None:
        """The clip's ``(F, D)`` features as a :class:`~motionrep.pipeline.chain.FeatureChain`: their columns in
        groups by skeleton depth, and the targets of each group from what the decoder makes of the groups before it
        (closed-loop quantisation), with sensitivities in closed loop.  None for a representation without a pose
        plan or with rotation blocks other than local quaternions and rotation vectors."""
        if not FeatureChain.supports(self._plan):
            return None
        return FeatureChain(features, self.motion.skeleton, self._plan, self._positions, self._positions_by_feature)

    def feature_sensitivity(self, features: ArrayLike) -> NDArray[np.float64]:
        """``(n, D)``: for ``n`` frames sampled evenly (:data:`SENSITIVITY_FRAMES`, fewer for wide features:
        :data:`SENSITIVITY_BUDGET`), how far a unit change of each feature moves the farthest joint or end site,
        in position units per feature unit.

        Forward differences through the representation and FK, all features at once (one decode of ``n * D``
        frames); the step of feature ``c`` is ``1e-6 (1 + max |feature c|)``. A feature that moves nothing (a
        fixed axis, a joint without descendants) gets 0.
        """
        x, h = sensitivity_steps(features)
        n, D = x.shape
        base = self._positions(x)
        pos = moved_positions(x, h, self._positions, None if self._plan is None else self._positions_by_feature)
        shift = Evaluator._max_distances(pos, base).reshape(D, n)
        return (shift / h[:, None]).T

    def _positions(self, features: ArrayLike) -> NDArray[np.float64]:
        """``(F, J + E, 3)`` FK positions of candidate features (counted in ``evaluations``).

        A representation with a pose plan decodes straight into pose arrays, its fixed translation axes set to
        the OFFSETs by the plan itself, and FK runs on those: the values of :meth:`_decoded`'s motion (the plan is
        how that representation decodes, ``Representation.pose_plan``), without building and validating a
        ``Motion``.  Features that do not decode (not finite, a zero-length quaternion) raise ``ValidationError``
        as there."""
        plan = self._plan
        if plan is None:
            return global_positions(self._decoded(features))
        self.evaluations += 1
        sk = self.motion.skeleton
        f = np.asarray(features)
        if f.ndim != 2 or f.shape[1] != plan.width:
            raise ValidationError(f"features must have shape (F, {plan.width}), got {f.shape}")
        poses = empty_poses(sk, f.shape[0])
        decode_planned(f, plan, poses.rotations, poses.root_translation, poses.joint_translations)
        return fk_arrays(sk, poses.rotations, poses.root_translation, poses.joint_translations)[0]

    def _positions_by_feature(self, X: NDArray[np.float64], count: int) -> NDArray[np.float64]:
        """:meth:`_positions` of the ``count`` poses of feature-major ``(D, count)`` C-contiguous float64 ``X``
        (:func:`motionrep.model.poseplan.decode_feature_major`; a representation with a pose plan only)."""
        self.evaluations += 1
        poses = empty_poses(self.motion.skeleton, count)
        decode_feature_major(X, count, self._plan, poses.rotations, poses.root_translation, poses.joint_translations)
        return fk_arrays(self.motion.skeleton, poses.rotations, poses.root_translation, poses.joint_translations)[0]

    def _decoded(self, features: ArrayLike) -> Motion:
        """Candidate features as the valid motion they decode to (counted in ``evaluations``)."""
        self.evaluations += 1
        return fixed_axes_restored(self.representation.from_features(features, self.motion.skeleton,
                                                                     self.motion.fps))

    def progress(self, stage: str, **fields: Any) -> None:
        """Report progress to the callback, if any."""
        if self._progress is not None:
            self._progress(stage, fields)


def max_joint_error(reference: Motion, candidate: Motion, options: Any = None) -> ErrorReport:
    """The shared L-infinity joint-position error of ``candidate`` against ``reference``.

    Args:
        reference: the original motion.
        candidate: a motion of the same skeleton (same joints, parents and end sites; offsets may differ), with
            the same number of frames and frame rate (strict), or what ``options`` allows.
        options: a :class:`motionrep.pipeline.pairing.MatchOptions` (default strict; see :mod:`motionrep.pipeline.pairing`).

    Returns:
        An :class:`ErrorReport` (file units and percent of the reference's character height).

    Raises:
        ValidationError: if the motions cannot be compared.
    """
    return Evaluator(reference)(candidate, options)


def compare(reference: Motion, candidate: Motion, options: MatchOptions = STRICT,
            evaluator: Evaluator | None = None) -> ErrorReport:
    """The shared L-infinity error of ``candidate`` against ``reference`` on the points and frames ``options``
    pair (:func:`motionrep.pipeline.pairing.compared_points`), with a :class:`~motionrep.pipeline.pairing.Comparison` saying what
    was compared and left out.

    Args:
        reference: the original motion.
        candidate: the motion after another tool.
        options: what may differ (default: nothing, as :func:`max_joint_error`).
        evaluator: an :class:`Evaluator` of ``reference``, to reuse its FK.

    Returns:
        An :class:`ErrorReport` (``frame`` a reference frame, ``joint`` a reference point name, ``num_points`` and
        ``num_frames`` what was compared, ``comparison`` the details).

    Raises:
        ValidationError: when the motions cannot be compared under ``options`` (naming the option that would).
    """
    ev = evaluator if evaluator is not None else Evaluator(reference)
    return ev(candidate, options)
