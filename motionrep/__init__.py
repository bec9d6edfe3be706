"""motionrep: skeletal motion capture toolkit.

Pose model (:class:`Skeleton`, :class:`Motion`), lossless BVH / NPZ / HDF5 input and output, forward kinematics,
pose representations and motion codecs as plugins, and one shared FK-based error measure.

Quaternions are ``(..., 4)`` arrays in **xyzw** order everywhere; arrays are ``(frames, joints, ...)``.
"""

from ._version import __version__
from . import _moved

_moved.install()  # the flat layout's module names keep answering (motionrep/_moved.py)

__all__ = [
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


def open(source):  # noqa: A001 - motionrep.open, like io.open: the runtime entry point
    """Open a ``.mrc`` clip (path, bytes or container) for sampling poses: a :class:`motionrep.pipeline.runtime.Clip`
    (``clip.pose(t)``, ``clip.poses(times)``, ``clip.positions(times)``; see ``motionrep.pipeline.runtime``)."""
    from .pipeline.runtime import open_clip

    return open_clip(source)


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
