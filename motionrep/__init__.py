"""motionrep: skeletal motion capture toolkit.

Pose model (:class:`Skeleton`, :class:`Motion`), lossless BVH / NPZ / HDF5 input and output, forward kinematics,
pose representations and motion codecs as plugins, and one shared FK-based error measure.

Quaternions are ``(..., 4)`` arrays in **xyzw** order everywhere; arrays are ``(frames, joints, ...)``.
"""

__version__ = "0.1.0"

from ._model import Motion, Skeleton  # noqa: E402
from .errors import MotionrepError  # noqa: E402
from .hookspecs import hookimpl  # noqa: E402
from .io import FeatureClip, read, write  # noqa: E402
from .kinematics import character_height, forward_kinematics, global_positions  # noqa: E402



def open(source):  # noqa: A001 - motionrep.open, like io.open: the runtime entry point
    """Open a ``.mrc`` clip (path, bytes or container) for sampling poses: a :class:`motionrep.runtime.Clip`
    (``clip.pose(t)``, ``clip.poses(times)``, ``clip.positions(times)``; see ``motionrep.runtime``)."""
    from .runtime import open_clip

    return open_clip(source)


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
