"""motionrep: skeletal motion capture toolkit.

Pose model (:class:`Skeleton`, :class:`Motion`), lossless BVH / NPZ / HDF5 input and output, forward kinematics,
pose representations and motion codecs as plugins, and one shared FK-based error measure.

Quaternions are ``(..., 4)`` arrays in **xyzw** order everywhere; arrays are ``(frames, joints, ...)``.

The main verbs are functions here: :func:`compress` (a motion to ``.mrc`` bytes within an error bound),
:func:`decompress` (``.mrc`` bytes or file to a motion), :func:`evaluate` (the shared L-infinity error of one
motion against another) and :func:`open` (a ``.mrc`` clip for sampling poses at any time); with :func:`read` and
:func:`write` for files.
"""

from __future__ import annotations

import os as _os
import sys as _sys
import types as _types

from ._version import __version__
from . import _moved
from .defaults import DEFAULT_CODEC, DEFAULT_MAX_ERROR, DEFAULT_REPRESENTATION

#: ``typing.TYPE_CHECKING`` without importing ``typing`` (type checkers take any name spelled so as True).
TYPE_CHECKING = False
if TYPE_CHECKING:  # what the public names are, for type checkers; at run time they are imported on first use
    from typing import Callable, Mapping

    from .errors import MotionrepError
    from .io import FeatureClip, read, write
    from .io.container import Container
    from .model._pose import Motion, Skeleton
    from .model.bound import MaxError
    from .model.kinematics import character_height, forward_kinematics, global_positions
    from .pipeline.compress import CompressResult
    from .pipeline.evaluate import ErrorReport
    from .pipeline.pairing import MatchOptions
    from .pipeline.runtime import Clip
    from .plugin.hookspecs import hookimpl

_moved.install()  # the flat layout's module names keep answering (motionrep/_moved.py)

__all__ = [
    "compress",
    "decompress",
    "evaluate",
    "open",
    "Skeleton",
    "Motion",
    "MotionrepError",
    "hookimpl",
    "FeatureClip",
    "read",
    "write",
    "forward_kinematics",
    "global_positions",
    "character_height",
    "__version__",
]

# The public names are imported on first use (PEP 562), so `import motionrep` -- and `motionrep --help`, which
# only needs the version -- starts without numpy.
_PUBLIC = {
    "Skeleton": ".model._pose", "Motion": ".model._pose", "MotionrepError": ".errors", "hookimpl": ".plugin.hookspecs",
    "FeatureClip": ".io", "read": ".io", "write": ".io", "forward_kinematics": ".model.kinematics",
    "global_positions": ".model.kinematics", "character_height": ".model.kinematics",
}


def compress(motion: Motion, codec: str = DEFAULT_CODEC, *, max_error: str | float | MaxError | None = DEFAULT_MAX_ERROR,
             representation: str = DEFAULT_REPRESENTATION, params: Mapping[str, object] | None = None, seed: int = 0,
             progress: Callable[[str, Mapping[str, object]], None] | None = None) -> CompressResult:
    """Compress ``motion`` into ``.mrc`` bytes whose decoded motion is within ``max_error`` of it.

    Args:
        motion: the clip (``motion.num_frames`` frames of ``motion.skeleton``).
        codec: a registered codec's name (``"transform"``, ``"svd"``, ``"adaptive-fourier"``...).
        max_error: the bound on the L-infinity joint-position error: ``"2%"`` of the character height, a
            distance in file units (``0.5``), or None for no bound (then the codec's size parameters decide).
        representation: the pose representation the codec sees.
        params: the codec's parameters (``{"rank": 8}``; ``motionrep plugins`` lists them).
        seed: the seed of any randomness (the same seed gives the same bytes).
        progress: called as ``progress(stage, fields)`` while the codec works.

    Returns:
        A :class:`motionrep.pipeline.compress.CompressResult`: ``data`` (the ``.mrc`` bytes), ``container``,
        ``report`` (the error of the stored payload, an :class:`ErrorReport`), ``figures`` (sizes and ratios),
        ``bound`` (in file units) and ``seconds``.

    Raises:
        UnknownPluginError: an unknown codec or representation.
        ParameterError: invalid parameters or bound (before any work).
        BoundNotMetError: the codec could not meet the bound.
    """
    from .pipeline.compress import compress_motion

    return compress_motion(motion, codec, representation=representation, max_error=max_error,
                           params=params, seed=seed, progress=progress)


def decompress(source: bytes | str | _os.PathLike[str] | Container, fps: float | None = None) -> Motion:
    """Decode a compressed clip: ``.mrc`` bytes, a ``.mrc`` file's path or a parsed container, to a
    :class:`Motion` of ``num_frames`` frames at its own frame rate, or resampled to ``fps`` (decoded at the new
    frame times).

    Raises:
        ContainerError: not a valid ``.mrc`` file (truncated, altered, an unknown version).
        UnknownPluginError: its codec or representation is not installed.
    """
    from .pipeline.decode import decompress as decode

    if isinstance(source, (str, _os.PathLike)):
        from .io.container import read_container

        return decode(read_container(source), fps, path=source)
    return decode(source, fps)


def evaluate(reference: Motion, candidate: Motion, options: MatchOptions | None = None) -> ErrorReport:
    """The shared L-infinity joint-position error of ``candidate`` against ``reference`` (forward kinematics of
    both, every joint and end site of every frame): an :class:`ErrorReport` with ``max_error`` (file units),
    ``max_error_percent`` (of the reference's character height), ``mean_error``, the worst ``frame`` and ``joint``.

    Args:
        reference: the original motion.
        candidate: the same skeleton with the same frames and frame rate, or what ``options`` (a
            :class:`motionrep.pipeline.pairing.MatchOptions`) allows: matching by names, resampling...

    Raises:
        ValidationError: the motions cannot be compared (naming the option that would let them).
    """
    from .pipeline.evaluate import compare
    from .pipeline.pairing import STRICT

    return compare(reference, candidate, STRICT if options is None else options)


def open(source: str | _os.PathLike[str] | bytes | Container) -> Clip:  # noqa: A001 - motionrep.open, like io.open
    """Open a ``.mrc`` clip (path, bytes or container) for sampling poses: a :class:`motionrep.pipeline.runtime.Clip`
    (``clip.pose(t)``, ``clip.poses(times)``, ``clip.positions(times)``; see ``motionrep.pipeline.runtime``)."""
    from .pipeline.runtime import open_clip

    return open_clip(source)


class _FrontDoor(_types.ModuleType):
    """``motionrep`` itself: importing an old flat module name that is also a verb (``import motionrep.compress``,
    ``motionrep.evaluate``; motionrep/_moved.py) still gives that module to the importer, and leaves the verb
    under the package's name (the import system would bind the module there)."""

    def __setattr__(self, name: str, value: object) -> None:
        if name in _VERBS and isinstance(value, _types.ModuleType):
            return
        super().__setattr__(name, value)


_VERBS = frozenset({"compress", "decompress", "evaluate", "open"})
_sys.modules[__name__].__class__ = _FrontDoor


def __getattr__(name: str):
    module = _PUBLIC.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
