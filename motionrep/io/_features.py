"""Feature clips: a representation's ``(F, D)`` features stored instead of a motion.

A :class:`FeatureClip` is what ``write_features`` saves and ``read_features`` returns (NPZ and HDF5, see
``specs/formats/npz.md`` and ``specs/formats/hdf5.md``).  :func:`features_from_motion` encodes a motion with a
registered representation; :func:`motion_from_features` decodes a clip through the installed representation of
the same name, refusing a clip written by another version of it.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..model._pose import Motion, Skeleton, _checked_motion_header, _readonly
from ..errors import ValidationError

__all__ = ["FeatureClip", "features_from_motion", "motion_from_features"]


@dataclass(frozen=True, eq=False)
class FeatureClip:
    """A clip stored as a representation's features rather than as a motion.

    Args:
        skeleton: the :class:`~motionrep.Skeleton` the features describe (complete, with channel layout).
        fps: frames per second (finite, > 0).
        representation: name of the registered representation that produced the features.
        representation_version: that representation's ``version`` (integer >= 1) when the features were made.
        features: ``(F, D)`` float64, one row per frame, finite, ``F >= 1``.
        feature_names: ``D`` strings, one per feature column.

    Raises:
        ValidationError: quoting what is wrong (shape, non-finite values, a name count that is not ``D``...).
    """

    skeleton: Skeleton
    fps: float
    representation: str
    representation_version: int
    features: NDArray[np.float64]
    feature_names: tuple[str, ...]

    def __post_init__(self) -> None:
        fps = _checked_motion_header(self.skeleton, self.fps)
        if not isinstance(self.representation, str) or not self.representation:
            raise ValidationError(f"representation must be a non-empty name, got {self.representation!r}")
        version = self.representation_version
        if isinstance(version, (bool, np.bool_)) or not isinstance(version, (int, np.integer)) or version < 1:
            raise ValidationError(f"representation_version must be an integer >= 1, got {version!r}")
        try:
            features = np.array(self.features, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValidationError("features must be numeric") from None
        if features.ndim != 2 or features.shape[0] == 0:
            raise ValidationError(f"features must have shape (F, D) with F >= 1, got {features.shape}")
        if not np.all(np.isfinite(features)):
            raise ValidationError("features contain NaN or infinity")
        names = self.feature_names
        if isinstance(names, str) or not all(isinstance(n, str) for n in names):
            raise ValidationError("feature_names must be a sequence of strings")
        names = tuple(names)
        if len(names) != features.shape[1]:
            raise ValidationError(f"feature_names lists {len(names)} names for {features.shape[1]} feature columns")
        object.__setattr__(self, "fps", fps)
        object.__setattr__(self, "representation_version", int(version))
        object.__setattr__(self, "features", _readonly(features))
        object.__setattr__(self, "feature_names", names)

    @property
    def num_frames(self) -> int:
        """Number of frames ``F``."""
        return int(self.features.shape[0])

    @property
    def width(self) -> int:
        """Number of feature columns ``D``."""
        return int(self.features.shape[1])

    @property
    def duration(self) -> float:
        """Length of the clip in seconds, ``num_frames / fps``."""
        return self.num_frames / self.fps

    def __repr__(self) -> str:
        return (f"FeatureClip({self.representation!r} v{self.representation_version}, {self.num_frames} frames x "
                f"{self.width} features at {self.fps:g} fps)")


def features_from_motion(motion: Motion, representation: str) -> FeatureClip:
    """Encode ``motion`` with the registered representation named ``representation``.

    Raises:
        UnknownPluginError: listing the available representations if none has that name.
    """
    from ..plugin.registry import get_representation

    rep = get_representation(representation)
    features = rep.to_features(motion)
    return FeatureClip(motion.skeleton, motion.fps, rep.name, rep.version, features,
                       tuple(rep.feature_names(motion.skeleton)))


def motion_from_features(clip: FeatureClip, path: str | os.PathLike[str] | None = None,
                         clip_name: str | None = None) -> Motion:
    """Decode ``clip`` through the installed representation of the same name and version.

    Args:
        clip: the features.
        path: the file they came from, named in errors.
        clip_name: the clip's name in a database, named in errors.

    Raises:
        UnknownPluginError: if no installed plugin provides the representation.
        PluginVersionError: (a :class:`~motionrep.errors.FormatError`) if the installed representation's version
            differs from the stored one.
    """
    from ..plugin.registry import get_representation

    rep = get_representation(clip.representation, version=clip.representation_version, path=path, clip=clip_name)
    return rep.from_features(clip.features, clip.skeleton, clip.fps)
