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

__all__ = [
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
