"""The bound a comparison draws (``render``, ``view``): the one asked for, else the one a compressed candidate
was made within, read from its container (:attr:`motionrep.io.container.Container.bound`), never from text.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Sequence

from ..model._pose import Motion
from ..model.bound import MaxError
from ..model.kinematics import character_height

__all__ = ["DrawnBound", "bound_to_draw"]


@dataclass(frozen=True)
class DrawnBound:
    """A bound to draw over an error curve.

    Attributes:
        distance: the bound in file units.
        read_as: how it reads (:meth:`motionrep.model.bound.MaxError.read_as`).
        source: the compressed file whose stored bound this is; None for the bound asked for.
    """

    distance: float
    read_as: str
    source: str | os.PathLike[str] | None = None


def bound_to_draw(reference: Motion, candidates: Sequence[str | os.PathLike[str]] = (), clip: str | None = None,
                  *, max_error: MaxError | None = None, asked: bool = False) -> DrawnBound | None:
    """The bound to draw when comparing ``reference`` with ``candidates``.

    Args:
        reference: the reference clip (the height and units of a bound asked for).
        candidates: candidate files; the first compressed one (a ``.mrc`` file, or clip ``clip`` of an archive)
            that states a bound gives it, when none is asked for.
        clip: the clip of an archive.
        max_error: the bound asked for (None: none).
        asked: whether a bound was asked for (``max_error=None`` with ``asked=True``: draw none).

    Returns:
        The bound, or None for none.

    Raises:
        ParameterError: for a percentage bound of a reference whose height is 0.
        FormatError: naming a candidate that cannot be read.
    """
    from .sources import open_source

    if asked or max_error is not None:
        if max_error is None:
            return None
        height = character_height(reference.skeleton)
        return DrawnBound(max_error.bound(height), max_error.read_as(height, reference.skeleton.units))
    for path in candidates:
        with open_source(path) as src:
            if src.kind not in ("compressed", "archive"):
                continue
            c = src.container(src.resolve(clip if src.kind == "archive" else None))
        stored = c.bound
        if stored is None or stored.asked is None or stored.distance is None:
            continue
        return DrawnBound(stored.distance, stored.asked.read_as(character_height(c.skeleton), c.skeleton.units),
                          path)
    return None
