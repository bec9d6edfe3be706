"""Sample a compressed clip many times: the runtime decoder behind ``motionrep.open``.

A game samples the pose of every character every frame, a training pipeline a batch of poses per step; both
open a ``.mrc`` once and then ask for poses at arbitrary times::

    clip = motionrep.open("walk.mrc")
    pose = clip.pose(0.25)                      # one pose, t in seconds
    pose.rotations                              # (J, 4) local rotations, xyzw
    batch = clip.poses(np.linspace(0, clip.duration, 1000))   # (T, J, 4), (T, 3), (T, P, 3)
    points = clip.positions([0.0, 0.5])         # (T, J + E, 3) world positions (FK)

Opening checks the container, looks up its codec and representation and prepares everything that does not
depend on the time: the codec's decoder (``Codec.decoder``: arrays checked and converted to their working
precision), the representation's per-skeleton plan (``Representation.decode_poses``), the axes that have no
position channel, and the scratch buffers of one block of poses.  Sampling then runs the codec and the
representation block by block in one C loop (``motionrep._cplan.Runtime``: the codec decoder's C ``sampler``, then
the pose plan, ``motionrep/_c/plan``) into the caller's arrays, and one pose is one C call that also makes its
arrays; a third party's codec without a C sampler is called from Python block by block (its compiled ``kernel``,
or its ``decoder``).  Nothing else decoded is cached: memory is the prepared payload plus a few hundred kB of
buffers, whatever the clip's length.

The values are those the core measured when it wrote the file: ``motionrep.pipeline.compress.decode_at``, the one decode
path, is :meth:`Clip.motion_at` (the same prepared codec decoder, the representation's ``from_features``, whose
values its ``decode_poses`` gives too), and a time decodes to the same bits alone or in a batch.  Time
``t`` (seconds from the first frame) maps to the codec's normalised time ``t * fps / (F - 1)``, clamped to the
clip, so a frame's time gives that frame's pose (to the rounding of the time itself; :meth:`Clip.motion` decodes
the frames exactly as ``decompress``).

A :class:`Clip` keeps scratch buffers: use one per thread (the C loops release the GIL, so threads with their own
clips decode in parallel).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..model._pose import Motion, Skeleton
from ..plugin.codec import Codec, Payload, frame_times
from ..io.container import Container, read_container, unpack
from ..errors import ContainerError, MotionrepError, PayloadError, ValidationError
from ..model.kinematics import fk_arrays
from ..model.ops import fixed_axes_restored, resample_times
from ..plugin.representation import Poses, Representation, empty_poses

__all__ = ["Clip", "Pose", "open_clip", "BLOCK"]

#: Poses decoded together when the codec has no C sampler (its Python-called kernel or decoder); the C loop takes
#: 64 at a time (``motionrep._cplan.SUB_BLOCK``, or the block the codec's sampler asks for).
BLOCK = 512
_F64 = np.dtype(np.float64)
#: What a codec may raise on a damaged payload besides PayloadError; it becomes a ContainerError naming the file.
_DECODE_ERRORS = (KeyError, ValueError, IndexError, TypeError, ArithmeticError)


@dataclass(frozen=True, eq=False)
class Pose:
    """One decoded pose (fresh arrays, the caller's to keep).

    Attributes:
        rotations: ``(J, 4)`` local rotations, unit xyzw quaternions (float64, or float32 when asked for).
        root_translation: ``(3,)`` float64, the root's local translation.
        joint_translations: ``(P, 3)`` float64, local translations of ``skeleton.translated_joints``.
    """

    rotations: NDArray[np.floating]
    root_translation: NDArray[np.float64]
    joint_translations: NDArray[np.float64]


class Clip:
    """A ``.mrc`` clip opened for sampling (see the module docstring); build it with :func:`open_clip`.

    Attributes:
        skeleton: the clip's :class:`~motionrep.Skeleton`.
        fps: frames per second of the encoded clip.
        num_frames: number of encoded frames ``F``.
        duration: seconds from the first to the last frame, ``(F - 1) / fps`` (0 for one frame).
        codec, representation: names, as in the file.
        container: the parsed container.
    """

    def __init__(self, container: Container, path: Any = None, *, codec: Codec | None = None,
                 representation: Representation | None = None):
        from ..plugin.registry import get_codec, get_representation

        if codec is None:
            codec = get_codec(container.codec, version=container.codec_version, provided_by=container.codec_plugin,
                              path=path)
        if representation is None:
            representation = get_representation(container.representation, version=container.representation_version,
                                                provided_by=container.representation_plugin, path=path)
        self._rep = representation
        self._path = path
        self._codec_name = codec.name
        self.container = container
        self.skeleton: Skeleton = container.skeleton
        payload = Payload(arrays=container.arrays, info=container.info, version=container.codec_version)
        # declared sizes against the clip and the decode-work limit, before anything is decoded or allocated
        self._codec_call(codec.check_payload, payload, int(container.num_frames))
        self._decoder = self._codec_call(codec.decoder, payload)
        self.fps = float(container.fps)
        self.num_frames = int(container.num_frames)
        self.codec, self.representation = container.codec, container.representation
        self.duration = (self.num_frames - 1) / self.fps
        self._per_second = self.fps / (self.num_frames - 1) if self.num_frames > 1 else 0.0
        width = representation.width(self.skeleton)
        compiled = all(hasattr(self._decoder, a) for a in ("kernel", "kernel_args", "width"))
        sampler = getattr(self._decoder, "sampler", None)
        if (compiled or sampler is not None) and self._decoder.width != width:
            raise ContainerError(f"codec {codec.name!r} decodes {self._decoder.width} features per pose, representation "
                                 f"{representation.name!r} needs {width}", path)
        self._codec_kernel = self._decoder.kernel if compiled else None
        self._codec_args = tuple(self._decoder.kernel_args) if compiled else ()
        plan = representation.pose_plan(self.skeleton)
        if plan is not None:
            fixed, values = _fixed_axes(self.skeleton)
            self._plan: Any = plan.with_fixed_axes(fixed, values).compiled()
        else:
            self._plan = None
        from .._cplan import SUB_BLOCK, Runtime

        # the codec's C sampler and the plan in one C loop (motionrep/_c/plan/module.c), when the codec has one
        self._runtime = Runtime(self._plan, sampler, width, SUB_BLOCK, Pose) if sampler is not None else None
        # one pose in one C call (Runtime.pose_new: t checked and clamped, the Pose and its arrays made in C)
        self._pose_new = self._runtime.pose_new if self._runtime is not None and self._plan is not None else None
        self._fixed = _fixed_axes_list(self.skeleton)
        self._X = np.empty((width, BLOCK))  # one block's features, feature-major (see Codec.decoder)
        self._moved_shape = (self.skeleton.translated_joints.size, 3)
        self._one = {_F64: empty_poses(self.skeleton, 1, np.float64),
                     np.dtype(np.float32): empty_poses(self.skeleton, 1, np.float32)}
        self._time = np.zeros(1)

    def __repr__(self) -> str:
        return (f"<Clip {self.codec}/{self.representation}: {self.num_frames} frames at {self.fps:g} fps, "
                f"{self.skeleton.num_joints} joints>")

    # ---- times ----------------------------------------------------------------------------------------------
    def normalized_times(self, times: ArrayLike) -> NDArray[np.float64]:
        """``(T,)`` codec times in [0, 1] of ``times`` in seconds (clamped to the clip).

        Raises:
            ValidationError: for times that are not finite numbers.
        """
        try:
            t = np.asarray(times, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError):
            raise ValidationError("times must be numbers (seconds)") from None
        if not np.isfinite(t).all():
            raise ValidationError("times must be finite (seconds)")
        return np.clip(t * self._per_second, 0.0, 1.0)

    # ---- sampling -------------------------------------------------------------------------------------------
    def pose(self, t: float, dtype: type = np.float64) -> Pose:
        """The pose at ``t`` seconds (clamped to ``[0, duration]``).

        Args:
            t: time in seconds from the first frame.
            dtype: of the rotations, float64 (the values the core measured) or float32 (those, rounded).

        Raises:
            ValidationError: if ``t`` is not a finite number.
        """
        pose_new = self._pose_new
        if pose_new is not None and (dtype is np.float64 or dtype is np.float32):
            got = pose_new(t, self._per_second, dtype is np.float32, self._moved_shape[0])
            if type(got) is Pose:
                return got
            if got == 202:
                raise self._time_error(got, t)
            if got != 201:  # 201: not a float; float(t) below decides (a string of a number is one)
                raise self._status_error(got)
        try:
            u = float(t) * self._per_second
        except (TypeError, ValueError):
            raise self._time_error(201, t) from None
        if not math.isfinite(u):
            raise self._time_error(202, t)
        one = self._one[_F64] if dtype is np.float64 else self._one.get(np.dtype(dtype))
        if one is None:
            raise ValidationError(f"rotations can be float64 or float32, not {np.dtype(dtype)}")
        self._time[0] = min(max(u, 0.0), 1.0)
        try:
            self._decode_block(self._time, one)
        except ValidationError as exc:  # the payload decodes to no valid pose: damaged
            raise self._payload_error(exc) from None
        return Pose(one.rotations[0].copy(), one.root_translation[0].copy(), one.joint_translations[0].copy())

    @staticmethod
    def _time_error(status: int, t: Any) -> ValidationError:
        if status == 201:
            return ValidationError(f"t must be a number (seconds), got {t!r}")
        return ValidationError(f"t must be finite, got {t!r}")

    def poses(self, times: ArrayLike, dtype: type = np.float64, out: Poses | None = None) -> Poses:
        """The poses at ``times`` ``(T,)`` seconds (each clamped to ``[0, duration]``).

        Args:
            times: seconds from the first frame.
            dtype: of the rotations, float64 (the values the core measured) or float32 (those, rounded).
            out: :class:`~motionrep.plugin.representation.Poses` of ``T`` rows to write into (then ``dtype`` is
                its rotations' dtype); fresh arrays when None.

        Raises:
            ValidationError: for times that are not finite, or an ``out`` of the wrong shape.
        """
        u = self.normalized_times(times)
        if out is None:
            out = empty_poses(self.skeleton, u.size, dtype)
        elif (len(out) != u.size or out.rotations.shape[1:] != (self.skeleton.num_joints, 4)
              or out.root_translation.shape != (u.size, 3)
              or out.joint_translations.shape != (u.size, self.skeleton.translated_joints.size, 3)
              or not all(a.flags.c_contiguous for a in (out.rotations, out.root_translation, out.joint_translations))
              or out.rotations.dtype not in (np.float64, np.float32)):
            raise ValidationError(f"out must hold {u.size} poses of this skeleton (see empty_poses)")
        if self._runtime is not None and self._plan is not None:
            status = self._runtime.poses(u, out.rotations, out.root_translation, out.joint_translations)
            if status:
                raise self._status_error(status)
            return out
        try:
            for a in range(0, u.size, BLOCK):
                b = min(u.size, a + BLOCK)
                self._decode_block(u[a:b], out.rows(slice(a, b)))
        except ValidationError as exc:  # the payload decodes to no valid pose: damaged
            raise self._payload_error(exc) from None
        return out

    def positions(self, times: ArrayLike) -> NDArray[np.float64]:
        """``(T, J + E, 3)`` world positions of every joint then every end site at ``times`` seconds (FK of
        :meth:`poses`, float64: the positions the core's error measure compares)."""
        p = self.poses(times)
        return fk_arrays(self.skeleton, p.rotations, p.root_translation, p.joint_translations)[0]

    def motion(self, fps: float | None = None) -> Motion:
        """Every frame (or the clip resampled to ``fps``, at :func:`motionrep.model.ops.resample_times`) as a
        :class:`~motionrep.Motion`: what :func:`motionrep.pipeline.compress.decompress` returns."""
        if fps is None or math.isclose(fps, self.fps, rel_tol=1e-12):
            return self.motion_at(frame_times(self.num_frames))
        return self.motion_at(resample_times(self.num_frames, self.fps, float(fps)), float(fps))

    def motion_at(self, u: ArrayLike, fps: float | None = None) -> Motion:
        """The :class:`~motionrep.Motion` at normalised times ``u`` ``(T,)`` in [0, 1]: the codec's features (the
        same prepared decoder as :meth:`poses`, as float64), the representation's ``from_features`` (the values
        of ``decode_poses``, plus what a ``Motion`` keeps beside them, such as the Euler branch) and the axes
        without a position channel restored.  ``motionrep.pipeline.compress.decode_at``, the one decode path, is this."""
        u = np.ascontiguousarray(u, dtype=np.float64).reshape(-1)
        features = np.asarray(self._features_at(u), dtype=np.float64)
        try:
            motion = self._rep.from_features(features, self.skeleton, self.fps if fps is None else float(fps))
        except ValidationError as exc:  # features that are no motion (NaN, quaternions of norm 1e22): damaged
            raise self._payload_error(exc) from None
        return fixed_axes_restored(motion)

    def _features_at(self, u: NDArray[np.float64]) -> NDArray:
        return self._codec_call(self._decoder, u)

    def _codec_call(self, fn: Any, *args: Any) -> Any:
        """``fn(*args)``, a call into the codec: its ``PayloadError`` (its own words) or what else a damaged
        payload makes it raise (:data:`_DECODE_ERRORS`) becomes a ``ContainerError`` naming the file; motionrep's
        other errors pass as they are."""
        try:
            return fn(*args)
        except PayloadError as exc:
            raise self._payload_error(exc) from None
        except MotionrepError:
            raise
        except _DECODE_ERRORS as exc:
            raise self._payload_error(exc) from None

    def _payload_error(self, exc: Exception) -> ContainerError:
        what = str(exc) if isinstance(exc, (PayloadError, ValidationError)) else f"{type(exc).__name__}: {exc}"
        return ContainerError(f"codec {self._codec_name!r} cannot decode this payload: {what}", self._path)

    def _status_error(self, status: int) -> ContainerError:
        """The error of a non-zero status of the C loop: the plan's (features that are no pose) or the codec's."""
        from ..model.poseplan import _raise_for

        if status >= 100:
            return self._payload_error(PayloadError(f"the compiled decoder failed (code {status - 100})"))
        try:
            _raise_for(status)
        except ValidationError as exc:
            return self._payload_error(exc)
        return self._payload_error(PayloadError(f"the compiled decoder failed (status {status})"))

    def _decode_block(self, u: NDArray[np.float64], out: Poses) -> None:
        """Decode at most :data:`BLOCK` normalised times into ``out``: the codec's features into the block's
        feature-major scratch (its C sampler, its compiled kernel, or its Python call), then the representation's
        plan (the C kernel) or its Python path."""
        m = u.shape[0]
        X = self._X
        if self._runtime is not None:
            status = self._runtime.features(u, X)
            if status:
                raise self._status_error(status)
        elif self._codec_kernel is not None:
            kernel = self._codec_kernel
            if hasattr(kernel, "dispatcher"):  # a numba kernel (motionrep.jit): its dispatcher, built on first use
                kernel = self._codec_kernel = kernel.dispatcher
            kernel(u, X, *self._codec_args)
        else:
            features = np.asarray(self._features_at(u))
            if features.shape != (m, X.shape[0]):
                raise self._payload_error(ValueError(f"decoded features of shape {features.shape}, expected "
                                                     f"{(m, X.shape[0])}"))
            X[:, :m] = features.T
        if self._plan is not None:
            from ..model.poseplan import _raise_for

            _raise_for(self._plan.run(X, m, True, out.rotations, out.root_translation, out.joint_translations))
            return
        self._rep.decode_poses(X[:, :m].T, self.skeleton, out)
        for name, index, values in self._fixed:
            getattr(out, name)[index] = values


def _fixed_axes(skeleton: Skeleton) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """``(1 + P, 3)`` whether each translation axis of the root and of ``skeleton.translated_joints`` has no
    position channel, and the joint's OFFSET there: decoding sets such an axis back to the OFFSET, as
    ``motionrep.model.ops.fixed_axes_restored`` does for a Motion."""
    joints = [0] + skeleton.translated_joints.tolist()
    fixed = np.array([[axis not in skeleton.position_axes[j] for axis in "XYZ"] for j in joints], bool)
    return fixed, skeleton.offsets[joints].astype(np.float64)


def _fixed_axes_list(skeleton: Skeleton) -> list:
    """The same as ``(Poses attribute, index, values)`` assignments, for a representation without a plan."""
    fixed, values = _fixed_axes(skeleton)
    out = []
    if fixed[0].any():
        axes = np.flatnonzero(fixed[0])
        out.append(("root_translation", (slice(None), axes), values[0, axes]))
    k_idx, axes = np.nonzero(fixed[1:])
    if k_idx.size:
        out.append(("joint_translations", (slice(None), k_idx, axes), values[1:][k_idx, axes]))
    return out


def open_clip(source: str | os.PathLike[str] | bytes | Container) -> Clip:
    """Open a ``.mrc`` file (a path, its bytes, or a parsed container) for sampling: ``motionrep.open``.

    Raises:
        ContainerError: the file is not a valid ``.mrc`` file, or its payload does not fit its codec.
        UnknownPluginError: its codec or representation is not installed.
    """
    if isinstance(source, Container):
        return Clip(source)
    if isinstance(source, (bytes, bytearray, memoryview)):
        return Clip(unpack(bytes(source)))
    return Clip(read_container(source), path=source)

