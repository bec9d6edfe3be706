"""motionrep: skeletal motion capture toolkit.

Pose model (:class:`Skeleton`, :class:`Motion`), lossless BVH / NPZ / HDF5 input and output, forward kinematics,
pose representations and motion codecs as plugins, and one shared FK-based error measure.

Quaternions are ``(..., 4)`` arrays in **xyzw** order everywhere; arrays are ``(frames, joints, ...)``.
"""

from ._model import Motion, Skeleton
from .errors import MotionrepError
from .io import read, write
from .kinematics import character_height, forward_kinematics, global_positions

__version__ = "0.1.0"

__all__ = [
    "Skeleton",
    "Motion",
    "MotionrepError",
    "read",
    "write",
    "forward_kinematics",
    "global_positions",
    "character_height",
    "__version__",
]
