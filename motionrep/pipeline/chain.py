"""Feature chains: closed-loop quantisation along the skeleton, offered to codecs by the encode context.

A codec that quantises every feature open loop lets a joint's quantisation error rotate its whole subtree: the
hand's error sums, over the chain above it, each ancestor's angular error times its distance to the hand, so the
steps of root-ish joints must be small. In closed loop the codec quantises the skeleton depth by depth, and the
targets of each depth are recomputed from what the decoder will make of the depths before it (:class:`FeatureChain`,
through :meth:`MotionContext.feature_chain <motionrep.pipeline.evaluate.MotionContext.feature_chain>`):

- a joint with exactly one point below it (one child joint or end site, not at the joint itself) gets *position
  feedback*: its true global rotation turned by the smallest rotation that points it, from its decoded position,
  at the true position of that point (a closed form: the half-way quaternion of the two vectors);
- any other joint gets *orientation feedback*: the local rotation that gives its true global rotation under its
  decoded parent, ``inv(decoded parent global) * true global``;
- but the children of a joint with more than :data:`MAX_CHILDREN` child joints (a hand with five fingers) keep
  their true values, and that joint its open-loop sensitivity: each child would take a copy of its parent's
  quantisation noise (measured on the tuning clips: 2-4 % fewer bytes at 2 % and 0.588 % on the seven of them with
  such joints than closing them too, the same at 0.0588 %);
- and a joint whose rotation never moves (a collar, a buttock, an eye of a rig that records them as still) keeps
  its true values when its parent's lever reaching through it gets no longer (:data:`STILL_LEVER`): closed, it would
  take a copy of its decoded parent's noise, a feature that cost nothing made noisy; held, its parent's error moves
  the points below it too, which is free when none of them is farther from the parent than the parent's own points
  (:attr:`FeatureChain.held`; measured in ``benchmarks/results/stillrule.md``).

A parent's error then no longer rotates the subtree, and a feature's sensitivity (:meth:`FeatureChain.sensitivity`)
is about its joint's own bones: how far a unit change moves the points directly below it (a child at the joint
itself passes on to its own children); translations move everything below them. The decoder is unchanged: only
which values the codec quantises.

Offered for pose plans whose rotation blocks are local quaternions or rotation vectors (``root-quat-axis-angle``,
the default representation); any other plan gets None, and the codec quantises open loop. The targets of a depth
are computed by the compiled core (``motionrep/_c/chain.c``: the depth posed, then its targets, frames x joints in
one call), scalar IEEE arithmetic without FMA contraction in a fixed order, with the core's conversions and FK (no
BLAS), so they are the same bits on every run, thread count and CPU.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._ccore import chain_pose, chain_targets
from ..errors import ValidationError
from ..model._pose import Skeleton
from ..model.kinematics import fk_arrays
from ..model.poseplan import AXIS_ANGLE, QUAT, PosePlan, decode_planned
from ..plugin.representation import empty_poses

__all__ = ["FeatureChain", "sensitivity_samples", "sensitivity_steps", "moved_by_feature", "moved_positions",
           "SENSITIVITY_FRAMES", "SENSITIVITY_BUDGET"]

#: :func:`sensitivity_samples` samples at most this many frames, and at most ``SENSITIVITY_BUDGET / D`` of them (but
#: at least 8) for ``D`` features, since it decodes ``D`` copies of each.
SENSITIVITY_FRAMES = 64
SENSITIVITY_BUDGET = 4096
#: A joint with more child joints than this stays open loop: its error is not taken out of its children (each child
#: would take a copy of its quantisation noise), and its sensitivity is the open-loop one.
MAX_CHILDREN = 3
#: A joint whose rotation never moves keeps its true values when that makes its parent's lever (the farthest point
#: its error moves) at most this many times longer.
STILL_LEVER = 1.0
#: A rotation whose features (radians, quaternion components) vary by at most this over the clip never moves.
_STILL = 1e-9
#: A bone (or lever) at most this fraction of the skeleton's longest local offset counts as zero length.
_COINCIDENT = 1e-6

Positions = Callable[[NDArray[np.float64]], NDArray[np.float64]]


def sensitivity_samples(features: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The forward differences of a sensitivity measure: ``(x, moved, h)``, ``x`` ``(n, D)`` the features of ``n``
    frames sampled evenly (:data:`SENSITIVITY_FRAMES`, fewer for wide features: :data:`SENSITIVITY_BUDGET`),
    ``moved`` ``(D, n, D)`` copies of them with feature ``c`` of copy ``c`` moved by ``h_c = 1e-6 (1 + max |feature
    c|)``."""
    x, h = sensitivity_steps(features)
    D = x.shape[1]
    moved = np.repeat(x[None], D, axis=0)  # (D, n, D): copy c has feature c moved by h_c
    moved[np.arange(D), :, np.arange(D)] += h[:, None]
    return x, moved, h


def moved_positions(x: NDArray[np.float64], h: NDArray[np.float64], positions: Positions,
                    positions_by_feature: Callable[[NDArray[np.float64], int], NDArray[np.float64]] | None = None
                    ) -> NDArray[np.float64]:
    """``(D n, J + E, 3)`` the positions of :func:`sensitivity_samples`' moved copies of ``x`` ``(n, D)`` (steps
    ``h``, :func:`sensitivity_steps`), copy after copy: through ``positions_by_feature`` (feature-major, as a pose
    plan decodes them: neither transposed nor made twice) when given, else through ``positions`` (pose-major, the
    same values transposed)."""
    n, D = x.shape
    if positions_by_feature is not None:
        return positions_by_feature(moved_by_feature(x, h), D * n)
    return positions(np.ascontiguousarray(moved_by_feature(x, h).T))


def _longest(local: NDArray[np.float64], translated: NDArray[np.int64]) -> NDArray[np.float64]:
    """``(J,)`` each joint's longest local offset over the frames of ``(F, J, 3)`` ``local`` (F >= 1), where
    only the ``translated`` joints differ between frames: the others' from the first frame alone (the same
    values as over every frame: each length is the same elementwise operations on the same numbers)."""
    reach = np.sqrt(np.sum(local[:1] ** 2, axis=2))[0]
    if translated.size:
        reach[translated] = np.sqrt(np.sum(local[:, translated] ** 2, axis=2)).max(axis=0)
    return reach


def _distances(pos: NDArray[np.float64], joints: NDArray[np.int64], points: NDArray[np.int64]
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(F, k, 3)`` the vectors from ``pos[:, joints]`` to ``pos[:, points]`` and ``(F, k)`` their lengths, all
    pairs at once: each the same float64 bits as ``v = pos[:, p] - pos[:, j]``, ``np.sqrt(np.sum(v * v,
    axis=1))`` alone (elementwise operations, each length's three squares added in order)."""
    v = pos[:, points] - pos[:, joints]
    return v, np.sqrt(np.sum(v * v, axis=2))


def sensitivity_steps(features: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`sensitivity_samples`'s ``(x, h)`` without the copies."""
    x_all = np.asarray(features, dtype=np.float64)
    F, D = x_all.shape
    count = min(F, SENSITIVITY_FRAMES, max(8, SENSITIVITY_BUDGET // max(D, 1)))
    rows = np.unique(np.linspace(0, F - 1, count).round().astype(np.int64))
    x = x_all[rows]
    return x, 1e-6 * (1.0 + np.abs(x).max(axis=0))


def moved_by_feature(x: NDArray[np.float64], h: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`sensitivity_samples`'s ``moved`` copies feature-major, ``(D, D n)`` C-contiguous (copy ``c`` in
    columns ``c n .. c n + n - 1``): ``np.ascontiguousarray(moved.reshape(D * n, D).T)``, the same additions,
    without transposing the copies."""
    n, D = x.shape
    X = np.empty((D, D, n))
    X[...] = x.T[:, None, :]  # a broadcast copy (np.tile repeats element by element here: 20x slower)
    X[np.arange(D), np.arange(D)] += h[:, None]
    return X.reshape(D, D * n)


class FeatureChain:
    """The depth groups of a clip's feature columns and their closed-loop targets.

    Args:
        features: ``(F, D)`` the clip's (true) features.
        skeleton: its skeleton.
        plan: the representation's pose plan (fixed translation axes set, as the context's); every rotation entry
            must be a local quaternion or rotation vector (:meth:`supports`).
        positions: ``(T, D)`` features -> ``(T, J + E, 3)`` FK positions (the context's), for
            :meth:`sensitivity`.
        positions_by_feature: ``((D, T) feature-major C-contiguous features, T)`` -> the same positions (the
            context's), if it offers them: :meth:`sensitivity` then hands its copies over without transposing them.

    Raises:
        ValidationError: features that do not decode (not finite, a zero-length quaternion).

    Attributes:
        groups: per depth of the skeleton that has columns, in order, the ``(n_g,)`` columns of its joints
            (rotation blocks and local translations; the root's translation in the first group).
        lever_points: ``(D, J + E)`` bool, the points a change of each feature moves once the loop restores what
            is below them.
        held: ``(J,)`` bool, the joints whose rotation never moves that keep their true values (module docstring).
    """

    def __init__(self, features: ArrayLike, skeleton: Skeleton, plan: PosePlan, positions: Positions,
                 positions_by_feature: Callable[[NDArray[np.float64], int], NDArray[np.float64]] | None = None):
        self._true = np.array(features, dtype=np.float64)
        F, D = self._true.shape
        sk, J, E = skeleton, skeleton.num_joints, skeleton.num_end_sites
        self._skeleton, self._plan, self._positions = sk, plan, positions
        self._positions_by_feature = positions_by_feature
        depth = np.asarray(sk.depths, np.int64)
        self._poses = empty_poses(sk, F)
        true_pos, true_rot = self._fk(self._true)
        # the columns of each joint: its rotation entry's, then its translation's (the root's first)
        cols_of: dict[int, list[int]] = {j: [] for j in range(J)}
        entry_of: dict[int, int] = {}
        for r, j in enumerate(plan.joints.tolist()):
            entry_of[j] = r
            cols_of[j] += [c for c in plan.columns[r].tolist() if c >= 0]
        translated = [0] + sk.translated_joints.tolist()
        for row, j in enumerate(translated):
            cols_of[j] += [c for c in plan.translation_columns[row].tolist() if c >= 0]
        depths = sorted({int(depth[j]) for j in range(J) if cols_of[j]})
        self.groups = [np.array(sorted(c for j in range(J) if depth[j] == d for c in cols_of[j]), np.int64)
                       for d in depths]
        self._group_depth = depths
        self._true_groups = [np.ascontiguousarray(self._true[:, c]) for c in self.groups]  # each group's true values
        # points directly below each joint: its end sites and child joints, a child at the joint itself passing on
        # to its own (over frames, the longest local offset: translated joints move)
        local = np.broadcast_to(sk.offsets, (F, J, 3)).copy()
        if sk.translated_joints.size:
            local[:, sk.translated_joints] = self._poses.joint_translations
        reach = _longest(local, sk.translated_joints) if F else np.zeros(J)
        tiny = _COINCIDENT * (float(reach[1:].max()) if J > 1 else 1.0)
        kids = sk.children
        opened = [len(kids[j]) > MAX_CHILDREN for j in range(J)]
        held = np.zeros(J, bool)  # still joints that keep their true values (their parent's lever passes through)

        ends = [[] for _ in range(J)]
        for e, j in enumerate(sk.end_site_parents.tolist()):
            ends[j].append(J + e)

        def below(j: int) -> list[int]:
            out = list(ends[j])
            for k in kids[j]:
                out += below(k) if reach[k] <= tiny else [k] + below(k) if held[k] else [k]
            return out

        far: dict[tuple[int, int], float] = {}  # (joint, point): their largest distance over frames

        def lever(j: int) -> float:
            points = below(j)
            missing = [pt for pt in points if (j, pt) not in far]
            if missing:  # their distances at once
                _, dist = _distances(true_pos, np.full(len(missing), j, np.int64), np.array(missing, np.int64))
                far.update(zip([(j, pt) for pt in missing], dist.max(axis=0).tolist()))
            return max((far[j, pt] for pt in points), default=0.0)

        # a joint whose rotation never moves would take a copy of its decoded parent's noise in closed loop: it keeps
        # its true values when its parent's lever reaching through it (to the points below it) gets no longer, so
        # that the parent's steps stay as they were; deepest first, so a held joint's own held children count
        spread = np.ptp(self._true, axis=0) if F else np.zeros(D)  # each feature's range over the clip
        for j in sorted(range(1, J), key=lambda j: (-int(depth[j]), j)):
            if j not in entry_of or opened[sk.parents[j]] or not F:
                continue
            rows = [c for c in plan.columns[entry_of[j]].tolist() if c >= 0]
            if float(spread[rows].max()) > _STILL:  # its rotation moves
                continue
            p = int(sk.parents[j])
            before = lever(p)
            held[j] = True
            held[j] = lever(p) <= STILL_LEVER * before
        self.held = held
        self.lever_points = np.zeros((D, J + E), bool)
        for j in range(J):
            rows = [c for c in plan.columns[entry_of[j]].tolist() if c >= 0] if j in entry_of else []
            if opened[j]:
                self.lever_points[rows] = True  # open loop: every point it moves
                continue
            self.lever_points[np.array(rows, np.int64)[:, None], np.array(below(j), np.int64)[None, :]] = True
        for row, j in enumerate(translated):  # a translation moves its joint and everything below it
            for c in plan.translation_columns[row].tolist():
                if c >= 0:
                    self.lever_points[c] = True
        # per depth: the joints with a rotation entry (retargeted), their entries' columns and parents, and which
        # of them get position feedback (exactly one point directly below, not at the joint itself)
        self._at: dict[int, tuple] = {}
        for d in depths[1:]:
            js = [j for j in range(J) if depth[j] == d and j in entry_of and not opened[sk.parents[j]]
                  and not held[j]]
            if not js:
                continue
            kinds = plan.kinds[[entry_of[j] for j in js]]
            width = [4 if k == QUAT else 3 for k in kinds.tolist()]
            cols = [plan.columns[entry_of[j], :w] for j, w in zip(js, width)]
            lever = np.zeros((F, len(js), 3))
            pointed = np.zeros(len(js), bool)
            single = [(i, j, pts[0]) for i, j in enumerate(js)
                      for pts in [list(kids[j]) + [J + e for e in np.flatnonzero(sk.end_site_parents == j).tolist()]]
                      if len(pts) == 1]
            if F and single:  # the levers of the joints with one point below, at once (each as it would be alone)
                i1, j1, p1 = (np.array(x, np.int64) for x in zip(*single))
                v, dist = _distances(true_pos, j1, p1)
                far_enough = dist.min(axis=0) > tiny
                lever[:, i1[far_enough]], pointed[i1[far_enough]] = v[:, far_enough], True
            js_a = np.array(js, np.int64)
            i = np.flatnonzero(pointed)
            lever_of = np.full(len(js), -1, np.int64)
            lever_of[i] = np.arange(i.size)
            a = np.ascontiguousarray(lever[:, i].transpose(1, 0, 2))
            # the conversion of each joint: its kind (0 quaternion, 1 rotation vector), where its columns sit among
            # the group's (-1 pads a rotation vector's), and its true features (the branch or sign to stay near)
            where = {c: k for k, c in enumerate(self.groups[depths.index(d)].tolist())}
            at = np.full((len(js), 4), -1, np.int64)
            truth = np.zeros((len(js), F, 4))
            for r, c in enumerate(cols):
                at[r, :c.size] = [where[int(v)] for v in c.tolist()]
                truth[r, :, :c.size] = self._true[:, c]
            self._at[d] = (sk.parents[js_a], np.ascontiguousarray(true_rot[:, js_a].transpose(1, 0, 2)), lever_of,
                           np.ascontiguousarray(local[:, js_a[i]].transpose(1, 0, 2)),
                           np.ascontiguousarray(true_pos[:, js_a[i]].transpose(1, 0, 2)), a,
                           np.sqrt(np.sum(a * a, axis=-1)), (kinds != QUAT).astype(np.int64), at, truth)
        # per depth, how the decoder poses its joints: each joint's rotation entry (kind 0 a quaternion, 1 a rotation
        # vector, -1 none: the identity; its columns) and local translation (an OFFSET, or columns where the plan
        # has them: -1 for a fixed axis, whose value the plan holds)
        self._levels = []
        for d in range(int(depth.max()) + 1 if J else 0):
            js = np.flatnonzero(depth == d)
            place = {j: i for i, j in enumerate(js.tolist())}
            kinds = np.full(js.size, -1, np.int64)
            rcols = np.zeros((js.size, 4), np.int64)
            for i, j in enumerate(js.tolist()):
                if j in entry_of:
                    kinds[i] = 0 if plan.kinds[entry_of[j]] == QUAT else 1
                    width = 4 if kinds[i] == 0 else 3
                    rcols[i, :width] = plan.columns[entry_of[j], :width]
            tcols = np.full((js.size, 3), -1, np.int64)
            tvals = sk.offsets[js].astype(np.float64)
            for row, j in enumerate(translated):
                if j in place:
                    tcols[place[j]] = plan.translation_columns[row]
                    tvals[place[j]] = np.where(plan.translation_columns[row] >= 0, 0.0, plan.translation_values[row])
            self._levels.append((js, sk.parents[js] if d else np.full(js.size, -1, np.int64), kinds, rcols, tcols,
                                 tvals))
        # the decoded state, joint-major ((J, F, 4), (J, F, 3)): a depth's parents are gathered as whole blocks
        self._rot = np.zeros((J, F, 4))
        self._pos = np.zeros((J, F, 3))
        self._posed = 0  # depths posed from the decoded features of the current run (targets' state)
        self._last = -1  # the last group targets() was called for
        self._run_ok = False  # the current run (targets of group 0, 1, ... in order) has posed every frame it needed
        self._incremental = False  # the current run may go by frames: the last one went through every group, ok
        self.runs = 0  # runs started (calls for group 0): a caller going by frames checks that no other run came between

    @property
    def complete(self) -> bool:
        """Whether the last run went through every group in order, every frame posed (no quaternion of zero length):
        the next run may go by frames (:meth:`targets`)."""
        return self._run_ok and self._last == len(self.groups) - 1

    @staticmethod
    def supports(plan: PosePlan | None) -> bool:
        """Whether a chain can be built for ``plan``: every rotation entry a local quaternion or rotation vector."""
        return plan is not None and bool(np.all(np.isin(plan.kinds, (QUAT, AXIS_ANGLE))))

    def _pose(self, d: int, decoded: NDArray[np.float64], frames: NDArray[np.int64] | None = None) -> None:
        """Global rotations and positions of the joints of depth ``d`` from ``decoded`` (the decoder's conversions;
        their parents' already posed), in every frame or only in ``frames``."""
        js, parents, kinds, rcols, tcols, tvals = self._levels[d]
        # compiled: motionrep/_c/chain.c (the conversions of motionrep/_c/mr_rotconv.h, as the decoder's)
        if chain_pose(np.ascontiguousarray(decoded, dtype=np.float64), kinds, rcols, js, parents, tcols, tvals,
                      self._rot, self._pos, frames):
            raise ValidationError("cannot normalise a quaternion of zero or non-finite length")

    def _fk(self, features: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(F, J + E, 3)`` positions and ``(F, J + E, 4)`` global rotations of ``features`` (the decoder's
        conversions; joints whose columns hold zeros decode to the identity)."""
        p = self._poses
        decode_planned(features, self._plan, p.rotations, p.root_translation, p.joint_translations,
                       check_finite=False)
        pos, rot = fk_arrays(self._skeleton, p.rotations, p.root_translation, p.joint_translations, True)
        return pos, rot

    def sensitivity(self, features: ArrayLike) -> NDArray[np.float64]:
        """``(n, D)`` position units per feature unit in closed loop, for ``n`` frames sampled as
        :meth:`MotionContext.feature_sensitivity <motionrep.pipeline.evaluate.MotionContext.feature_sensitivity>`
        samples them (:func:`sensitivity_samples`): how far a unit change of each feature moves the farthest of its
        :attr:`lever_points`."""
        x, h = sensitivity_steps(features)
        n, D = x.shape
        base = self._positions(x)
        pos = moved_positions(x, h, self._positions, self._positions_by_feature).reshape(D, n, base.shape[1], 3)
        # the distances of the lever points only, (K, n) for the K (feature, point) pairs in row order, and per
        # feature their largest (0 for a feature without lever points; the distances are >= 0)
        feature, point = np.nonzero(self.lever_points)
        d = pos[feature, :, point] - base[:, point].transpose(1, 0, 2)
        dist = np.sqrt(np.sum(d * d, axis=-1))
        shift = np.zeros((D, n))
        counts = np.bincount(feature, minlength=D)
        has = counts > 0
        if has.any():
            starts = np.cumsum(counts) - counts
            shift[has] = np.maximum.reduceat(dist, starts[has], axis=0)
        return (shift / h[:, None]).T

    def targets(self, group: int, decoded: NDArray[np.float64], frames: NDArray[np.int64] | None = None,
                previous: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """``(F, n_g)`` the values to quantise for the columns of ``groups[group]``, given ``decoded`` ``(F, D)``
        whose columns of the earlier groups hold what the decoder will make of them (the others are not read);
        where those do not decode (a quaternion of zero length), the true values.

        A translation column's target is its true value; a rotation block's is the feedback's (module docstring),
        a rotation vector on the branch ``(theta + 2 pi k) n`` nearest the true features, a quaternion of the
        sign nearest them.

        A run is one call per group, in order from group 0. With ``frames`` (increasing int64) and ``previous``
        ``(F, n_g)``, the caller states that ``decoded``'s columns of the earlier groups differ from the last run's
        only in ``frames``, and ``previous`` holds this group's targets of that run: then only those frames are
        computed and the others taken from ``previous``, the same values as computing every frame (a frame's
        targets and poses depend on that frame's decoded values alone, by the same arithmetic). The chain computes
        every frame instead when the last run did not go through every group (or met a quaternion of zero length)
        or this call is not the next group of the current run; :attr:`runs` counts the runs, so that a caller can
        tell that nobody else ran the chain in between.
        """
        d = self._group_depth[group]
        if group == 0:  # a run starts
            self._incremental = self.complete
            self._run_ok = True
            self.runs += 1
            self._posed = 0
        elif group != self._last + 1:  # not the next group of the current run: pose from the start
            self._posed = 0
            self._incremental = False
        self._last = group
        if frames is not None and not (self._incremental and previous is not None and frames.size < len(self._true)):
            frames = None  # (every frame: as without frames)
        out = self._true_groups[group].copy() if frames is None else previous.copy()
        if frames is not None and not frames.size:  # nothing above changed: the last run's poses and targets
            self._posed = max(self._posed, d)
            return out
        try:
            while self._posed < d:  # the joints above depth d, as the decoder poses them
                self._pose(self._posed, decoded, frames)
                self._posed += 1
        except ValidationError:  # a decoded quaternion of zero length (a huge step): open loop for this run
            self._posed, self._last, self._run_ok = 0, -2, False
            return self._true_groups[group].copy()
        if d not in self._at:
            return out
        if chain_targets(self._rot, self._pos, *self._at[d], out, frames) >= 0:  # compiled: motionrep/_c/chain.c
            self._run_ok = False
            raise ValidationError("cannot convert a quaternion of zero length to a rotation vector")
        return out
