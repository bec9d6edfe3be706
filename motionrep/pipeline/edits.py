"""Feature edits: the shared error of small changes to a candidate, in microseconds.

A codec that searches by small local changes (one coefficient of one feature, which moves that feature over a
stretch of frames) needs the error each change would give. Measuring the whole candidate again
(:meth:`MotionContext.frame_errors <motionrep.pipeline.evaluate.MotionContext.frame_errors>`) costs a decode and FK of
every frame and joint; a change of one feature over ``n`` frames moves only the joints below the one that feature
belongs to, in those frames. :class:`FeatureEdits` keeps a candidate's features together with their poses, their FK
and the distance of every point (joints and end sites) to the reference in every frame, and computes a change again
only there, in C (``motionrep/_c/edits.c``): the pose plan's conversions and FK's arithmetic, operation for
operation, so the distances it keeps are those :class:`~motionrep.pipeline.evaluate.Evaluator` measures for the same
features, bit for bit.

A change is an *edit*: deltas added to one feature column over consecutive frames. :meth:`FeatureEdits.apply` takes
many edits and, one after the other, applies each if every point it moves stays within a bound in every frame it
touches (points it does not move keep their distance): a greedy search in one call. It also tells which features
move which points (:attr:`FeatureEdits.moved_points`), what a codec cannot otherwise learn from the representation's
layout.

Available through :meth:`MotionContext.feature_edits <motionrep.pipeline.evaluate.MotionContext.feature_edits>` for
every representation with a pose plan (every shipped one).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._ccore import edits as _edits
from ..errors import ValidationError
from ..model._pose import Skeleton
from ..model.poseplan import AXIS_ANGLE, EULER, EULER_DEGREES, QUAT, WORLD_IDENTITY, WORLD_QUAT, PosePlan

__all__ = ["FeatureEdits"]

_STATUS = {1: "features contain NaN or infinity", 2: "cannot normalise a quaternion of zero or non-finite length",
           3: "6D rotation encoding has a zero or degenerate column"}


class FeatureEdits:
    """Candidate features kept with their poses, FK and per-point distances to a reference, edited column by column.

    Args:
        features: ``(F, D)`` candidate features.
        skeleton: the reference's skeleton.
        plan: the representation's pose plan for it (fixed translation axes set, as the context's).
        reference: ``(F, J + E, 3)`` FK positions of the reference.

    Raises:
        ValidationError: features of the wrong shape, or that do not decode (not finite, a zero-length quaternion).
    """

    def __init__(self, features: ArrayLike, skeleton: Skeleton, plan: PosePlan, reference: NDArray[np.float64]):
        f = np.asarray(features, dtype=np.float64)
        F, D = f.shape if f.ndim == 2 else (-1, -1)
        J, E, N = skeleton.num_joints, skeleton.num_end_sites, plan.translation_columns.shape[0]
        if D != plan.width or reference.shape != (F, J + E, 3):
            raise ValidationError(f"features must have shape ({reference.shape[0]}, {plan.width}), got {f.shape}")
        if N < 1:
            raise ValidationError("feature edits need a plan with the root's translation")
        self._shape = (F, D, J, E, N)
        self._plan = plan.packed()
        self._layout, self.moved_points, lip = _layout(F, D, skeleton, plan)
        # each column's factors of the points it moves, in the order of the kernel's cjoints, then csites (row
        # by row: boolean indexing walks the rows in order)
        self._geom = np.concatenate([skeleton.offsets.reshape(-1), skeleton.end_site_offsets.reshape(-1),
                                     lip[:, :J][self.moved_points[:, :J]], lip[:, J:][self.moved_points[:, J:]]])
        sizes = [D * F, F * J * 4, F * J * 4, F * N * 3, F * J * 4, F * (J + E) * 3, F * (J + E) * 3, F * (J + E)]
        self._state = np.empty(sum(sizes))
        bounds = np.cumsum([0] + sizes)
        part = [self._state[a:b] for a, b in zip(bounds[:-1], bounds[1:])]
        self._X = part[0].reshape(D, F)
        self._X[...] = f.T
        part[6][...] = reference.reshape(-1)
        self._dist = part[7].reshape(F, J + E)
        status = _edits(self._layout, *self._plan, self._geom, self._state, None, None, 0.0, False, None)
        if status:
            raise ValidationError(_STATUS[status])

    @property
    def features(self) -> NDArray[np.float64]:
        """``(F, D)`` the current features (read-only view)."""
        view = self._X.T.view()
        view.flags.writeable = False
        return view

    def point_errors(self) -> NDArray[np.float64]:
        """``(F, J + E)`` distance of every joint and end site to the reference in every frame (a copy)."""
        return self._dist.copy()

    def frame_errors(self) -> NDArray[np.float64]:
        """``(F,)`` the largest distance of each frame (``MotionContext.frame_errors`` of :attr:`features`)."""
        return self._dist.max(axis=1) if self._dist.shape[1] else np.zeros(self._dist.shape[0])

    def apply(self, columns: ArrayLike, firsts: ArrayLike, counts: ArrayLike, deltas: ArrayLike, bound: float,
              commit: bool = True, leads: NDArray[np.int64] | None = None, starts: ArrayLike | None = None,
              scales: ArrayLike | None = None) -> NDArray[np.bool_]:
        """Edits in turn: edit ``e`` adds the next ``counts[e]`` values of ``deltas`` to column ``columns[e]`` of the
        frames ``firsts[e] ..``; it is accepted if every point that column moves stays within ``bound`` of the
        reference in every frame it touches, computed on the features as the edits before it left them.

        Args:
            columns, firsts, counts: ``(m,)`` integers.
            deltas: ``(sum(counts),)`` float64; with ``starts`` and ``scales``, values the edits share: edit ``e``
                adds ``deltas[starts[e] : starts[e] + counts[e]] * scales[e]`` (each product as numpy forms it).
            starts, scales: ``(m,)`` integers and floats, or None (both or neither).
            bound: the largest distance allowed, in file units.
            commit: apply the accepted edits (else only say which would pass, each on the current features).
            leads: ``(m,)`` int64 array or None: the frame of each edit (counted from its first) to check first, -1
                for the frame of its largest change; updated in place, where an edit fails, to the frame it failed
                in (a search that tries a failed edit again checks that frame first, where it most likely fails
                again). Which frame is checked first changes the time an edit takes, not whether it is accepted.

        Returns:
            ``(m,)`` bool, which edits were accepted.

        Raises:
            ValidationError: an edit outside the features, deltas that do not match the counts, or ``starts``
                that reach outside them.
        """
        F, D = self._shape[:2]
        edits = np.ascontiguousarray(np.stack([np.asarray(columns, np.int64).reshape(-1),
                                               np.asarray(firsts, np.int64).reshape(-1),
                                               np.asarray(counts, np.int64).reshape(-1)], axis=1))
        d = np.ascontiguousarray(deltas, dtype=np.float64).reshape(-1)
        c, a, n = edits.T
        if edits.size and (c.min() < 0 or c.max() >= D or a.min() < 0 or n.min() < 0 or np.any(a + n > F)):
            raise ValidationError(f"edits must lie within the {F} frames and {D} features")
        if (starts is None) != (scales is None):
            raise ValidationError("starts and scales go together")
        if starts is not None:
            starts = np.ascontiguousarray(starts, dtype=np.int64).reshape(-1)
            scales = np.ascontiguousarray(scales, dtype=np.float64).reshape(-1)
            if starts.shape != n.shape or scales.shape != n.shape:
                raise ValidationError(f"starts and scales must have {n.size} entries, got {starts.size}, {scales.size}")
            if starts.size and (starts.min() < 0 or np.any(starts + n > d.size)):
                raise ValidationError(f"starts must keep every edit within the {d.size} deltas")
        elif d.size != int(n.sum()):
            raise ValidationError(f"deltas must hold {int(n.sum())} values (the counts' sum), got {d.size}")
        if leads is not None and (not isinstance(leads, np.ndarray) or leads.dtype != np.int64
                                  or leads.shape != (edits.shape[0],) or not leads.flags.c_contiguous
                                  or not leads.flags.writeable):
            raise ValidationError(f"leads must be a writable contiguous int64 array of shape ({edits.shape[0]},)")
        accepted = np.zeros(edits.shape[0], np.uint8)
        _edits(self._layout, *self._plan, self._geom, self._state, edits, d, float(bound), bool(commit), accepted,
               leads, starts, scales)
        return accepted.view(bool)


def _layout(F: int, D: int, skeleton: Skeleton, plan: PosePlan
            ) -> tuple[NDArray[np.int64], NDArray[np.bool_], NDArray[np.float64]]:
    """The kernel's int64 layout (``motionrep/_c/module.c``, ``edits_setup``), ``(D, J + E)`` which points each
    feature column moves, and ``(D, J + E)`` the factor of each column's bound on how far a change moves each point
    (:func:`_reach_bounds`)."""
    J, E = skeleton.num_joints, skeleton.num_end_sites
    parents = np.asarray(skeleton.parents, np.int64)
    N = plan.translation_columns.shape[0]
    slot = np.full(J, -1, np.int64)
    slot[0] = 0
    slot[np.asarray(skeleton.translated_joints, np.int64)[:N - 1]] = np.arange(1, N)
    entry = np.full(J, -1, np.int64)
    entry[plan.joints] = np.arange(plan.joints.size)
    world = bool(np.any((plan.kinds == WORLD_QUAT) | (plan.kinds == WORLD_IDENTITY)))
    below = np.eye(J, dtype=bool)  # below[a, j]: j is a or under it
    for j in range(1, J):
        below[:, j] |= below[:, parents[j]]
    moved = np.zeros((D, J), bool)
    decoded = np.zeros((D, J), bool)
    for r in range(plan.joints.size):
        j = int(plan.joints[r])
        for c in plan.columns[r][plan.columns[r] >= 0]:
            moved[c] |= below[j]
            if world:
                decoded[c] |= below[j] & (entry >= 0)
            decoded[c, j] = True
    for k in range(N):
        j = 0 if k == 0 else int(skeleton.translated_joints[k - 1])
        for c in plan.translation_columns[k][plan.translation_columns[k] >= 0]:
            moved[c] |= below[j]
    site_parents = np.asarray(skeleton.end_site_parents, np.int64)
    sites = moved[:, site_parents] if E else np.zeros((D, 0), bool)
    # per column (row by row), the joints it moves (2 j, + 1 where its entry is decoded again) and its end sites
    c, j = np.nonzero(moved)
    cjoints = 2 * j + decoded[c, j]
    csites = np.nonzero(sites)[1]
    cstart = np.concatenate([[0], np.cumsum(moved.sum(axis=1))])
    sstart = np.concatenate([[0], np.cumsum(sites.sum(axis=1))])
    kind, lip = _reach_bounds(D, skeleton, plan, below, slot)
    layout = np.concatenate([[F, J, E, D, N, int(world)], parents, slot, site_parents, entry, kind, cstart, sstart,
                             cjoints, csites]).astype(np.int64)
    return layout, np.concatenate([moved, sites], axis=1), lip


def _reach_bounds(D: int, skeleton: Skeleton, plan: PosePlan, below: NDArray[np.bool_], slot: NDArray[np.int64]
                  ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """For each feature column and point (joints, then end sites), a bound on how far a change of the column
    moves the point, where one is known: kind 1, at most ``|change| lip``; kind ``2 + r``, at most
    ``lip 2 x / sqrt(1 - x^2)``, ``x = |change| / |q|`` for the quaternion ``q`` of plan entry ``r`` (``x < 1/2``);
    kind 0, none (the kernel then computes the change). Returns ``(D,)`` kinds and ``(D, J + E)`` ``lip``.

    A translation column moves its joint's points by exactly the change. A rotation turns the joint's subtree
    about the joint, which moves a point at distance ``r`` from it by at most ``r`` times the angle: the angle is
    at most the change for a rotation vector (the exponential map is 1-Lipschitz) or an Euler angle (radians;
    pi / 180 per degree), and at most ``2 asin(x)`` for a quaternion; ``r`` is at most the length of the bones
    from the joint to the point (0 for the joint itself). A subtree with translated joints (bones of varying
    length), world rotations, 6D encodings, and a column read twice get no bound."""
    J, E = skeleton.num_joints, skeleton.num_end_sites
    kind = np.zeros(D, np.int64)
    lip = np.zeros((D, J + E))
    uses = np.zeros(D, np.int64)
    for cols in list(plan.columns) + list(plan.translation_columns):
        np.add.at(uses, cols[cols >= 0], 1)
    bone = np.linalg.norm(skeleton.offsets, axis=1)
    parents = skeleton.parents
    reach = np.zeros((J, J))  # reach[a, j]: the bones' length from a down to j
    for j in range(1, J):
        reach[:, j] = np.where(below[:, parents[j]], reach[:, parents[j]] + bone[j], 0.0)
    site_parents = np.asarray(skeleton.end_site_parents, np.int64)
    sites = np.linalg.norm(skeleton.end_site_offsets, axis=1) if site_parents.size else np.zeros(0)
    rigid = ~(below[:, slot > 0].any(axis=1))  # no translated joint at or below
    # radius[a, p]: the bones' length from joint a down to point p (0 where p is not below a)
    radius = np.concatenate([reach, np.where(below[:, site_parents], reach[:, site_parents] + sites, 0.0)], axis=1)
    factor = {AXIS_ANGLE: 1.0, EULER: 1.0, EULER_DEGREES: np.pi / 180.0}
    for r in range(plan.joints.size):
        j, k, cols = int(plan.joints[r]), int(plan.kinds[r]), plan.columns[r]
        cols = cols[cols >= 0]
        if not rigid[j] or k not in factor and k != QUAT:
            continue
        for c in cols:
            kind[c] = 1 if k != QUAT else 2 + r
            lip[c] = radius[j] * factor.get(k, 1.0)
    for k in range(plan.translation_columns.shape[0]):
        for c in plan.translation_columns[k][plan.translation_columns[k] >= 0]:
            kind[c], lip[c] = 1, 1.0
    kind[uses != 1] = 0
    return kind, lip
