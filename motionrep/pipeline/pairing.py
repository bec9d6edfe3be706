"""Comparison across exports: which points and frames of a reference and a candidate are compared.

The shared error (:mod:`motionrep.pipeline.evaluate`) is strict by default: the candidate must have the reference's joints
in the reference's order, the same end sites, the same frame rate and frame count.  A clip that went through
another tool (Blender, a game engine, a retargeter) is the same character in other clothes: joints reordered,
a namespace prefix (``mixamorig:``), end sites turned into bone tails or dropped, a few helper joints added,
another frame rate.  :class:`MatchOptions` says what may differ, :func:`pair_points` pairs the FK points
(joints and end sites) of the two skeletons, :func:`pair_frames` the frames, :func:`compared_points` gives the
positions paired, and :func:`motionrep.pipeline.evaluate.compare` measures the shared L-infinity error on them (this
module is below :mod:`motionrep.pipeline.evaluate` and never imports it).  The :class:`Comparison` attached to the report
lists exactly which joints, end sites and frames were compared and which were left out, so the number never
hides a mismatch.  See ``specs/comparison.md``.

Matching by name (``match="names"``):

* joints are paired by name, after removing the first of ``strip_prefix`` that starts a name (on both sides);
  the order of the joints does not matter;
* joints that only one side has are refused unless ``ignore_extra`` (then left out and listed);
* an end site of joint ``p`` is paired with the candidate's end site of the same joint; where the other side has
  no end site there, but the joint has one child that the other side does not have and that has no children
  itself (Blender turns an end site into a bone's tail, and motionrep's own glTF writes end sites as nodes
  ``<joint>_end``), the end site is paired with that child if their rest positions agree (within
  :data:`TAIL_TOLERANCE` of the character height); end sites without a counterpart are left out and listed
  (no option needed: end sites carry no motion of their own).

Frames (``resample=True``): the candidate is evaluated at the reference's frame times (``i / fps``): rotations
slerped along the shorter arc, translations linearly (:func:`motionrep.model.ops.interpolate_frames`), and then run
through FK.  Reference frames whose time lies after the candidate's last frame (more than 1e-6 of a frame time)
are left out and listed, and so are candidate frames after the reference's last frame.

Size: one concern, pairing two motions for the shared error; the point pairing (names, prefixes, end sites and
bone tails), the frame pairing and the report of what was left out describe one another.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any, Sequence

import numpy as np
from numpy.typing import NDArray

from ..model._pose import Motion, Skeleton
from ..errors import ValidationError, naming
from ..model.kinematics import character_height, global_positions, point_names, rest_positions

__all__ = ["MatchOptions", "PointPairing", "FramePairing", "Comparison", "STRICT", "TAIL_TOLERANCE",
           "RESAMPLE_METHOD", "pair_points", "pair_frames", "compared_points", "paired_positions",
           "compared_bones", "skeleton_difference"]

#: A bone tail is paired with an end site when their rest positions are this close, in parts of the height.
TAIL_TOLERANCE = 0.01

#: How a candidate at other frame times is sampled at the reference's (stated in every resampled report).
RESAMPLE_METHOD = ("candidate sampled at the reference's frame times: rotations slerped, translations "
                   "linear, then forward kinematics")

_MATCHES = ("order", "names")


@dataclass(frozen=True)
class MatchOptions:
    """What may differ between a reference and a candidate (the default: nothing).

    Attributes:
        match: ``"order"`` (the default: same joints, same order, same end sites) or ``"names"``.
        strip_prefix: prefixes removed from the start of joint names before matching (``("mixamorig:",)``);
            only with ``match="names"``.
        ignore_extra: joints only one side has are left out (and listed) instead of refused.
        resample: a candidate at another frame rate or length is sampled at the reference's frame times.
    """

    match: str = "order"
    strip_prefix: tuple[str, ...] = ()
    ignore_extra: bool = False
    resample: bool = False

    def __post_init__(self) -> None:
        if self.match not in _MATCHES:
            raise ValidationError(f"match must be one of {', '.join(_MATCHES)}, got {self.match!r}")
        prefixes = (self.strip_prefix,) if isinstance(self.strip_prefix, str) else tuple(self.strip_prefix)
        if not all(isinstance(p, str) and p for p in prefixes):
            raise ValidationError(f"strip_prefix must be non-empty strings, got {self.strip_prefix!r}")
        object.__setattr__(self, "strip_prefix", prefixes)
        if prefixes and self.match != "names":
            raise naming(ValidationError("strip_prefix needs match='names'"), "strip_prefix", "match='names'")
        if self.ignore_extra and self.match != "names":
            raise naming(ValidationError("ignore_extra needs match='names'"), "ignore_extra", "match='names'")

    @property
    def strict(self) -> bool:
        """True for the default: nothing may differ."""
        return self.match == "order" and not self.resample


#: The default options: the strict comparison.
STRICT = MatchOptions()


@dataclass(frozen=True)
class PointPairing:
    """Which FK points (joints, then end sites, as :func:`motionrep.model.kinematics.point_names`) are compared.

    Attributes:
        reference: ``(P,)`` point indices of the reference that are compared.
        candidate: ``(P,)`` the candidate's point paired with each.
        names: the reference's names of the compared points.
        joints: reference joints compared.
        end_sites: reference end sites compared (``"<joint>/End Site"``).
        tails: the reference end sites paired with a candidate joint (a bone tail), as ``(end site, joint)``,
            and candidate end sites paired with a reference joint, as ``(joint, end site)``.
        reference_only_joints, candidate_only_joints: joints left out, on each side.
        reference_only_end_sites, candidate_only_end_sites: end sites left out, on each side.
    """

    reference: tuple[int, ...]
    candidate: tuple[int, ...]
    names: tuple[str, ...]
    joints: tuple[str, ...]
    end_sites: tuple[str, ...]
    tails: tuple[tuple[str, str], ...] = ()
    reference_only_joints: tuple[str, ...] = ()
    candidate_only_joints: tuple[str, ...] = ()
    reference_only_end_sites: tuple[str, ...] = ()
    candidate_only_end_sites: tuple[str, ...] = ()


@dataclass(frozen=True)
class FramePairing:
    """Which frames of the reference are compared, and how the candidate was put on them.

    Attributes:
        compared: ``(first, last)`` reference frames compared (inclusive; a contiguous run from frame 0).
        reference_frames: frames of the reference.
        candidate_frames: frames of the candidate.
        positions: ``(n,)`` fractional candidate frame of each compared reference frame.
        method: how the candidate was sampled (None when frame ``i`` is compared with frame ``i``).
        reference_left_out: ``[first, last]`` runs of reference frames not compared (after the candidate's end).
        candidate_left_out: ``[first, last]`` runs of candidate frames not used (after the reference's end).
    """

    compared: tuple[int, int]
    reference_frames: int
    candidate_frames: int
    positions: NDArray[np.float64] = field(repr=False)
    method: str | None = None
    reference_left_out: tuple[tuple[int, int], ...] = ()
    candidate_left_out: tuple[tuple[int, int], ...] = ()


@dataclass(frozen=True)
class Comparison:
    """What a report compared and left out (attached to :class:`~motionrep.pipeline.evaluate.ErrorReport` as
    ``comparison``).

    Attributes:
        match: ``"order"`` or ``"names"``.
        strip_prefix: prefixes removed before matching.
        joints, end_sites: reference names of the joints and end sites compared.
        tails: end sites paired with a bone tail (``(end site, joint)`` pairs, see :class:`PointPairing`).
        frames: ``[first, last]`` reference frames compared; ``frame_count`` how many.
        method: how the candidate was resampled, or None.
        left_out: every joint, end site and frame run left out, by side (empty lists when nothing was).
    """

    match: str
    strip_prefix: tuple[str, ...]
    joints: tuple[str, ...]
    end_sites: tuple[str, ...]
    tails: tuple[tuple[str, str], ...]
    frames: tuple[int, int]
    frame_count: int
    method: str | None
    left_out: dict[str, Any]

    def as_dict(self) -> dict[str, Any]:
        """A JSON-serialisable dict of every field."""
        d = asdict(self)
        d["tails"] = [list(t) for t in self.tails]
        d["frames"] = list(self.frames)
        return d

    @property
    def complete(self) -> bool:
        """True when nothing was left out."""
        return not any(self.left_out.values())

    def lines(self) -> list[str]:
        """Human-readable lines: what was compared, then each thing left out."""
        first, last = self.frames
        how = "by name" + (f" (prefix {', '.join(map(repr, self.strip_prefix))} removed)" if self.strip_prefix
                           else "") if self.match == "names" else "in order"
        tails = f" ({len(self.tails)} paired with a bone tail)" if self.tails else ""
        out = [f"compared: {len(self.joints)} joints {how}, {len(self.end_sites)} end sites{tails}, "
               f"frames {first}-{last} ({self.frame_count})" + (f"; {self.method}" if self.method else "")]
        for key, label in _LEFT_OUT_LABELS:
            items = self.left_out.get(key) or []
            if items:
                shown = [f"{a}-{b}" if a != b else f"{a}" for a, b in items] if "frames" in key else list(items)
                out.append(f"left out: {label} ({len(items) if 'frames' not in key else _count(items)}): "
                           + ", ".join(shown))
        if len(out) == 1:
            out[0] += "; nothing left out"
        return out


_LEFT_OUT_LABELS = (
    ("reference_joints", "joints only the reference has"),
    ("candidate_joints", "joints only the candidate has"),
    ("reference_end_sites", "end sites only the reference has"),
    ("candidate_end_sites", "end sites only the candidate has"),
    ("reference_frames", "reference frames after the candidate's end"),
    ("candidate_frames", "candidate frames after the reference's end"),
)


def _count(runs: Sequence[Sequence[int]]) -> int:
    return sum(b - a + 1 for a, b in runs)


def _key(name: str, prefixes: tuple[str, ...]) -> str:
    for p in prefixes:
        if name.startswith(p) and len(name) > len(p):
            return name[len(p):]
    return name


def skeleton_difference(a: Skeleton, b: Skeleton, a_name: str = "the reference",
                        b_name: str = "the candidate") -> str | None:
    """The first way two skeletons' structures differ, in words naming the first differing joint, or None when
    they share joint names, parents and end sites (offsets may differ).

    ``"joint 3 is 'LowerBack' in walk.bvh but 'lowerback' in walk.mrc (the names differ only in case)"``.
    """
    if a.same_structure(b):
        return None
    count = "" if a.num_joints == b.num_joints else f"{a.num_joints} joints in {a_name} but {b.num_joints} in " \
                                                      f"{b_name}; "
    for j, (x, y) in enumerate(zip(a.names, b.names)):
        if x != y:
            case = " (the names differ only in case)" if x.lower() == y.lower() else ""
            return f"{count}joint {j} is {x!r} in {a_name} but {y!r} in {b_name}{case}"
    if count:
        longer, name = (a, a_name) if a.num_joints > b.num_joints else (b, b_name)
        j = min(a.num_joints, b.num_joints)
        return f"{count}the first joint only {name} has is joint {j}, {longer.names[j]!r}"
    if not np.array_equal(a.parents, b.parents):
        j = int(np.nonzero(a.parents != b.parents)[0][0])
        return (f"joint {a.names[j]!r} has parent {a.names[a.parents[j]]!r} in {a_name} but "
                f"{b.names[b.parents[j]]!r} in {b_name}")
    if a.num_end_sites != b.num_end_sites:
        return f"{a.num_end_sites} end sites in {a_name} but {b.num_end_sites} in {b_name}"
    k = int(np.nonzero(a.end_site_parents != b.end_site_parents)[0][0])
    return (f"end site {k} hangs from {a.names[a.end_site_parents[k]]!r} in {a_name} but from "
            f"{b.names[b.end_site_parents[k]]!r} in {b_name}")


def _keys(skeleton: Skeleton, prefixes: tuple[str, ...], side: str) -> dict[str, int]:
    keys: dict[str, int] = {}
    for j, n in enumerate(skeleton.names):
        k = _key(n, prefixes)
        if k in keys:
            raise ValidationError(f"joints {skeleton.names[keys[k]]!r} and {n!r} of {side} have the same name "
                                  f"once the prefix is removed")
        keys[k] = j
    return keys


def _order_pairing(ref: Skeleton, cand: Skeleton) -> PointPairing:
    what = skeleton_difference(ref, cand)
    if what is not None:
        raise naming(ValidationError(f"cannot compare motions of different skeletons: {what} (match='names' "
                                     "compares joints by name, and the points both have)"), "match='names'")
    names = point_names(ref)
    J = ref.num_joints
    idx = tuple(range(len(names)))
    return PointPairing(idx, idx, names, names[:J], names[J:])


def _tail_pairs(a: Skeleton, b: Skeleton, joint_map: dict[int, int], sites_a: list[int], b_free: set[int],
                height: float) -> dict[int, int]:
    """End sites of ``a`` (indices into its end sites) paired with a leaf joint of ``b`` that ``a`` lacks, hanging
    from the joint paired with the end site's joint, at the end site's rest position (within the tolerance)."""
    rest_a, rest_b = rest_positions(a), rest_positions(b)
    Ja = a.num_joints
    children_b = b.children
    out: dict[int, int] = {}
    for e in sites_a:
        p = int(a.end_site_parents[e])
        if p not in joint_map:
            continue
        q = joint_map[p]
        leaves = [c for c in children_b[q] if c in b_free and not children_b[c]]
        if not leaves:
            continue
        # rest positions relative to the paired joint, so a root offset or translation does not matter
        want = rest_a[Ja + e] - rest_a[p]
        dist = [float(np.linalg.norm((rest_b[c] - rest_b[q]) - want)) for c in leaves]
        best = int(np.argmin(dist))
        if dist[best] <= TAIL_TOLERANCE * max(height, 1e-12):
            out[e] = leaves[best]
            b_free.discard(leaves[best])
    return out


def _name_pairing(ref: Skeleton, cand: Skeleton, options: MatchOptions) -> PointPairing:
    prefixes = options.strip_prefix
    rk, ck = _keys(ref, prefixes, "the reference"), _keys(cand, prefixes, "the candidate")
    joint_map = {rk[k]: ck[k] for k in rk if k in ck}  # reference joint -> candidate joint
    inverse = {c: r for r, c in joint_map.items()}
    if not joint_map:
        raise naming(ValidationError("cannot compare motions by name: the reference and the candidate have no joint "
                                     "name in common" + ("" if prefixes else " (strip_prefix removes a namespace "
                                                                          "such as 'mixamorig:')")), "strip_prefix")
    Jr, Jc = ref.num_joints, cand.num_joints
    rnames, cnames = point_names(ref), point_names(cand)
    # end sites paired with end sites of the paired joint, in order
    site_map: dict[int, int] = {}
    cand_sites: dict[int, list[int]] = {}
    for e, q in enumerate(cand.end_site_parents.tolist()):
        cand_sites.setdefault(q, []).append(e)
    taken: dict[int, int] = {}
    for e, p in enumerate(ref.end_site_parents.tolist()):
        q = joint_map.get(p)
        if q is None:
            continue
        k = taken.get(q, 0)
        if k < len(cand_sites.get(q, [])):
            site_map[e] = cand_sites[q][k]
            taken[q] = k + 1
    height = character_height(ref)
    ref_free = set(range(Jr)) - set(joint_map)
    cand_free = set(range(Jc)) - set(inverse)
    free_ref_sites = [e for e in range(ref.num_end_sites) if e not in site_map]
    ref_tails = _tail_pairs(ref, cand, joint_map, free_ref_sites, cand_free, height)
    used_cand_sites = set(site_map.values())
    free_cand_sites = [e for e in range(cand.num_end_sites) if e not in used_cand_sites]
    cand_tails = _tail_pairs(cand, ref, inverse, free_cand_sites, ref_free, height)

    ref_only = [ref.names[j] for j in sorted(ref_free)]
    cand_only = [cand.names[j] for j in sorted(cand_free)]
    if (ref_only or cand_only) and not options.ignore_extra:
        parts = [f"{len(x)} joint{'s' * (len(x) != 1)} only in the {side}: {_listing(x)}"
                 for x, side in ((ref_only, "reference"), (cand_only, "candidate")) if x]
        raise naming(ValidationError(f"cannot compare motions by name: {'; '.join(parts)} (ignore_extra=True "
                                     "compares the joints both have)"), "ignore_extra=True")
    pairs: list[tuple[int, int]] = [(r, c) for r, c in sorted(joint_map.items())]
    pairs += [(r, Jc + c) for c, r in cand_tails.items()]  # a reference joint that is a candidate end site
    pairs += [(Jr + e, Jc + c) for e, c in sorted(site_map.items())]
    pairs += [(Jr + e, c) for e, c in sorted(ref_tails.items())]
    pairs.sort()
    tails = tuple((rnames[Jr + e], cand.names[c]) for e, c in sorted(ref_tails.items())) + \
        tuple((ref.names[r], cnames[Jc + c]) for c, r in sorted(cand_tails.items()))
    cand_tail_joints = set(cand_tails.values())
    ref_only = [ref.names[j] for j in sorted(ref_free - cand_tail_joints)]
    cand_only = [cand.names[j] for j in sorted(cand_free)]
    ref_sites_out = [rnames[Jr + e] for e in range(ref.num_end_sites) if e not in site_map and e not in ref_tails]
    used = used_cand_sites | set(cand_tails)
    cand_sites_out = [cnames[Jc + e] for e in range(cand.num_end_sites) if e not in used]
    ref_idx = tuple(r for r, _ in pairs)
    return PointPairing(
        reference=ref_idx, candidate=tuple(c for _, c in pairs), names=tuple(rnames[r] for r in ref_idx),
        joints=tuple(rnames[r] for r in ref_idx if r < Jr), end_sites=tuple(rnames[r] for r in ref_idx if r >= Jr),
        tails=tails, reference_only_joints=tuple(ref_only), candidate_only_joints=tuple(cand_only),
        reference_only_end_sites=tuple(ref_sites_out), candidate_only_end_sites=tuple(cand_sites_out))


def _rates(a: float, b: float) -> str:
    """``"120.0005 vs 120"``: two frame rates with the digits that tell them apart."""
    for digits in range(3, 13):
        x, y = f"{a:.{digits}g}", f"{b:.{digits}g}"
        if x != y or math.isclose(a, b, rel_tol=1e-12):
            return f"{x} vs {y}"
    return f"{a!r} vs {b!r}"


def _listing(names: Sequence[str], most: int = 8) -> str:
    shown = ", ".join(repr(n) for n in names[:most])
    return shown + (f" and {len(names) - most} more" if len(names) > most else "")


def pair_points(reference: Skeleton, candidate: Skeleton, options: MatchOptions = STRICT) -> PointPairing:
    """The FK points compared between two skeletons (see the module docstring).

    Raises:
        ValidationError: when the skeletons cannot be compared under ``options``, naming what differs and the
            option that would compare them.
    """
    if options.match == "order":
        return _order_pairing(reference, candidate)
    return _name_pairing(reference, candidate, options)


def pair_frames(reference: Motion, candidate: Motion, options: MatchOptions = STRICT) -> FramePairing:
    """The reference frames compared and the candidate frame (fractional) each is compared with.

    Raises:
        ValidationError: frame counts or rates that differ without ``resample`` (naming ``--resample``), or no
            overlap at all.
    """
    Fr, Fc = reference.num_frames, candidate.num_frames
    same_rate = math.isclose(candidate.fps, reference.fps, rel_tol=1e-6)
    if not options.resample:
        if Fc != Fr:
            rates = "" if same_rate else f" at {_rates(reference.fps, candidate.fps)} fps"
            rates += "" if same_rate else f"; a .mrc decompresses at any rate: fps={reference.fps:g}"
            raise naming(ValidationError(f"cannot compare motions with different frame counts: {Fr} vs {Fc}{rates} "
                                         "(resample=True samples the candidate at the reference's frame times)"),
                         "fps=", "resample=True")
        if not same_rate:
            raise naming(ValidationError(f"cannot compare motions with different frame rates: "
                                         f"{_rates(reference.fps, candidate.fps)} fps (resample=True samples the "
                                         "candidate at the reference's frame times)"), "resample=True")
        return FramePairing((0, Fr - 1), Fr, Fc, np.arange(Fr, dtype=np.float64))
    positions = np.arange(Fr) / reference.fps * candidate.fps  # reference frame times in candidate frames
    inside = positions <= (Fc - 1) + 1e-6
    n = int(np.count_nonzero(inside))
    if n == 0:  # cannot happen (frame 0 is at time 0 on both sides); kept as a clear refusal
        raise ValidationError("the candidate and the reference have no frame time in common")
    positions = np.minimum(positions[:n], Fc - 1)
    cand_end = (Fr - 1) / reference.fps * candidate.fps  # the reference's last time, in candidate frames
    cand_used = int(math.floor(cand_end + 1e-6)) + 1
    if positions.size and not np.all(positions == np.round(positions)):
        method: str | None = RESAMPLE_METHOD
    else:
        method = None if same_rate else RESAMPLE_METHOD
    return FramePairing((0, n - 1), Fr, Fc, positions, method,
                        ((n, Fr - 1),) if n < Fr else (),
                        ((cand_used, Fc - 1),) if cand_used < Fc else ())


def _comparison(points: PointPairing, frames: FramePairing, options: MatchOptions) -> Comparison:
    left_out = {
        "reference_joints": list(points.reference_only_joints),
        "candidate_joints": list(points.candidate_only_joints),
        "reference_end_sites": list(points.reference_only_end_sites),
        "candidate_end_sites": list(points.candidate_only_end_sites),
        "reference_frames": [list(r) for r in frames.reference_left_out],
        "candidate_frames": [list(r) for r in frames.candidate_left_out],
    }
    first, last = frames.compared
    return Comparison(options.match, options.strip_prefix, points.joints, points.end_sites, points.tails,
                      (first, last), last - first + 1, frames.method, left_out)


def compared_points(reference: Motion, candidate: Motion, options: MatchOptions = STRICT
                    ) -> tuple[NDArray[np.float64], tuple[int, ...], Comparison]:
    """What the shared error compares under ``options``: ``(n, P, 3)`` candidate FK positions at the compared
    reference frames, the ``P`` reference points they pair with (indices into the ``J + E`` FK points), and the
    :class:`Comparison` (:func:`motionrep.pipeline.evaluate.compare` measures them).

    Raises:
        ValidationError: when the motions cannot be compared under ``options`` (naming the option that would).
    """
    from ..model.ops import interpolate_frames

    points = pair_points(reference.skeleton, candidate.skeleton, options)
    frames = pair_frames(reference, candidate, options)
    if frames.method is not None:
        candidate = interpolate_frames(candidate, frames.positions, reference.fps)
    elif frames.positions.size != candidate.num_frames:
        candidate = candidate.frames(frames.positions.astype(np.int64))
    comparison = _comparison(points, frames, options)
    cand_pos = global_positions(candidate)[:, list(points.candidate)]
    return cand_pos, points.reference, comparison


def paired_positions(reference: Motion, candidate: Motion, options: MatchOptions = STRICT
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64], PointPairing, FramePairing]:
    """``(n, P, 3)`` reference and candidate FK positions of the compared frames and points (for drawing)."""
    from ..model.ops import interpolate_frames

    points = pair_points(reference.skeleton, candidate.skeleton, options)
    frames = pair_frames(reference, candidate, options)
    if frames.method is not None or frames.positions.size != candidate.num_frames:
        candidate = interpolate_frames(candidate, frames.positions, reference.fps)
    first, last = frames.compared
    ref_pos = global_positions(reference)[first:last + 1][:, list(points.reference)]
    cand_pos = global_positions(candidate)[:, list(points.candidate)]
    return ref_pos, cand_pos, points, frames


def compared_bones(skeleton: Skeleton, points: Sequence[int]) -> NDArray[np.int64]:
    """``(B, 2)`` bones between the compared points (indices into ``points``, the reference's FK points): each
    compared point joined to its nearest compared ancestor, so a skeleton with points left out is still drawn
    as one figure."""
    J = skeleton.num_joints
    where = {int(p): k for k, p in enumerate(points)}
    bones = []
    for k, p in enumerate(int(x) for x in points):
        up = int(skeleton.end_site_parents[p - J]) if p >= J else int(skeleton.parents[p])
        while up >= 0 and up not in where:
            up = int(skeleton.parents[up])
        if up >= 0:
            bones.append((where[up], k))
    return np.array(bones, dtype=np.int64).reshape(-1, 2)
