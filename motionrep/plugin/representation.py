"""The pose-representation interface.

A representation turns a :class:`~motionrep.Motion` into a ``(F, D)`` float64 feature matrix (one row per
frame) and back.  Codecs work on features; the shared evaluator always judges the motion decoded from them.

Plugins subclass :class:`Representation` and register an instance through the
``register_representations`` hook (see ``specs/plugins.md``).
"""

from __future__ import annotations

import functools
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, Callable, ClassVar, Sequence, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..model._pose import Motion, Skeleton
from ..errors import ValidationError
from ..model.kinematics import forward_kinematics
from ..model.poseplan import PosePlan, decode_planned

__all__ = ["Representation", "TorchPath", "joint_reach", "check_features", "FeatureLayout", "feature_layout", "per_skeleton",
           "representation_problems", "Poses", "empty_poses", "motion_from_poses", "decoded_motion", "PosePlan"]


@dataclass(frozen=True, eq=False)
class Poses:
    """Decoded poses as plain arrays: what :meth:`Representation.decode_poses` writes and the runtime decoder
    (``motionrep.open``) returns.

    Attributes:
        root_translation: ``(T, 3)`` float64, the root's local translation.
        rotations: ``(T, J, 4)`` local rotations, unit xyzw quaternions (float64, or float32 when asked for).
        joint_translations: ``(T, P, 3)`` float64, local translations of ``skeleton.translated_joints``.
    """

    root_translation: NDArray[np.float64]
    rotations: NDArray[np.floating]
    joint_translations: NDArray[np.float64]

    def __len__(self) -> int:
        return int(self.rotations.shape[0])

    def rows(self, index: slice) -> "Poses":
        """The poses ``index`` selects (views)."""
        return Poses(self.root_translation[index], self.rotations[index], self.joint_translations[index])


def empty_poses(skeleton: Skeleton, count: int, dtype: type = np.float64) -> Poses:
    """Uninitialised :class:`Poses` for ``count`` poses of ``skeleton``, rotations in ``dtype`` (float64 or
    float32)."""
    if np.dtype(dtype) not in (np.dtype(np.float64), np.dtype(np.float32)):
        raise ValidationError(f"rotations can be float64 or float32, not {np.dtype(dtype)}")
    P = skeleton.translated_joints.shape[0]
    return Poses(np.empty((count, 3)), np.empty((count, skeleton.num_joints, 4), dtype), np.empty((count, P, 3)))


def motion_from_poses(poses: Poses, skeleton: Skeleton, fps: float, **extra) -> Motion:
    """The validated :class:`Motion` of ``poses`` (float64; ``extra`` as ``Motion``'s ``euler_branch``)."""
    return Motion(skeleton, fps, poses.root_translation, poses.rotations, poses.joint_translations, **extra)


def decoded_motion(representation: "Representation", features: ArrayLike, skeleton: Skeleton, fps: float,
                   **extra) -> Motion:
    """``from_features`` for a representation that implements :meth:`Representation.decode_poses`: decode into
    fresh :class:`Poses` and build the :class:`Motion` of them, so both give the same values."""
    try:
        rows = np.shape(features)[0] if np.ndim(features) == 2 else 0
    except (TypeError, ValueError):  # not an array at all: decode_poses says so
        rows = 0
    poses = empty_poses(skeleton, rows)
    representation.decode_poses(features, skeleton, poses)
    return motion_from_poses(poses, skeleton, fps, **extra)


class Representation(ABC):
    """A way to write a pose as a vector of numbers.

    Class attributes:
        name: unique name used on the command line and in files (``"root-quat-axis-angle"``).
        version: integer >= 1, stored with features in files; bump it whenever the meaning of the feature
            columns changes, and never reuse a number.
        description: one line for ``motionrep plugins``.
    """

    name: ClassVar[str]
    version: ClassVar[int]
    description: ClassVar[str] = ""

    def layout(self, skeleton: Skeleton) -> "FeatureLayout":
        """The :class:`FeatureLayout` of ``skeleton``'s feature columns (optional).

        A representation whose columns follow :func:`feature_layout` returns it here (decorate the function that
        builds it with :func:`per_skeleton`), and :meth:`width` and :meth:`feature_names` follow from it; one that
        does not overrides those two instead.
        """
        raise NotImplementedError(f"representation {self.name!r} defines neither layout() nor width() and "
                                  "feature_names()")

    def width(self, skeleton: Skeleton) -> int:
        """Number of feature columns ``D`` for ``skeleton`` (default: ``layout(skeleton).width``)."""
        return self.layout(skeleton).width

    def feature_names(self, skeleton: Skeleton) -> list[str]:
        """A name for each of the ``D`` feature columns (e.g. ``"Hips/tx"``, ``"LeftKnee/aa_x"``; default:
        ``layout(skeleton).names``)."""
        return list(self.layout(skeleton).names)

    @abstractmethod
    def to_features(self, motion: Motion) -> NDArray[np.float64]:
        """Encode ``motion`` as ``(F, D)`` float64 features, continuous over frames."""

    @abstractmethod
    def from_features(self, features: ArrayLike, skeleton: Skeleton, fps: float) -> Motion:
        """Decode ``(F, D)`` features (possibly lossy, e.g. from a codec) into a valid Motion.

        Raises:
            ValidationError: if ``features`` is not ``(F, D)`` for this skeleton, or not finite.
        """

    def pose_plan(self, skeleton: Skeleton) -> PosePlan | None:
        """How ``skeleton``'s features become poses, as a :class:`~motionrep.model.poseplan.PosePlan` (optional).

        A representation whose rotations are computed from its columns by the core's conversions (quaternions,
        rotation vectors, Euler angles, 6D, rotations in world axes) returns its plan here (build it with
        :meth:`FeatureLayout.pose_plan`, decorate the function with :func:`per_skeleton`); :meth:`decode_poses`
        and the runtime decoder (``motionrep.open``) then decode in one compiled pass.  Default: None (decoding
        goes through :meth:`decode_poses`).
        """
        return None

    def decode_poses(self, features: ArrayLike, skeleton: Skeleton, out: Poses) -> None:
        """Decode ``(T, D)`` features into ``out`` (:class:`Poses` of ``T`` rows, see :func:`empty_poses`).

        ``from_features`` must give the same values (the shipped representations build their ``Motion`` from it
        with :func:`decoded_motion`).  The default runs :meth:`pose_plan` when the representation has one, else
        goes through :meth:`from_features`; override it with a path that writes into ``out`` without building a
        ``Motion``.  The runtime decoder (``motionrep.open``) calls it for every block of poses of a
        representation without a plan.

        Raises:
            ValidationError: as :meth:`from_features`.
        """
        plan = self.pose_plan(skeleton)
        if plan is not None:
            f = check_features(features, plan.width, self.name, float32=True)
            decode_planned(f, plan, out.rotations, out.root_translation, out.joint_translations, check_finite=False)
            return
        motion = self.from_features(features, skeleton, 1.0)
        out.root_translation[...] = motion.root_translation
        out.rotations[...] = motion.rotations
        out.joint_translations[...] = motion.joint_translations

    def torch_path(self) -> "TorchPath | None":
        """The representation in torch (optional): a :class:`TorchPath`, or None (the default).

        A representation that offers one can be decoded and encoded inside a training loop
        (:func:`motionrep.torch.decode_features`, :func:`motionrep.torch.encode_features`, the losses of
        :mod:`motionrep.torch`), checked against the numpy path by the conformance suite.  Import torch only
        inside this method (from a private ``_torch`` module), so that importing the plugin never imports it.
        """
        return None

    @abstractmethod
    def weights(self, motion: Motion) -> NDArray[np.float64]:
        """``(D,)`` per-feature weights ``w`` of the Tojo et al. (2022) loss, eq. 3.

        1 for translation components; for the rotation components of a joint, the distance from that joint to
        its farthest descendant (joints and end sites) in the first frame (:func:`joint_reach`), so that
        ``w * feature error`` is roughly a joint-position error in file units.
        """

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r} v{self.version}>"


class TorchPath(ABC):
    """A representation's torch path (:meth:`Representation.torch_path`): decoder and encoder on torch tensors
    (their dtype and device kept), differentiable, agreeing with the numpy path to 1e-10 (``specs/torch.md``)."""

    @abstractmethod
    def decode(self, features: Any, skeleton: Skeleton) -> tuple[Any, Any, Any]:
        """``(..., F, D)`` features to ``(root_translation (..., F, 3), rotations (..., F, J, 4) xyzw local,
        joint_translations (..., F, P, 3))``, as :meth:`Representation.decode_poses` (any leading batch
        dimensions, differentiable in ``features``)."""

    @abstractmethod
    def encode(self, skeleton: Skeleton, root_translation: Any, rotations: Any, joint_translations: Any,
               reference: NDArray[np.float64] | None = None) -> Any:
        """``(F, 3)``, ``(F, J, 4)``, ``(F, P, 3)`` tensors to ``(F, D)`` features, as
        :meth:`Representation.to_features` (differentiable in the poses).

        The discrete choices of an encoding (quaternion signs, full turns of angles, the Euler solution) are
        piecewise constant: they are taken as the numpy path takes them, from ``reference``, the numpy
        features of the same poses when the caller has them (``to_features(motion)``, which sees hints such as
        ``Motion.euler_branch``), else from the values.
        """


def representation_problems(rep: Any) -> list[str]:
    """What is wrong with ``rep`` as a plugin object, one phrase each (empty: nothing).

    Checked when a representation is registered (:mod:`motionrep.plugin.registry`, which raises ``PluginError``) and by
    the conformance suite (:func:`motionrep.testing.check_representation`): an instance of
    :class:`Representation`; a non-empty ``name`` without surrounding spaces; an integer ``version`` >= 1; a
    string ``description``; ``layout`` overridden, or both ``width`` and ``feature_names``.
    """
    if not isinstance(rep, Representation):
        return ["is not a motionrep.plugin.representation.Representation"]
    out = []
    name = getattr(rep, "name", None)
    if not isinstance(name, str) or not name or name != name.strip():
        out.append("name must be a non-empty string without surrounding spaces")
    version = getattr(rep, "version", None)
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        out.append(f"version must be an integer >= 1, got {version!r}")
    if not isinstance(rep.description, str):
        out.append("description must be a string")
    cls = type(rep)
    own = {m: getattr(cls, m) is not getattr(Representation, m) for m in ("layout", "width", "feature_names")}
    if not own["layout"] and not (own["width"] and own["feature_names"]):
        out.append("must define layout(skeleton), or width(skeleton) and feature_names(skeleton)")
    return out


def joint_reach(motion: Motion) -> NDArray[np.float64]:
    """``(J,)`` distance from each joint to its farthest descendant (joints and end sites) in frame 0.

    A joint with no descendants has reach 0.  This is the rotation weight of Tojo et al. (2022), eq. 3.
    """
    sk = motion.skeleton
    pos = forward_kinematics(motion.frames(slice(0, 1))).positions[0]  # (J + E, 3)
    J = sk.num_joints
    owner = np.concatenate([np.arange(J), sk.end_site_parents])  # point -> joint it belongs to
    reach = np.zeros(J)
    # Walk every point up its chain of ancestors; J is small (tens to a few hundred).
    for point in range(pos.shape[0]):
        j = int(owner[point]) if point >= J else int(sk.parents[point])
        while j >= 0:
            d = float(np.linalg.norm(pos[point] - pos[j]))
            if d > reach[j]:
                reach[j] = d
            j = int(sk.parents[j])
    return reach


_F32 = np.dtype(np.float32)


def check_features(features: ArrayLike, width: int, name: str, *, float32: bool = False) -> NDArray[np.floating]:
    """Validate ``(F, width)`` finite features for representation ``name``; return them as float64.

    Args:
        float32: return float32 features as they are (for decoders whose arithmetic is float64 anyway, such as
            the ``motionrep.model.rotations`` column conversions): no converted copy.

    Raises:
        ValidationError: naming the representation, the expected and the received shape.
    """
    try:
        keep = float32 and type(features) is np.ndarray and features.dtype is _F32
        f = features if keep else np.asarray(features, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValidationError(f"features for representation {name!r} must be numeric") from None
    if f.ndim != 2 or f.shape[1] != width or f.shape[0] == 0:
        raise ValidationError(f"representation {name!r} expects features of shape (frames, {width}) for this "
                              f"skeleton, got {f.shape}")
    if not np.isfinite(f).all():
        raise ValidationError(f"features for representation {name!r} contain NaN or infinity")
    return f


@dataclass(frozen=True, eq=False)
class FeatureLayout:
    """Where each joint's columns sit in a ``(F, D)`` feature matrix.

    The shipped representations all use this layout (third-party ones may too): the root translation
    first (3 columns, ``"<root>/tx"``, ``"<root>/ty"``, ``"<root>/tz"``), then, for every joint in skeleton
    order, its rotation block (zero or more columns, named ``"<joint>/<suffix>"``) followed, for the joints in
    ``skeleton.translated_joints``, by its local translation (3 columns ``"<joint>/tx"``...).  Build one with
    :func:`feature_layout`.

    Attributes:
        skeleton: the skeleton the layout is for.
        names: ``D`` column names.
        rotation_joints: ``(R,)`` indices of the joints that have a rotation block, in skeleton order.
        rotation_columns: per entry of ``rotation_joints``, the ``(k_j,)`` column indices of its block.
        translation_columns: ``(P, 3)`` column indices of the local translation of each joint in
            ``skeleton.translated_joints``.
    """

    skeleton: Skeleton
    names: tuple[str, ...]
    rotation_joints: NDArray[np.int64]
    rotation_columns: tuple[NDArray[np.int64], ...]
    translation_columns: NDArray[np.int64]

    @property
    def width(self) -> int:
        """Number of feature columns ``D``."""
        return len(self.names)

    def rotation_block(self, features: NDArray[np.float64]) -> NDArray[np.float64]:
        """``(F, R, k)`` rotation blocks of ``(F, D)`` features, when every block has the same width ``k``.

        Raises:
            ValidationError: if the blocks differ in width (use ``rotation_columns`` one joint at a time).
        """
        return features[:, self._uniform_index()]

    def split(self, features: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(F, 3)`` root translation and ``(F, P, 3)`` joint translations of ``(F, D)`` features."""
        return features[:, :3], features[:, self.translation_columns]

    def pose_plan(self, entry: Callable[[int, NDArray[np.int64]], tuple[int, Sequence[int], Sequence[int]]]
                  ) -> PosePlan:
        """The :class:`~motionrep.model.poseplan.PosePlan` of this layout: ``entry(j, columns)`` gives, for joint ``j``
        with rotation block ``columns``, ``(kind, columns it reads, Euler axes or ())``; the joints without a
        block decode to the identity; the translations come from their columns.

        Example::

            plan = layout.pose_plan(lambda j, cols: (poseplan.AXIS_ANGLE, cols, ()))
        """
        R = len(self.rotation_joints)
        kinds = np.zeros(R, np.int64)
        columns = np.full((R, 6), -1, np.int64)
        axes = np.full((R, 3), -1, np.int64)
        for r, (j, cols) in enumerate(zip(self.rotation_joints.tolist(), self.rotation_columns)):
            kind, used, order = entry(j, cols)
            kinds[r] = kind
            columns[r, :len(used)] = used
            axes[r, :len(order)] = order
        sk = self.skeleton
        tcols = np.concatenate([np.arange(3, dtype=np.int64).reshape(1, 3), self.translation_columns])
        return PosePlan(width=self.width, num_joints=sk.num_joints, kinds=kinds, columns=columns, axes=axes,
                        joints=self.rotation_joints.astype(np.int64), parents=sk.parents.astype(np.int64),
                        translation_columns=tcols, translation_values=np.zeros(tcols.shape))

    def assemble(self, root_translation: NDArray[np.float64], rotations: NDArray[np.float64] | Sequence[NDArray],
                 joint_translations: NDArray[np.float64]) -> NDArray[np.float64]:
        """Build ``(F, D)`` features from their parts.

        Args:
            root_translation: ``(F, 3)``.
            rotations: ``(F, R, k)`` blocks in ``rotation_joints`` order, or a sequence of ``R`` arrays
                ``(F, k_j)``.
            joint_translations: ``(F, P, 3)`` local translations of ``skeleton.translated_joints``.
        """
        F = root_translation.shape[0]
        out = np.empty((F, self.width))
        out[:, :3] = root_translation
        if isinstance(rotations, np.ndarray):
            if len(self.rotation_joints):
                out[:, self._uniform_index()] = rotations
        else:
            for cols, block in zip(self.rotation_columns, rotations):
                out[:, cols] = block
        if self.translation_columns.size:
            out[:, self.translation_columns] = joint_translations
        return out

    def weights(self, rotation_weight: NDArray[np.float64]) -> NDArray[np.float64]:
        """``(D,)`` weights: 1 for every translation column, ``rotation_weight[j]`` for joint ``j``'s block.

        Args:
            rotation_weight: ``(J,)`` weight of each joint's rotation columns (for example
                :func:`joint_reach` times a unit factor).
        """
        w = np.ones(self.width)
        for j, cols in zip(self.rotation_joints.tolist(), self.rotation_columns):
            w[cols] = rotation_weight[j]
        return w

    def _uniform_index(self) -> NDArray[np.int64]:
        widths = {c.shape[0] for c in self.rotation_columns}
        if len(widths) > 1:
            raise ValidationError(f"rotation blocks have different widths {sorted(widths)}")
        if not self.rotation_columns:
            return np.zeros((0, 0), np.int64)
        return np.stack(self.rotation_columns)


def feature_layout(skeleton: Skeleton, rotation_suffixes: Callable[[int], Sequence[str]]) -> FeatureLayout:
    """The :class:`FeatureLayout` of ``skeleton`` for a representation with the given rotation blocks.

    Args:
        skeleton: the skeleton.
        rotation_suffixes: for joint index ``j``, the names of its rotation columns without the joint prefix
            (``("qx", "qy", "qz", "qw")``), or an empty sequence for a joint without rotation columns.

    Example::

        layout = feature_layout(sk, lambda j: ("r0", "r1", "r2", "r3", "r4", "r5") if sk.rotation_orders[j]
                                else ())
    """
    names = [f"{skeleton.names[0]}/{a}" for a in ("tx", "ty", "tz")]
    translated = set(skeleton.translated_joints.tolist())
    rot_joints: list[int] = []
    rot_cols: list[NDArray[np.int64]] = []
    trans_cols: list[list[int]] = []
    for j, joint in enumerate(skeleton.names):
        suffixes = tuple(rotation_suffixes(j))
        if suffixes:
            rot_joints.append(j)
            rot_cols.append(np.arange(len(names), len(names) + len(suffixes)))
            names.extend(f"{joint}/{s}" for s in suffixes)
        if j in translated:
            trans_cols.append(list(range(len(names), len(names) + 3)))
            names.extend(f"{joint}/{a}" for a in ("tx", "ty", "tz"))
    return FeatureLayout(skeleton, tuple(names), np.array(rot_joints, np.int64), tuple(rot_cols),
                         np.array(trans_cols, np.int64).reshape(-1, 3))


_T = TypeVar("_T")


def per_skeleton(build: Callable[[Skeleton], _T]) -> Callable[[Skeleton], _T]:
    """Decorator: remember ``build(skeleton)`` for the most recent skeleton object.

    A representation's layout (and anything else derived from the skeleton alone) is the same for every call
    with one clip, and decoding one pose at a time would otherwise rebuild it for every pose. The cache holds
    one entry, keyed by the skeleton's identity (a :class:`Skeleton` is immutable), and is safe to use from
    several threads (the entry is replaced as a whole).

    Example::

        @per_skeleton
        def _layout(skeleton):
            return feature_layout(skeleton, lambda j: ("qx", "qy", "qz", "qw"))
    """
    last: tuple[Skeleton, _T] | None = None

    @functools.wraps(build)
    def cached(skeleton: Skeleton) -> _T:
        nonlocal last
        entry = last
        if entry is not None and entry[0] is skeleton:
            return entry[1]
        value = build(skeleton)
        last = (skeleton, value)
        return value

    return cached
