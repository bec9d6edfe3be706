"""Operations on motions: the validity fix every decoded motion gets, and the one resampler in time.

* :func:`fixed_axes_restored`: a decoded (lossy) motion made valid for its skeleton (translation axes without a
  position channel set back to the joint's OFFSET);
* :func:`resample`: a motion evaluated at another frame rate (rotations slerped, translations interpolated
  linearly); :func:`interpolate_frames` is the same at any fractional frame positions;
* :func:`resample_times`: the normalised times of a clip resampled to another frame rate, for decoders that
  evaluate a compressed clip at any time (``motionrep decompress --fps``);
* :func:`detect_up_axis`: whether a clip is Y-up or Z-up, guessed from its world positions (the glTF writer,
  the renderer, the viewer and the torch dataset all guess it this one way).

Shapes follow the pose model: ``(F, J, 4)`` xyzw rotations, ``(F, 3)`` root translation, ``(F, P, 3)``
translations of the joints with position channels.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._pose import Motion
from ..errors import ParameterError, naming
from .rotations import euler_to_quat, quat_slerp, quat_to_euler_continuous

__all__ = ["fixed_axes_restored", "resample", "resample_times", "interpolate_frames", "resampled_count",
           "detect_up_axis"]


def fixed_axes(skeleton) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """``(1 + P, 3)`` whether each translation axis of the root and of ``skeleton.translated_joints`` has no position
    channel, and the joint's OFFSET there: what :func:`fixed_axes_restored` sets such an axis to, in the form
    :meth:`motionrep.model.poseplan.PosePlan.with_fixed_axes` takes (decoding straight to the restored values)."""
    joints = [0] + skeleton.translated_joints.tolist()
    fixed = np.array([[axis not in skeleton.position_axes[j] for axis in "XYZ"] for j in joints], bool)
    return fixed, skeleton.offsets[joints].astype(np.float64)


def fixed_axes_restored(motion: Motion) -> Motion:
    """``motion`` with every translation axis that has no position channel set back to the joint's OFFSET.

    A skeleton whose root (or another translated joint) lacks a position channel on some axis cannot move along
    it: the pose model requires that axis to equal the OFFSET.  Features decoded from a lossy payload carry
    small deviations there; they are removed here (before evaluation and before writing), so every decoded
    motion is a valid motion of its skeleton and can be written to BVH.
    """
    sk = motion.skeleton
    root_axes = sk.position_axes[0]
    root = motion.root_translation
    if len(root_axes) < 3:
        root = root.copy()
        for i, axis in enumerate("XYZ"):
            if axis not in root_axes:
                root[:, i] = sk.offsets[0, i]
    jt = motion.joint_translations
    if jt is not None and jt.shape[1]:
        partial = [(k, j) for k, j in enumerate(sk.translated_joints.tolist()) if len(sk.position_axes[j]) < 3]
        if partial:
            jt = jt.copy()
            for k, j in partial:
                for i, axis in enumerate("XYZ"):
                    if axis not in sk.position_axes[j]:
                        jt[:, k, i] = sk.offsets[j, i]
    if root is motion.root_translation and jt is motion.joint_translations:
        return motion
    return motion.replace(root_translation=root, joint_translations=jt)


def _check_fps(fps: float) -> float:
    fps = float(fps)
    if not (math.isfinite(fps) and fps > 0):
        raise naming(ParameterError(f"fps must be > 0, got {fps!r}"), "fps")
    return fps


def resampled_count(num_frames: int, fps: float, new_fps: float) -> int:
    """Frames of a ``num_frames`` clip at ``fps`` resampled to ``new_fps``: the first frame at 0 s, then one every
    ``1 / new_fps`` seconds, as many as cover the clip from its first to its last frame to the nearest new frame
    (the span ``(num_frames - 1) / fps`` in new frames, rounded, halves down), so the last frame is never lost to
    a frame rate stored with a few digits (a 2.29991 s span at 30 fps is 69 intervals, 70 frames, not 69); a last
    new frame up to half a frame past the end gives the last source frame."""
    new_fps = _check_fps(new_fps)
    if num_frames <= 1:
        return 1
    # an exact half rounds down (the last new frame is never past the clip's end); 1e-9 absorbs float noise
    return int(math.ceil((num_frames - 1) / fps * new_fps - 0.5 - 1e-9)) + 1


def resample_times(num_frames: int, fps: float, new_fps: float) -> NDArray[np.float64]:
    """``(n,)`` normalised times (in [0, 1], the clip's first to last frame) of the frames of a clip resampled
    from ``fps`` to ``new_fps`` (:func:`resampled_count` frames).

    Raises:
        ParameterError: for a ``new_fps`` that is not a positive number.
    """
    count = resampled_count(num_frames, fps, new_fps)
    if num_frames == 1:
        return np.zeros(1)
    duration = (num_frames - 1) / fps
    return np.minimum(np.arange(count) / new_fps / duration, 1.0)


def interpolate_frames(motion: Motion, positions: ArrayLike, fps: float) -> Motion:
    """``motion`` evaluated at fractional frame ``positions`` ``(n,)`` (clamped to ``[0, F - 1]``), as a motion at
    ``fps``.

    Between two frames, rotations of joints with three rotation channels (and of joints without any) are slerped
    along the shorter arc; joints with one or two rotation channels interpolate their continuous Euler angles,
    so that they stay expressible with their own axes; translations are interpolated linearly.  A whole
    position gives that frame.
    """
    F = motion.num_frames
    pos = np.clip(np.asarray(positions, dtype=np.float64).reshape(-1), 0.0, F - 1)
    lo = np.floor(pos).astype(np.int64)
    hi = np.minimum(lo + 1, F - 1)
    t = pos - lo

    def lerp(a: NDArray[np.float64]) -> NDArray[np.float64]:
        w = t.reshape((-1,) + (1,) * (a.ndim - 1))
        return a[lo] + (a[hi] - a[lo]) * w

    rotations = quat_slerp(motion.rotations[lo], motion.rotations[hi], t[:, None])
    for j, order in enumerate(motion.skeleton.rotation_orders):
        if 0 < len(order) < 3:
            angles = quat_to_euler_continuous(motion.rotations[:, j], order)
            rotations[:, j] = euler_to_quat(lerp(angles), order)
    return Motion(motion.skeleton, fps, lerp(motion.root_translation), rotations, lerp(motion.joint_translations))


def resample(motion: Motion, fps: float, num_frames: int | None = None) -> Motion:
    """``motion`` at ``fps``: frame ``i`` is the motion at ``i / fps`` seconds (interpolated as in
    :func:`interpolate_frames`; times past the last frame give the last frame).

    Args:
        motion: the clip.
        fps: the new frame rate.
        num_frames: frames of the result; default :func:`resampled_count` (up to the last source frame, to the
            nearest new frame).

    Raises:
        ParameterError: for an ``fps`` that is not a positive number.
    """
    fps = _check_fps(fps)
    count = resampled_count(motion.num_frames, motion.fps, fps) if num_frames is None else int(num_frames)
    return interpolate_frames(motion, np.arange(count) * (motion.fps / fps), fps)


def detect_up_axis(positions: NDArray[np.float64]) -> str:
    """Guess whether a clip is Y-up or Z-up from its ``(F, P, 3)`` world positions.

    Only Y and Z compete (X-up files are rare).  First the floor: feet rest on the ground, so along the up axis
    the lowest point of each frame stays nearly level, while along a horizontal axis it follows the steps and
    the travel.  The axis whose lowest point varies clearly less over the frames wins.  When that does not
    decide (a single frame, a motion without ground contact), the body: a person is taller than deep most of
    the time, so Z wins only if the median per-frame extent along Z is 1.3 times that along Y; otherwise Y
    (BVH's usual convention).
    """
    pos = np.asarray(positions, dtype=np.float64)
    extent = np.median(pos.max(axis=1) - pos.min(axis=1), axis=0)
    size = float(extent.max())
    if pos.shape[0] > 1 and size > 0:
        floor_spread = pos.min(axis=1).std(axis=0) / size
        y, z = float(floor_spread[1]), float(floor_spread[2])
        if abs(y - z) > 0.02 and min(y, z) < 0.5 * max(y, z):
            return "y" if y < z else "z"
    return "z" if extent[2] > 1.3 * extent[1] else "y"
