"""Compact, lossless storage of a motion for NPZ (format version 3) and HDF5 (format version 3).

A clip read from BVH is its channel values: every array motionrep holds (quaternions, translations, the file's
Euler angles, the Euler-branch flags) is computed from the ``(F, C)`` channel matrix.  When that computation
gives back the clip's arrays **bit for bit**, only the channel matrix is stored, and the values as the decimals
they were written as: each column ``c`` as integers ``n`` with ``value = n / 10**digits[c]`` exactly (float64
division of two exact numbers is correctly rounded, as the decimal's own parsing was; ``digits[c]`` is the most
any value of the column needs, at most 12), frame-to-frame differences of those integers (``channel_deltas``,
int32 when they fit), and *patches*: the flat indices and float64 values of the values that are not such a
decimal (``-0.0``, or one odd value with 14 digits; ``channel_patches``, ``channel_patch_values``).  When more
than half of the values would be patches the matrix is kept as float64 (``channel_values``).  Any other clip
keeps the version-2 arrays.  Both formats deflate the arrays (``specs/formats/npz.md``, ``specs/formats/hdf5.md``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..model._pose import Motion, Skeleton

__all__ = ["channel_arrays", "motion_from_channel_arrays", "CHANNEL_KEYS", "MAX_DIGITS"]

#: Keys of the compact layout (logical field names; NPZ keys and HDF5 datasets of the same names).
CHANNEL_KEYS = ("channel_digits", "channel_deltas", "channel_patches", "channel_patch_values", "channel_values")
#: Most digits after the decimal point a column may have to be stored as integers.
MAX_DIGITS = 12
_NEGATIVE_ZERO = np.uint64(0x8000000000000000)


def _same(a: Any, b: Any) -> bool:
    if a is None or b is None:
        return a is None and b is None
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _decimals(values: NDArray[np.float64]) -> dict[str, NDArray] | None:
    """The integer layout of ``values`` (F, C), or None when more than half of the values would be patches."""
    F, C = values.shape
    bits = values.view(np.uint64)
    need = np.full((F, C), MAX_DIGITS + 1, np.int64)  # each value's digits after the point (13: none is enough)
    for d in range(MAX_DIGITS, -1, -1):
        scale = 10.0 ** d
        with np.errstate(all="ignore"):
            n = np.rint(values * scale)
            exact = ((n / scale).view(np.uint64) == bits) & (np.abs(n) < 2.0 ** 53)
        need[exact] = d
    short = need <= MAX_DIGITS
    digits = np.where(short, need, 0).max(axis=0, initial=0)
    scale = 10.0 ** digits
    with np.errstate(all="ignore"):
        n = np.rint(values * scale)
        exact = ((n / scale).view(np.uint64) == bits) & (np.abs(n) < 2.0 ** 53) & (bits != _NEGATIVE_ZERO)
    patches = np.flatnonzero(~exact.reshape(-1))  # -0.0 (an integer has no sign), values with more digits
    if patches.size * 2 > values.size:
        return None
    ints = np.where(exact, n, 0.0).astype(np.int64)
    deltas = np.diff(ints, axis=0, prepend=np.zeros((1, C), np.int64))
    small = deltas.size == 0 or int(np.abs(deltas).max()) < 2 ** 31
    return {"channel_digits": digits.astype(np.int8),
            "channel_deltas": deltas.astype(np.int32) if small else deltas,
            "channel_patches": patches.astype(np.int64),
            "channel_patch_values": values.reshape(-1)[patches].copy()}


def channel_arrays(motion: Motion) -> dict[str, NDArray] | None:
    """The compact arrays of ``motion``, or None when its channel values do not give back every one of its arrays
    bit for bit (a clip not read from BVH, or changed since)."""
    from ..errors import ValidationError
    from ._bvh import _motion_from_channels, channel_values

    if motion.euler_angles is None or motion.euler_branch is None:
        return None
    try:
        values = np.ascontiguousarray(channel_values(motion), dtype=np.float64)
        back = _motion_from_channels(motion.skeleton, values, motion.fps)
    except ValidationError:
        return None
    for name in ("root_translation", "rotations", "joint_translations", "euler_angles", "euler_branch"):
        if not _same(getattr(back, name), getattr(motion, name)):
            return None
    return _decimals(values) or {"channel_values": values}


def channel_matrix(digits: NDArray, deltas: NDArray, patches: NDArray, patch_values: NDArray
                   ) -> NDArray[np.float64]:
    """The ``(F, C)`` channel values of the integer layout (shapes and ranges checked by the caller)."""
    ints = np.cumsum(deltas.astype(np.int64), axis=0)
    with np.errstate(all="ignore"):
        values = ints / (10.0 ** digits.astype(np.int64))
    values.reshape(-1)[patches] = patch_values
    return values


def motion_from_channel_arrays(skeleton: Skeleton, fps: float, values: NDArray[np.float64]) -> Motion:
    """The motion of channel values, as the BVH reader builds it (the same compiled conversion)."""
    from ._bvh import _motion_from_channels

    return _motion_from_channels(skeleton, np.ascontiguousarray(values, dtype=np.float64), fps)
