"""The demo clip shipped with motionrep (``motionrep/data/walk.bvh``) and the code that generates it.

The clip is synthetic, not captured: a 450-frame (15 s at 30 fps) walk on
:func:`motionrep.model.synthetic.humanoid_skeleton`: twelve and a half strides of about 1.2 s, a few harmonics of the
stride per joint, a vertical bob and a side sway, and forward travel of 110 cm/s.  Regenerate the shipped file
with ``python -m motionrep.io._demo`` (the test suite checks that it matches).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np

from ..model._pose import Motion
from ..model.rotations import euler_to_quat
from ..model.synthetic import humanoid_skeleton

__all__ = ["demo_walk", "DEMO_FILE", "demo_path"]

#: Name of the shipped demo clip inside the ``motionrep.data`` resources.
DEMO_FILE = "walk.bvh"

# joint -> per axis (X, Y, Z in the joint's ZXY channels) list of (harmonic, amplitude in degrees, phase)
_GAIT = {
    "Hips": {"Y": [(1, 6.0, 0.0)], "Z": [(1, 3.0, 0.5)], "X": [(2, 2.0, 0.0)]},
    "Spine": {"Y": [(1, -4.0, 0.0)], "X": [(2, 1.5, 0.3)]},
    "Chest": {"Y": [(1, -3.0, 0.2)]},
    "Neck": {"X": [(2, 2.0, 1.0)]},
    "Head": {"Y": [(1, 2.0, 0.4)]},
    "LeftUpLeg": {"X": [(1, -25.0, 0.0), (2, 4.0, 0.6)]},
    "RightUpLeg": {"X": [(1, 25.0, 0.0), (2, 4.0, 0.6)]},
    "LeftLeg": {"X": [(1, 20.0, 1.3), (2, 12.0, 0.9)]},
    "RightLeg": {"X": [(1, -20.0, 1.3), (2, 12.0, 0.9)]},
    "LeftArm": {"X": [(1, 18.0, 0.0)], "Z": [(2, 3.0, 0.2)]},
    "RightArm": {"X": [(1, -18.0, 0.0)], "Z": [(2, 3.0, 0.2)]},
    "LeftForeArm": {"X": [(1, 10.0, 0.8)]},
    "RightForeArm": {"X": [(1, -10.0, 0.8)]},
}
# static offsets of the resting pose (degrees): arms down, knees slightly bent
_REST = {"LeftArm": {"Z": -75.0}, "RightArm": {"Z": 75.0}, "LeftLeg": {"X": 8.0}, "RightLeg": {"X": 8.0},
         "LeftForeArm": {"X": 15.0}, "RightForeArm": {"X": 15.0}}


def demo_walk(frames: int = 450, fps: float = 30.0, strides: float = 12.5) -> Motion:
    """The demo walk: deterministic, ``strides`` strides (about 1.2 s each) from the first to the last frame,
    travelling along +Z.

    Returns:
        A :class:`~motionrep.Motion` on :func:`motionrep.model.synthetic.humanoid_skeleton` (ZXY channels, cm).
    """
    sk = humanoid_skeleton("ZXY")
    t = np.arange(frames) / fps
    stride_seconds = (frames - 1) / fps / strides
    phase = 2.0 * np.pi * t / stride_seconds
    J = sk.num_joints
    angles = np.zeros((frames, J, 3))  # in channel order Z, X, Y
    column = {"Z": 0, "X": 1, "Y": 2}
    for name, axes in _GAIT.items():
        j = sk.index(name)
        for axis, terms in axes.items():
            for harmonic, amplitude, offset in terms:
                angles[:, j, column[axis]] += amplitude * np.sin(harmonic * phase + offset)
    for name, axes in _REST.items():
        j = sk.index(name)
        for axis, value in axes.items():
            angles[:, j, column[axis]] += value
    rotations = euler_to_quat(angles, "ZXY", degrees=True)
    root = np.broadcast_to(sk.offsets[0], (frames, 3)).copy()
    root[:, 2] += 110.0 * t  # forward travel, cm/s
    root[:, 1] += 2.0 * np.cos(2.0 * phase)  # vertical bob, twice per stride
    root[:, 0] += 1.5 * np.sin(phase)  # side sway, once per stride
    return Motion(sk, fps, root, rotations)


def demo_path() -> Path:
    """Path of the shipped demo BVH file."""
    return Path(str(resources.files("motionrep") / "data" / DEMO_FILE))


if __name__ == "__main__":  # pragma: no cover - regenerates the shipped file
    from ._bvh import write_bvh

    target = Path(__file__).resolve().parent / "data" / DEMO_FILE
    write_bvh(demo_walk(), target, decimals=6)  # six decimals: a readable file (the clip is synthetic)
    print(f"wrote {target}")
