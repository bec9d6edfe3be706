"""The pose-representation interface.

A representation turns a :class:`~motionrep.Motion` into a ``(F, D)`` float64 feature matrix (one row per
frame) and back.  Codecs work on features; the shared evaluator always judges the motion decoded from them.

Plugins subclass :class:`Representation` and register an instance through the
``register_representations`` hook (see ``specs/plugins.md``).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._model import Motion, Skeleton
from .errors import ValidationError
from .kinematics import forward_kinematics

__all__ = ["Representation", "joint_reach", "check_features"]


class Representation(ABC):
    """A way to write a pose as a vector of numbers.

    Class attributes:
        name: unique name used on the command line and in files (``"root-quat-axis-angle"``).
        version: integer >= 1, stored with features in files; bump it whenever the meaning of the feature
            columns changes, and never reuse a number.
        description: one line for ``motionrep plugins``.
    """

    name: ClassVar[str]
    version: ClassVar[int]
    description: ClassVar[str] = ""

    @abstractmethod
    def width(self, skeleton: Skeleton) -> int:
        """Number of feature columns ``D`` for ``skeleton``."""

    @abstractmethod
    def feature_names(self, skeleton: Skeleton) -> list[str]:
        """A name for each of the ``D`` feature columns (e.g. ``"Hips/tx"``, ``"LeftKnee/aa_x"``)."""

    @abstractmethod
    def to_features(self, motion: Motion) -> NDArray[np.float64]:
        """Encode ``motion`` as ``(F, D)`` float64 features, continuous over frames."""

    @abstractmethod
    def from_features(self, features: ArrayLike, skeleton: Skeleton, fps: float) -> Motion:
        """Decode ``(F, D)`` features (possibly lossy, e.g. from a codec) into a valid Motion.

        Raises:
            ValidationError: if ``features`` is not ``(F, D)`` for this skeleton, or not finite.
        """

    @abstractmethod
    def weights(self, motion: Motion) -> NDArray[np.float64]:
        """``(D,)`` per-feature weights ``w`` of the Tojo et al. (2022) loss, eq. 3.

        1 for translation components; for the rotation components of a joint, the distance from that joint to
        its farthest descendant (joints and end sites) in the first frame (:func:`joint_reach`), so that
        ``w * feature error`` is roughly a joint-position error in file units.
        """

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r} v{self.version}>"


def joint_reach(motion: Motion) -> NDArray[np.float64]:
    """``(J,)`` distance from each joint to its farthest descendant (joints and end sites) in frame 0.

    A joint with no descendants has reach 0.  This is the rotation weight of Tojo et al. (2022), eq. 3.
    """
    sk = motion.skeleton
    pos = forward_kinematics(motion.frames(slice(0, 1))).positions[0]  # (J + E, 3)
    J = sk.num_joints
    owner = np.concatenate([np.arange(J), sk.end_site_parents])  # point -> joint it belongs to
    reach = np.zeros(J)
    # Walk every point up its chain of ancestors; J is small (tens to a few hundred).
    for point in range(pos.shape[0]):
        j = int(owner[point]) if point >= J else int(sk.parents[point])
        while j >= 0:
            d = float(np.linalg.norm(pos[point] - pos[j]))
            if d > reach[j]:
                reach[j] = d
            j = int(sk.parents[j])
    return reach


def check_features(features: ArrayLike, width: int, name: str) -> NDArray[np.float64]:
    """Validate ``(F, width)`` finite features for representation ``name``; return them as float64.

    Raises:
        ValidationError: naming the representation, the expected and the received shape.
    """
    try:
        f = np.asarray(features, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValidationError(f"features for representation {name!r} must be numeric") from None
    if f.ndim != 2 or f.shape[1] != width or f.shape[0] == 0:
        raise ValidationError(f"representation {name!r} expects features of shape (frames, {width}) for this "
                              f"skeleton, got {f.shape}")
    if not np.all(np.isfinite(f)):
        raise ValidationError(f"features for representation {name!r} contain NaN or infinity")
    return f
