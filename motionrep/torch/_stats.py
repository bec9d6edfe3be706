"""Normalisation statistics of a dataset's features: mean and standard deviation per feature column
(``specs/dataset.md``, "Statistics file").

Computed once over the clips of the training split (every frame of every clip counted once, whatever the
windows' stride), in float64; saved as a small JSON file (``format`` ``"motionrep-feature-stats"``,
``format_version`` 1) that names the representation, its version and the feature columns, so statistics are never
applied to features they do not describe.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import FormatError, ValidationError
from ..io import atomic_path

__all__ = ["FeatureStats", "STATS_FORMAT", "STATS_FORMAT_VERSION"]

STATS_FORMAT = "motionrep-feature-stats"
STATS_FORMAT_VERSION = 1
#: A column whose standard deviation is below this times (1 + |mean|) is constant: its std is stored as 1, so
#: normalising leaves it centred instead of dividing by (almost) zero.
CONSTANT_TOLERANCE = 1e-8


@dataclass(frozen=True, eq=False)
class FeatureStats:
    """Mean and standard deviation of each of ``D`` feature columns.

    Attributes:
        representation: the representation's registered name.
        representation_version: its version.
        names: ``D`` column names (``Representation.feature_names``).
        mean: ``(D,)`` float64.
        std: ``(D,)`` float64, > 0 (1 for a constant column).
        frames: frames counted.
        clips: names of the clips counted.
    """

    representation: str
    representation_version: int
    names: tuple[str, ...]
    mean: NDArray[np.float64]
    std: NDArray[np.float64]
    frames: int
    clips: tuple[str, ...] = ()

    @classmethod
    def from_arrays(cls, arrays: Iterable[NDArray], representation: str, representation_version: int,
                    names: Sequence[str], clips: Sequence[str] = ()) -> "FeatureStats":
        """Statistics of ``(F_i, D)`` feature arrays, one clip each (summed in float64, shifted by the first
        clip's mean so that large offsets do not cancel)."""
        D = len(names)
        total = np.zeros(D)
        squares = np.zeros(D)
        shift = None
        frames = 0
        for a in arrays:
            a = np.asarray(a, dtype=np.float64)
            if a.ndim != 2 or a.shape[1] != D:
                raise ValidationError(f"features of shape (frames, {D}) expected, got {a.shape}")
            if shift is None:
                shift = a.mean(axis=0)
            d = a - shift
            total += d.sum(axis=0)
            squares += np.einsum("fd,fd->d", d, d)
            frames += a.shape[0]
        if frames == 0 or shift is None:
            raise ValidationError("no frames to compute feature statistics from")
        m = total / frames
        var = np.maximum(squares / frames - m * m, 0.0)
        mean = shift + m
        std = np.sqrt(var)
        std = np.where(std > CONSTANT_TOLERANCE * (1.0 + np.abs(mean)), std, 1.0)
        return cls(representation, int(representation_version), tuple(names), mean, std, frames, tuple(clips))

    @property
    def width(self) -> int:
        """``D``."""
        return len(self.names)

    def check(self, representation: str, representation_version: int, names: Sequence[str]) -> None:
        """Raise ValidationError unless these statistics describe features of that representation and columns."""
        if (representation, int(representation_version)) != (self.representation, self.representation_version):
            raise ValidationError(f"feature statistics are for {self.representation!r} v{self.representation_version}"
                                  f", not {representation!r} v{representation_version}")
        if tuple(names) != self.names:
            raise ValidationError(f"feature statistics describe {self.width} columns of another skeleton "
                                  f"(this one has {len(names)})")

    def _cast(self, x: Any) -> tuple[Any, Any]:
        if type(x).__module__.startswith("torch"):
            import torch

            return (torch.as_tensor(self.mean, dtype=x.dtype, device=x.device),
                    torch.as_tensor(self.std, dtype=x.dtype, device=x.device))
        return self.mean.astype(np.result_type(x, np.float32)), self.std.astype(np.result_type(x, np.float32))

    def normalize(self, features: Any) -> Any:
        """``(features - mean) / std`` for a ``(..., D)`` numpy array or torch tensor (same type and dtype)."""
        mean, std = self._cast(features)
        return (features - mean) / std

    def denormalize(self, features: Any) -> Any:
        """The inverse of :meth:`normalize`: ``features * std + mean`` (differentiable for a tensor)."""
        mean, std = self._cast(features)
        return features * std + mean

    def to_dict(self) -> dict[str, Any]:
        """The JSON document :meth:`save` writes."""
        return {"format": STATS_FORMAT, "format_version": STATS_FORMAT_VERSION,
                "representation": self.representation, "representation_version": self.representation_version,
                "frames": self.frames, "clips": list(self.clips), "names": list(self.names),
                "mean": [float(v) for v in self.mean], "std": [float(v) for v in self.std]}

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the statistics as JSON, atomically (floats written exactly: Python's shortest round-trip form)."""
        with atomic_path(path) as tmp:
            Path(tmp).write_text(json.dumps(self.to_dict(), indent=1) + "\n", encoding="utf-8")

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> "FeatureStats":
        """Read a file :meth:`save` wrote.

        Raises:
            FormatError: naming the file when it is not a statistics file, of a newer version, or malformed.
        """
        try:
            doc = json.loads(Path(path).read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise FormatError(f"cannot read feature statistics: {exc}", path) from None
        if not isinstance(doc, dict) or doc.get("format") != STATS_FORMAT:
            raise FormatError(f"not a feature statistics file (format {STATS_FORMAT!r} expected)", path)
        version = doc.get("format_version")
        if not isinstance(version, int) or not 1 <= version <= STATS_FORMAT_VERSION:
            raise FormatError(f"feature statistics format_version {version!r}; this motionrep reads 1 to "
                              f"{STATS_FORMAT_VERSION}", path)
        try:
            names = tuple(str(n) for n in doc["names"])
            mean = np.asarray(doc["mean"], dtype=np.float64)
            std = np.asarray(doc["std"], dtype=np.float64)
            stats = cls(str(doc["representation"]), int(doc["representation_version"]), names, mean, std,
                        int(doc["frames"]), tuple(str(c) for c in doc.get("clips", [])))
        except (KeyError, TypeError, ValueError) as exc:
            raise FormatError(f"malformed feature statistics ({exc})", path) from None
        D = len(names)
        if mean.shape != (D,) or std.shape != (D,) or not (np.isfinite(mean).all() and np.isfinite(std).all()
                                                            and (std > 0).all()):
            raise FormatError(f"malformed feature statistics: mean and std must be {D} finite numbers, std > 0", path)
        return stats

    def __repr__(self) -> str:
        return f"FeatureStats({self.representation!r} v{self.representation_version}, {self.width} columns, " \
               f"{self.frames} frames)"

