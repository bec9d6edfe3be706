"""Synthetic skeletons and motions, deterministic for a seed: the demo clip, the tests and plugin authors use
them, so nothing needs a data file.

* :func:`chain_skeleton`, :func:`humanoid_skeleton` and :func:`odd_skeleton` (every unusual channel layout);
* :func:`synthetic_motion` (smooth, periodic, walking forward) and :func:`spinning_motion` (crossing every place
  a naive rotation encoding breaks);
* :func:`random_unit_quaternions`.

Quaternions are ``(..., 4)`` xyzw; arrays are ``(frames, joints, ...)``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ._pose import Motion, Skeleton
from .rotations import axis_angle_to_quat, euler_to_quat, quat_multiply

__all__ = ["SIX_ORDERS", "chain_skeleton", "humanoid_skeleton", "odd_skeleton", "synthetic_motion",
           "spinning_motion", "random_unit_quaternions"]

#: The six Tait-Bryan rotation orders BVH uses.
SIX_ORDERS: tuple[str, ...] = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")


def _channels(position: bool, order: str) -> tuple[str, ...]:
    pos = ("Xposition", "Yposition", "Zposition") if position else ()
    return pos + tuple(f"{a}rotation" for a in order)


def chain_skeleton(num_joints: int = 4, orders: tuple[str, ...] | None = None, bone: float = 10.0) -> Skeleton:
    """A single chain of ``num_joints`` joints along +Y, each ``bone`` units long, with an end site.

    Args:
        num_joints: joints in the chain (root included).
        orders: rotation order per joint (cycles through :data:`SIX_ORDERS` by default).
        bone: bone length in file units.
    """
    orders = orders or tuple(SIX_ORDERS[j % 6] for j in range(num_joints))
    offsets = np.zeros((num_joints, 3))
    offsets[1:, 1] = bone
    return Skeleton(
        names=tuple(f"j{j}" for j in range(num_joints)),
        parents=np.arange(num_joints) - 1,
        offsets=offsets,
        channels=tuple(_channels(j == 0, orders[j]) for j in range(num_joints)),
        end_site_parents=np.array([num_joints - 1]),
        end_site_offsets=np.array([[0.0, bone, 0.0]]),
    )


def humanoid_skeleton(orders: tuple[str, ...] | str = "ZXY") -> Skeleton:
    """A 15-joint humanoid (hips, spine, neck, head, two arms and two legs) about 170 units tall.

    Args:
        orders: one rotation order for every joint, or one per joint.
    """
    spec = [  # name, parent, offset
        ("Hips", -1, (0, 95, 0)),
        ("Spine", 0, (0, 12, 0)), ("Chest", 1, (0, 15, 0)), ("Neck", 2, (0, 20, 0)), ("Head", 3, (0, 10, 0)),
        ("LeftShoulder", 2, (8, 16, 0)), ("LeftArm", 5, (12, 0, 0)), ("LeftForeArm", 6, (26, 0, 0)),
        ("RightShoulder", 2, (-8, 16, 0)), ("RightArm", 8, (-12, 0, 0)), ("RightForeArm", 9, (-26, 0, 0)),
        ("LeftUpLeg", 0, (9, -5, 0)), ("LeftLeg", 11, (0, -42, 0)),
        ("RightUpLeg", 0, (-9, -5, 0)), ("RightLeg", 13, (0, -42, 0)),
    ]
    # reorder depth first so the skeleton can be written to BVH unchanged
    kids: dict[int, list[int]] = {}
    for i, (_, p, _) in enumerate(spec):
        kids.setdefault(p, []).append(i)
    dfs: list[int] = []
    stack = [0]
    while stack:
        j = stack.pop()
        dfs.append(j)
        stack.extend(reversed(kids.get(j, [])))
    new_index = {old: new for new, old in enumerate(dfs)}
    J = len(spec)
    order_list = (orders,) * J if isinstance(orders, str) else tuple(orders)
    names = tuple(spec[o][0] for o in dfs)
    parents = np.array([-1 if spec[o][1] < 0 else new_index[spec[o][1]] for o in dfs])
    offsets = np.array([spec[o][2] for o in dfs], dtype=float)
    leaves = [j for j in range(J) if j not in set(parents.tolist())]
    return Skeleton(
        names=names,
        parents=parents,
        offsets=offsets,
        channels=tuple(_channels(j == 0, order_list[j]) for j in range(J)),
        end_site_parents=np.array(leaves),
        end_site_offsets=np.array([[0.0, 8.0, 0.0] if names[j] == "Head" else
                                   ([0.0, -40.0, 10.0] if "Leg" in names[j] else
                                    [np.sign(offsets[j, 0]) * 24.0, 0.0, 0.0]) for j in leaves]),
        units="cm",
    )


def synthetic_motion(skeleton: Skeleton | None = None, frames: int = 120, fps: float = 60.0, seed: int = 0,
                     amplitude_deg: float = 40.0, cycles: float = 2.0) -> Motion:
    """A smooth, periodic motion (sums of a few sinusoids per channel) with forward root travel.

    Deterministic for ``seed``.  Angles stay within ``amplitude_deg`` of zero per axis (no gimbal lock for the
    default amplitude), so every Euler channel round-trips exactly.

    Returns:
        A :class:`~motionrep.Motion` with ``euler_branch`` unset.
    """
    sk = skeleton if skeleton is not None else humanoid_skeleton()
    rng = np.random.default_rng(seed)
    J = sk.num_joints
    t = np.arange(frames) / fps
    period = frames / fps / cycles
    angles = np.zeros((frames, J, 3))
    for h in (1, 2, 3):
        amp = rng.uniform(-1, 1, (J, 3)) * amplitude_deg / (h * 1.8)
        phase = rng.uniform(0, 2 * np.pi, (J, 3))
        angles += amp[None] * np.sin(2 * np.pi * h * t[:, None, None] / period + phase[None])
    rotations = np.empty((frames, J, 4))
    for j, order in enumerate(sk.rotation_orders):
        if order:
            rotations[:, j] = euler_to_quat(angles[:, j, :len(order)], order, degrees=True)
        else:
            rotations[:, j] = (0.0, 0.0, 0.0, 1.0)
    root = np.broadcast_to(sk.offsets[0], (frames, 3)).copy()
    scale = max(1.0, float(np.abs(sk.offsets).max()))
    root[:, 2] += 0.8 * scale * t  # walk forward
    root[:, 1] += 0.03 * scale * np.sin(4 * np.pi * t / period)  # bob
    P = sk.translated_joints.shape[0]
    jt = np.broadcast_to(sk.offsets[sk.translated_joints], (frames, P, 3)).copy()
    if P:
        jt += 0.01 * scale * np.sin(2 * np.pi * t / period)[:, None, None]
    return Motion(sk, fps, root, rotations, jt)


def random_unit_quaternions(shape: tuple[int, ...], seed: int = 0) -> NDArray[np.float64]:
    """Uniformly random unit quaternions ``shape + (4,)`` (xyzw)."""
    q = np.random.default_rng(seed).normal(size=tuple(shape) + (4,))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def odd_skeleton() -> Skeleton:
    """A 7-joint chain with every unusual channel layout a representation must handle.

    The root has rotation channels only (no position channels); ``x_only`` has one rotation channel,
    ``zy`` two; ``fixed`` has none; ``slider`` has position and rotation channels (six, as in Bandai Namco
    files); ``piston`` has position channels only; ``tip`` is a plain three-channel joint with an end site.
    """
    names = ("root", "x_only", "zy", "fixed", "slider", "piston", "tip")
    offsets = np.array([[0, 50, 0], [0, 12, 0], [0, 12, 3], [2, 10, 0], [0, 9, 0], [0, 8, 1], [0, 7, 0]], float)
    channels = (
        ("Zrotation", "Xrotation", "Yrotation"),
        ("Xrotation",),
        ("Zrotation", "Yrotation"),
        (),
        ("Xposition", "Yposition", "Zposition", "Yrotation", "Xrotation", "Zrotation"),
        ("Xposition", "Yposition", "Zposition"),
        ("Yrotation", "Zrotation", "Xrotation"),
    )
    return Skeleton(names=names, parents=np.arange(7) - 1, offsets=offsets, channels=channels,
                    end_site_parents=np.array([6]), end_site_offsets=np.array([[0.0, 6.0, 0.0]]), units="cm")


def spinning_motion(skeleton: Skeleton | None = None, frames: int = 90, fps: float = 30.0, turns: float = 2.5,
                    seed: int = 1) -> Motion:
    """A motion whose rotations cross every place a naive encoding breaks.

    The root yaws ``turns`` full turns about +Y (its quaternion must change sign on the way, unless made
    continuous), on top of :func:`synthetic_motion` at 25 degrees; the first non-root joint with three rotation
    channels twists about the first axis of its order from 0.7 pi to 1.3 pi (crossing the pi where axis-angle
    wraps and Euler angles pass +-180 degrees).
    """
    base = synthetic_motion(skeleton, frames=frames, fps=fps, seed=seed, amplitude_deg=25.0)
    sk = base.skeleton
    t = np.linspace(0.0, 1.0, frames)
    rot = base.rotations.copy()
    if sk.rotation_orders[0]:
        yaw = axis_angle_to_quat(np.outer(2 * np.pi * turns * t, [0.0, 1.0, 0.0]))
        rot[:, 0] = quat_multiply(yaw, rot[:, 0])
    twist = [j for j in range(1, sk.num_joints) if len(sk.rotation_orders[j]) == 3]
    if twist:
        j = twist[0]
        axis = np.zeros(3)
        axis["XYZ".index(sk.rotation_orders[j][0])] = 1.0
        rot[:, j] = axis_angle_to_quat(np.outer(np.pi * (0.7 + 0.6 * t), axis))
    return base.replace(rotations=rot)
