"""Test support for motionrep and its plugins.

Small synthetic skeletons and motions (deterministic for a seed), so tests need no data files.  Third-party
plugin authors can use these too.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ._model import Motion, Skeleton
from .rotations import euler_to_quat

__all__ = ["chain_skeleton", "humanoid_skeleton", "synthetic_motion", "SIX_ORDERS"]

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


# -------------------------------------------------------------------------------------------------------------
# Conformance suite for representation and codec plugins
#
# A plugin's own tests call these, e.g.:
#
#     from motionrep.testing import check_representation, check_codec
#
#     def test_my_representation_conforms():
#         check_representation(MyRepresentation())
#
#     def test_my_codec_conforms():
#         check_codec(MyCodec())
#
# Each check raises AssertionError (explicitly, so ``python -O`` does not strip it) with a message naming the
# plugin, the clip and what failed.
# -------------------------------------------------------------------------------------------------------------
import dataclasses as _dataclasses  # noqa: E402
import io as _io  # noqa: E402
import json as _json  # noqa: E402
import sys as _sys  # noqa: E402
from dataclasses import dataclass as _dataclass, field as _field  # noqa: E402
from typing import Any as _Any, Iterable as _Iterable, Mapping as _Mapping, Sequence as _Sequence  # noqa: E402

from .codec import Codec as _Codec, Payload as _Payload, frame_times as _frame_times  # noqa: E402
from .codec import params_help as _params_help  # noqa: E402
from .errors import BoundNotMetError as _BoundNotMetError, MotionrepError as _MotionrepError  # noqa: E402
from .errors import ParameterError as _ParameterError  # noqa: E402
from .kinematics import character_height as _character_height, global_positions as _global_positions  # noqa: E402
from .representation import Representation as _Representation  # noqa: E402
from .rotations import axis_angle_to_quat as _axis_angle_to_quat  # noqa: E402
from .rotations import quat_multiply as _quat_multiply, quat_slerp as _quat_slerp  # noqa: E402
from .rotations import quat_to_euler_continuous as _quat_to_euler_continuous  # noqa: E402

__all__ += [
    "odd_skeleton",
    "spinning_motion",
    "conformance_motions",
    "upsample_motion",
    "check_representation",
    "check_codec",
    "ConformanceContext",
    "ConformanceErrorReport",
]


def _fail(message: str) -> None:
    raise AssertionError(message)


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
        yaw = _axis_angle_to_quat(np.outer(2 * np.pi * turns * t, [0.0, 1.0, 0.0]))
        rot[:, 0] = _quat_multiply(yaw, rot[:, 0])
    twist = [j for j in range(1, sk.num_joints) if len(sk.rotation_orders[j]) == 3]
    if twist:
        j = twist[0]
        axis = np.zeros(3)
        axis["XYZ".index(sk.rotation_orders[j][0])] = 1.0
        rot[:, j] = _axis_angle_to_quat(np.outer(np.pi * (0.7 + 0.6 * t), axis))
    return base.replace(rotations=rot)


def conformance_motions() -> list[Motion]:
    """The clips :func:`check_representation` uses by default (all small, deterministic).

    A humanoid in one rotation order, a humanoid whose joints cycle through the six Tait-Bryan orders,
    :func:`odd_skeleton` (1- and 2-axis joints, a joint without rotation channels, position channels on
    non-root joints, a root without position channels), :func:`spinning_motion` on the humanoid and on the odd
    skeleton, and a one-frame clip.
    """
    mixed = humanoid_skeleton(tuple(SIX_ORDERS[j % 6] for j in range(15)))
    odd = synthetic_motion(odd_skeleton(), frames=40, fps=25.0, seed=3)
    odd = odd.replace(root_translation=np.broadcast_to(odd.skeleton.offsets[0], (40, 3)))  # no position channels
    return [
        synthetic_motion(frames=60, seed=0),
        synthetic_motion(mixed, frames=50, seed=2),
        odd,
        spinning_motion(),
        spinning_motion(odd_skeleton(), frames=60, seed=4),
        synthetic_motion(frames=1, seed=5),
    ]


def upsample_motion(motion: Motion, factor: int) -> Motion:
    """``motion`` with ``factor - 1`` frames inserted between each pair of frames.

    Rotations of joints with three rotation channels are slerped along the shorter arc; joints with one or two
    rotation channels interpolate their (continuous) Euler angles, so they stay expressible with their own
    axes; translations are interpolated linearly.  Frame ``i`` of the input is frame ``i * factor`` of the
    output, and the output's fps is ``factor`` times the input's.
    """
    F = motion.num_frames
    if F < 2 or factor < 2:
        return motion
    sk = motion.skeleton
    s = np.arange(factor) / factor  # (k,)

    def lerp(a: NDArray) -> NDArray:
        a0, a1 = a[:-1], a[1:]
        shape = (1, factor) + (1,) * (a.ndim - 1)
        out = a0[:, None] + (a1 - a0)[:, None] * s.reshape(shape)
        return np.concatenate([out.reshape(((F - 1) * factor,) + a.shape[1:]), a[-1:]], axis=0)

    q0, q1 = motion.rotations[:-1], motion.rotations[1:]  # (F-1, J, 4)
    q = _quat_slerp(q0[:, None], q1[:, None], np.broadcast_to(s[None, :, None], (F - 1, factor, q0.shape[1])))
    q = np.concatenate([q.reshape(((F - 1) * factor,) + q0.shape[1:]), motion.rotations[-1:]], axis=0)
    for j, order in enumerate(sk.rotation_orders):
        if 0 < len(order) < 3:
            angles = _quat_to_euler_continuous(motion.rotations[:, j], order)
            q[:, j] = euler_to_quat(lerp(angles), order)
    return Motion(sk, motion.fps * factor, lerp(motion.root_translation), q, lerp(motion.joint_translations))


def _label(i: int, motion: Motion) -> str:
    return f"clip {i} ({motion!r}, {motion.skeleton!r})"


def _scale(motion: Motion) -> float:
    h = _character_height(motion.skeleton)
    return h if h > 0 else 1.0


def _expect_validation_error(call, what: str) -> None:
    try:
        call()
    except _MotionrepError as exc:
        if "\n" in str(exc) or not str(exc):
            _fail(f"{what}: the error message must be one non-empty line, got {str(exc)!r}")
        return
    except Exception as exc:  # noqa: BLE001 - reporting what was raised instead
        _fail(f"{what}: expected a motionrep ValidationError, got {type(exc).__name__}: {exc}")
    _fail(f"{what}: expected a motionrep ValidationError, nothing was raised")


def check_representation(rep: _Representation, motions: _Iterable[Motion] | None = None, *,
                         tolerance: float = 1e-6, refine: int = 8) -> None:
    """Check that ``rep`` honours the :class:`~motionrep.representation.Representation` contract.

    For every clip (default :func:`conformance_motions`):

    * ``width`` equals the number of ``feature_names``, which are unique non-empty strings;
    * ``to_features`` gives finite ``(F, D)`` float64, the same on every call, and the same when the input's
      quaternions are negated at random (features depend on the pose, not on quaternion signs);
    * ``weights`` gives finite, non-negative ``(D,)`` float64;
    * ``from_features(to_features(m))`` has the same skeleton, fps and frame count, and reproduces the FK
      positions of every joint and end site, and the translations of joints with position channels, within
      ``tolerance`` times the character height;
    * features are continuous: on the clip upsampled ``refine`` times (:func:`upsample_motion`), no column
      jumps between frames by more than half its largest jump on the original clip (a continuous encoding
      shrinks its steps with the time step; a sign flip or wrap keeps its size);
    * features perturbed as a lossy codec would still decode to a valid Motion;
    * features of the wrong width, of the wrong rank, or with NaN raise a one-line
      :class:`~motionrep.errors.ValidationError`.

    Raises:
        AssertionError: naming the representation, the clip and the failed property.
    """
    who = f"representation {getattr(rep, 'name', rep)!r}"
    if not isinstance(rep, _Representation):
        _fail(f"{who}: is not a motionrep.representation.Representation")
    if not isinstance(rep.name, str) or not rep.name or rep.name != rep.name.strip():
        _fail(f"{who}: name must be a non-empty string without surrounding spaces")
    if isinstance(rep.version, bool) or not isinstance(rep.version, int) or rep.version < 1:
        _fail(f"{who}: version must be an integer >= 1, got {rep.version!r}")
    if not isinstance(rep.description, str):
        _fail(f"{who}: description must be a string")
    clips = list(conformance_motions() if motions is None else motions)
    if not clips:
        _fail(f"{who}: no clips to check")
    rng = np.random.default_rng(0)
    for i, m in enumerate(clips):
        where = f"{who}, {_label(i, m)}"
        sk, F = m.skeleton, m.num_frames
        D = rep.width(sk)
        names = rep.feature_names(sk)
        if not isinstance(D, (int, np.integer)) or D < 1:
            _fail(f"{where}: width must be a positive integer, got {D!r}")
        if len(names) != D or len(set(names)) != D or not all(isinstance(n, str) and n for n in names):
            _fail(f"{where}: feature_names must be {D} unique non-empty strings, got {len(names)} "
                  f"({len(set(names))} distinct)")
        feats = rep.to_features(m)
        if not isinstance(feats, np.ndarray) or feats.dtype != np.float64 or feats.shape != (F, D):
            _fail(f"{where}: to_features must return float64 ({F}, {D}), got "
                  f"{getattr(feats, 'dtype', type(feats))} {getattr(feats, 'shape', '')}")
        if not np.all(np.isfinite(feats)):
            _fail(f"{where}: to_features returned NaN or infinity")
        if not np.array_equal(rep.to_features(m), feats):
            _fail(f"{where}: to_features is not deterministic")
        scale = _scale(m)
        fscale = 1e-9 * (1.0 + np.abs(feats).max(axis=0))
        signs = np.where(rng.random(m.rotations.shape[:2]) < 0.5, -1.0, 1.0)
        flipped = rep.to_features(m.replace(rotations=m.rotations * signs[..., None], euler_branch=m.euler_branch))
        bad = np.abs(flipped - feats) > fscale
        if bad.any():
            f, c = np.argwhere(bad)[0]
            _fail(f"{where}: features depend on quaternion signs: column {names[c]!r} at frame {f} is "
                  f"{feats[f, c]!r} but {flipped[f, c]!r} once some input quaternions are negated")
        w = rep.weights(m)
        if not isinstance(w, np.ndarray) or w.dtype != np.float64 or w.shape != (D,):
            _fail(f"{where}: weights must return float64 ({D},), got {getattr(w, 'dtype', type(w))} "
                  f"{getattr(w, 'shape', '')}")
        if not np.all(np.isfinite(w)) or np.any(w < 0):
            _fail(f"{where}: weights must be finite and >= 0")
        decoded = rep.from_features(feats, sk, m.fps)
        if not isinstance(decoded, Motion):
            _fail(f"{where}: from_features must return a Motion, got {type(decoded).__name__}")
        if decoded.skeleton != sk or decoded.fps != m.fps or decoded.num_frames != F:
            _fail(f"{where}: from_features changed the skeleton, fps or frame count")
        err = np.linalg.norm(_global_positions(decoded) - _global_positions(m), axis=-1)
        if err.max() > tolerance * scale:
            f, p = np.unravel_index(int(err.argmax()), err.shape)
            _fail(f"{where}: round trip moves point {p} at frame {f} by {err.max():.3g} file units, more than "
                  f"{tolerance:g} x the character height ({scale:.6g})")
        if m.joint_translations.size:
            terr = np.abs(decoded.joint_translations - m.joint_translations).max()
            if terr > tolerance * scale:
                _fail(f"{where}: round trip changes joint translations by {terr:.3g}")
        if F >= 2:
            _check_continuity(rep, m, feats, names, refine, where)
        noise = rng.normal(size=feats.shape) * 1e-3 * (1.0 + np.abs(feats).max(axis=0))
        try:
            lossy = rep.from_features(feats + noise, sk, m.fps)
        except Exception as exc:  # noqa: BLE001
            _fail(f"{where}: slightly perturbed features (as from a lossy codec) failed to decode: "
                  f"{type(exc).__name__}: {exc}")
        if not isinstance(lossy, Motion) or lossy.num_frames != F:
            _fail(f"{where}: perturbed features did not decode to a {F}-frame Motion")
        _expect_validation_error(lambda: rep.from_features(np.zeros((F, D + 1)), sk, m.fps),
                                 f"{where}: features of width {D + 1}")
        _expect_validation_error(lambda: rep.from_features(np.zeros(D), sk, m.fps), f"{where}: 1-D features")
        nan = feats.copy()
        nan[0, 0] = np.nan
        _expect_validation_error(lambda: rep.from_features(nan, sk, m.fps), f"{where}: features with NaN")


def _check_continuity(rep: _Representation, motion: Motion, feats: NDArray, names: _Sequence[str], refine: int,
                      where: str) -> None:
    fine = rep.to_features(upsample_motion(motion, refine))
    coarse_jump = np.abs(np.diff(feats, axis=0)).max(axis=0)
    fine_jump = np.abs(np.diff(fine, axis=0))
    floor = 1e-9 * (1.0 + np.abs(feats).max(axis=0))
    bad = fine_jump > 0.5 * coarse_jump + floor
    if bad.any():
        f, c = np.argwhere(bad)[0]
        _fail(f"{where}: column {names[c]!r} is not continuous: on the clip upsampled {refine}x it jumps by "
              f"{fine_jump[f, c]:.6g} between frames {f} and {f + 1}, while its largest jump between the "
              f"original frames is {coarse_jump[c]:.6g} (a sign flip or wrap-around?)")


@_dataclass(frozen=True)
class ConformanceErrorReport:
    """The L-infinity FK error the conformance context measures.

    Attributes:
        max_error: largest distance over all frames, joints and end sites, in file units.
        max_error_percent: the same as a percentage of the character height.
        frame: frame of the largest distance.
        point: joint (or end site, after the joints) of the largest distance.
    """

    max_error: float
    max_error_percent: float
    frame: int
    point: int


@_dataclass
class ConformanceContext:
    """A self-contained :class:`~motionrep.codec.EncodeContext` for testing codecs.

    It measures candidates the way the core does: decode the features through ``representation``, run FK and
    take the largest distance to ``motion``'s joints and end sites.

    Attributes:
        motion: the reference clip.
        representation: the representation the features come from.
        codec: the codec under test (used by :meth:`evaluate_payload`).
        params: the codec's validated ``Params``.
        bound: error bound in file units, or None.
        seed: random seed.
        times: ``(F,)`` normalised frame times.
        progress_log: every :meth:`progress` call, as ``(stage, fields)``.
    """

    motion: Motion
    representation: _Representation
    codec: _Codec
    params: _Any
    bound: float | None = None
    seed: int = 0
    times: NDArray[np.float64] = _field(default_factory=lambda: np.zeros(0))
    progress_log: list[tuple[str, dict[str, _Any]]] = _field(default_factory=list)

    def __post_init__(self) -> None:
        if self.times.size == 0:
            self.times = _frame_times(self.motion.num_frames)
        self._reference = _global_positions(self.motion)

    def evaluate(self, features: _Any) -> ConformanceErrorReport:
        """Error of candidate ``(F, D)`` features."""
        return self._measure(features, self._reference, 0)

    def evaluate_payload(self, payload: _Payload) -> ConformanceErrorReport:
        """Error of a candidate payload, decoded at the frame times."""
        return self.evaluate(self.codec.decode(payload, self.times))

    def evaluate_frames(self, features: _Any, first: int) -> ConformanceErrorReport:
        """Error of candidate ``(n, D)`` features of the frames ``first .. first + n - 1``."""
        return self._measure(features, self._reference[first:first + np.shape(features)[0]], first)

    def _measure(self, features: _Any, reference: NDArray[np.float64], first: int) -> ConformanceErrorReport:
        m = self.representation.from_features(features, self.motion.skeleton, self.motion.fps)
        err = np.linalg.norm(_global_positions(m) - reference, axis=-1)
        f, p = np.unravel_index(int(err.argmax()), err.shape)
        worst = float(err.max())
        return ConformanceErrorReport(worst, 100.0 * worst / _scale(self.motion), int(f) + first, int(p))

    def progress(self, stage: str, **fields: _Any) -> None:
        """Record a progress report."""
        self.progress_log.append((stage, dict(fields)))


def _payload_arrays(payload: _Payload, where: str) -> dict[str, NDArray]:
    if not isinstance(payload, _Payload):
        _fail(f"{where}: encode must return a motionrep.codec.Payload, got {type(payload).__name__}")
    arrays = dict(payload.arrays)
    if not arrays:
        _fail(f"{where}: the payload stores no arrays")
    for key, a in arrays.items():
        if not isinstance(key, str) or not key:
            _fail(f"{where}: payload array names must be non-empty strings, got {key!r}")
        if not isinstance(a, np.ndarray) or a.dtype.kind not in "biuf":
            _fail(f"{where}: payload array {key!r} must be a numeric numpy array, got "
                  f"{getattr(a, 'dtype', type(a))}")
    try:
        _json.dumps(dict(payload.info))
    except (TypeError, ValueError) as exc:
        _fail(f"{where}: payload info must be JSON-serialisable: {exc}")
    return arrays


def check_codec(codec: _Codec, motions: _Iterable[Motion] | None = None,
                representation: _Representation | str = "root-quat-axis-angle", *,
                params: _Mapping[str, _Any] | None = None, bound_fraction: float | None = 0.05,
                bound_params: _Mapping[str, _Any] | None = None, seed: int = 0) -> list[dict[str, _Any]]:
    """Check that ``codec`` honours the :class:`~motionrep.codec.Codec` contract.

    * ``name``, ``format_version`` and ``Params`` are valid; every parameter has a default and a help text;
      ``parse_params({})`` works and an unknown parameter raises :class:`~motionrep.errors.ParameterError`.
    * For every clip (default: one small :func:`synthetic_motion`), encoded from ``representation`` with
      ``params`` and no bound: ``encode`` returns a :class:`~motionrep.codec.Payload` of named numeric arrays
      with JSON-serialisable ``info``; the same seed gives the same arrays, byte for byte; ``decode`` gives
      finite ``(T, D)`` float64 at any times in [0, 1] (also one time, and a subset gives the same rows); the
      arrays survive a save to ``.npz`` and back; ``decode`` does not import torch.
    * With ``bound_fraction`` (times the character height) as the bound, ``encode`` either returns a payload
      whose error, measured by FK, is within the bound, or raises
      :class:`~motionrep.errors.BoundNotMetError` reporting a best error above it.

    Args:
        codec: the codec instance.
        motions: clips to encode.
        representation: a Representation or the name of a registered one.
        params: codec parameters for the encode without a bound (strings allowed, as from the command line).
        bound_fraction: the bound for the bounded encode, as a fraction of the character height; None skips it.
        bound_params: codec parameters for the bounded encode (default: ``params``), e.g. without the fixed
            size that ``params`` needs when there is no bound.
        seed: the seed handed to the codec.

    Returns:
        One dict per clip: ``num_parameters``, ``max_error`` (unbounded encode) and ``bounded_error`` (None if
        skipped or the bound was not met).

    Raises:
        AssertionError: naming the codec, the clip and the failed property.
    """
    who = f"codec {getattr(codec, 'name', codec)!r}"
    if not isinstance(codec, _Codec):
        _fail(f"{who}: is not a motionrep.codec.Codec")
    if not isinstance(codec.name, str) or not codec.name or codec.name != codec.name.strip():
        _fail(f"{who}: name must be a non-empty string without surrounding spaces")
    fv = codec.format_version
    if isinstance(fv, bool) or not isinstance(fv, int) or fv < 1:
        _fail(f"{who}: format_version must be an integer >= 1, got {fv!r}")
    if codec.readable_versions and fv not in codec.readable_versions:
        _fail(f"{who}: readable_versions {codec.readable_versions} must include format_version {fv}")
    if not _dataclasses.is_dataclass(codec.Params):
        _fail(f"{who}: Params must be a dataclass")
    for f in _dataclasses.fields(codec.Params):
        if f.default is _dataclasses.MISSING and f.default_factory is _dataclasses.MISSING:
            _fail(f"{who}: parameter {f.name!r} has no default")
    for entry in _params_help(codec.Params):
        if not entry["help"]:
            _fail(f"{who}: parameter {entry['name']!r} has no help text (field metadata['help'])")
    try:
        codec.parse_params({})
    except Exception as exc:  # noqa: BLE001
        _fail(f"{who}: parse_params({{}}) failed: {type(exc).__name__}: {exc}")
    try:
        codec.parse_params({"no_such_parameter_xyz": "1"})
    except _ParameterError:
        pass
    else:
        _fail(f"{who}: an unknown parameter must raise ParameterError")
    if isinstance(representation, str):
        from .plugins import get_representation

        representation = get_representation(representation)
    p = codec.parse_params(dict(params or {}))
    bp = p if bound_params is None else codec.parse_params(dict(bound_params))
    clips = list([synthetic_motion(frames=48, seed=7)] if motions is None else motions)
    results = []
    for i, m in enumerate(clips):
        where = f"{who}, {_label(i, m)}"
        feats = representation.to_features(m)
        w = representation.weights(m)
        F, D = feats.shape
        ctx = ConformanceContext(m, representation, codec, p, None, seed)
        payload = codec.encode(feats.copy(), w.copy(), ctx)
        arrays = _payload_arrays(payload, where)
        again = _payload_arrays(codec.encode(feats.copy(), w.copy(),
                                             ConformanceContext(m, representation, codec, p, None, seed)), where)
        if sorted(again) != sorted(arrays) or any(
                again[k].dtype != arrays[k].dtype or again[k].tobytes() != arrays[k].tobytes() for k in arrays):
            _fail(f"{where}: encoding twice with seed {seed} gave different payloads")
        torch_before = "torch" in _sys.modules
        out = codec.decode(payload, ctx.times)
        if not torch_before and "torch" in _sys.modules:
            _fail(f"{where}: decode imported torch (decoding must work without it)")
        if not isinstance(out, np.ndarray) or out.dtype != np.float64 or out.shape != (F, D):
            _fail(f"{where}: decode must return float64 ({F}, {D}), got {getattr(out, 'dtype', type(out))} "
                  f"{getattr(out, 'shape', '')}")
        if not np.all(np.isfinite(out)):
            _fail(f"{where}: decode returned NaN or infinity")
        sub = codec.decode(payload, ctx.times[::2])
        if sub.shape != (len(ctx.times[::2]), D) or not np.allclose(sub, out[::2], rtol=1e-9, atol=1e-9):
            _fail(f"{where}: decoding a subset of the times must give the same rows")
        one = codec.decode(payload, np.array([0.5]))
        if one.shape != (1, D) or not np.all(np.isfinite(one)):
            _fail(f"{where}: decoding at one time must give finite (1, {D}) features")
        buf = _io.BytesIO()
        np.savez(buf, **arrays)
        buf.seek(0)
        with np.load(buf) as loaded:
            stored = _Payload({k: loaded[k] for k in loaded.files}, dict(payload.info))
        if not np.array_equal(codec.decode(stored, ctx.times), out):
            _fail(f"{where}: the payload decodes differently after a save to .npz and back")
        result: dict[str, _Any] = {"num_parameters": payload.num_parameters,
                                   "max_error": ctx.evaluate(out).max_error, "bounded_error": None}
        if bound_fraction is not None:
            bound = bound_fraction * _scale(m)
            bctx = ConformanceContext(m, representation, codec, bp, bound, seed)
            try:
                bounded = codec.encode(feats.copy(), w.copy(), bctx)
            except _BoundNotMetError as exc:
                if exc.best_error is not None and not exc.best_error > bound:
                    _fail(f"{where}: BoundNotMetError reports a best error {exc.best_error:.6g} within the bound "
                          f"{bound:.6g}")
            else:
                _payload_arrays(bounded, where)
                reached = bctx.evaluate_payload(bounded).max_error
                if reached > bound * (1 + 1e-9):
                    _fail(f"{where}: with bound {bound:.6g} the payload's error is {reached:.6g}")
                result["bounded_error"] = reached
        results.append(result)
    return results
