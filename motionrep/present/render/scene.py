"""What a rendering looks at: the up axis, the candidate put on the reference's frames, the bones to draw, and
one orthographic camera for the whole rendering (screen positions of both clips, their floor shadow, the floor
grid), which follows a clip that travels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ...model._pose import Motion
from ...errors import ValidationError, naming
from ...pipeline.evaluate import ErrorReport
from ...model.kinematics import character_height
from ...model.ops import detect_up_axis, resample  # detect_up_axis: public here too, as before it moved

__all__ = ["detect_up_axis", "to_plot", "align_candidate", "Worst", "bone_segments", "Scene", "build_scene"]


def to_plot(positions: NDArray[np.float64], up: str) -> NDArray[np.float64]:
    """Data coordinates to matplotlib's (x, y, z-up), by a proper rotation (handedness kept)."""
    if up == "z":
        return positions
    if up == "y":  # rotate +90 degrees about X: (x, y, z) -> (x, -z, y)
        return np.stack([positions[..., 0], -positions[..., 2], positions[..., 1]], axis=-1)
    raise ValidationError(f"up axis must be 'y', 'z' or 'auto', got {up!r}")


def align_candidate(reference: Motion, candidate: Motion, ref_name: str = "REF",
                    cand_name: str = "CAND") -> tuple[Motion, str | None]:
    """Check that ``candidate`` can be compared with ``reference`` and put it on the reference's frames.

    Same skeleton structure is required (joint names, parents, end sites; offsets may differ).  Same frame rate:
    the frame counts must match.  Another frame rate: the times of the last frames must agree within one frame
    time of the coarser clip, and the candidate is resampled at the reference's frame times.

    Returns:
        The aligned candidate and a note describing any resampling (``None`` if none was needed).

    Raises:
        ValidationError: naming both files and what differs.
    """
    from ...pipeline.evaluate import skeleton_difference

    what = skeleton_difference(reference.skeleton, candidate.skeleton, ref_name, cand_name)
    if what is not None:
        raise naming(ValidationError(f"{ref_name} and {cand_name} do not share a skeleton: {what} (match='names' "
                                     "compares joints by name, and the points both have)"), "match='names'")
    if math.isclose(reference.fps, candidate.fps, rel_tol=1e-6):
        if reference.num_frames != candidate.num_frames:
            raise naming(ValidationError(
                f"{ref_name} has {reference.num_frames} frames but {cand_name} has {candidate.num_frames} "
                f"(both at {reference.fps:g} fps): compare clips of the same length, or resample=True compares the "
                "frames both have"), "resample=True")
        return candidate, None
    tolerance = 1.0 / min(reference.fps, candidate.fps) + 1e-9
    ref_end = (reference.num_frames - 1) / reference.fps
    cand_end = (candidate.num_frames - 1) / candidate.fps
    if abs(ref_end - cand_end) > tolerance:
        raise naming(ValidationError(
            f"{ref_name} spans {ref_end:.4g} s ({reference.num_frames} frames at {reference.fps:g} fps) but "
            f"{cand_name} spans {cand_end:.4g} s ({candidate.num_frames} frames at {candidate.fps:g} fps): "
            "they must cover the same time (resample=True compares the frames both have)"), "resample=True")
    note = (f"{cand_name} ({candidate.num_frames} frames at {candidate.fps:g} fps) resampled at {ref_name}'s "
            f"{reference.num_frames} frame times ({reference.fps:g} fps)")
    return resample(candidate, reference.fps, reference.num_frames), note


@dataclass(frozen=True)
class Worst:
    """The error report and the index of its worst point among the ``J + E`` FK points."""

    report: ErrorReport
    point: int

    @property
    def name(self) -> str:
        return self.report.joint

    @property
    def frame(self) -> int:
        return self.report.frame

    @property
    def units(self) -> str | None:
        return self.report.units


def bone_segments(motion: Motion, tolerance: float = 1e-3) -> NDArray[np.int64]:
    """``(B, 2)`` point-index pairs ``(parent, child)`` drawn as bones (points as FK returns them: joints, then end
    sites).

    Every end site hangs from its joint, and every joint from its parent **when the link keeps its length**: a
    joint moved by position channels by more than ``tolerance`` of the character height over the clip (a
    root-motion node above the hips, as in Bandai Namco files, a slider) is connected to nothing, so no line is
    drawn that is not a bone of the character.  The root has no parent.
    """
    sk = motion.skeleton
    J = sk.num_joints
    moving: set[int] = set()
    if sk.translated_joints.size:
        size = max(character_height(sk), 1e-12)
        spread = np.ptp(motion.joint_translations, axis=0).max(axis=-1)  # (P,)
        moving = {int(j) for j, d in zip(sk.translated_joints.tolist(), spread.tolist()) if d > tolerance * size}
    pairs = [(int(sk.parents[j]), j) for j in range(1, J) if j not in moving]
    pairs += [(int(p), J + e) for e, p in enumerate(sk.end_site_parents)]
    return np.array(pairs, dtype=np.int64).reshape(-1, 2)


def nice_step(length: float) -> float:
    """A round grid spacing (1, 2 or 5 times a power of ten) close to ``length``."""
    if not length > 0:
        return 1.0
    power = 10.0 ** math.floor(math.log10(length))
    return min((1.0, 2.0, 5.0, 10.0), key=lambda m: abs(math.log(m * power / length))) * power


@dataclass
class Scene:
    """Everything the panels share: screen positions from one fixed camera, the floor, the limits.

    The camera is orthographic, so one screen unit is one file unit everywhere (equal scaling on every axis).
    A clip that travels further than a few body widths is followed: frame ``f`` is drawn shifted by
    ``-shift[f]`` (the root's smoothed screen position), so the character stays large in the middle of the
    picture and the floor moves under it.
    """

    ref: NDArray[np.float64]  # (F, P, 2) screen positions
    cand: NDArray[np.float64] | None
    ref_shadow: NDArray[np.float64]  # (F, P, 2) the points dropped onto the floor
    bones: NDArray[np.int64]
    floor: NDArray[np.float64]  # (G, 2, 2) grid segments on the floor
    xlim: tuple[float, float]
    ylim: tuple[float, float]
    shift: NDArray[np.float64]  # (F, 2) screen shift of each frame (zeros when not following)
    follows: bool = False

    @property
    def aspect(self) -> float:
        return (self.xlim[1] - self.xlim[0]) / (self.ylim[1] - self.ylim[0])


def build_scene(ref_pos: NDArray, cand_pos: NDArray | None, bones: NDArray, up: str, span: NDArray[np.int64],
           height: float, fps: float) -> Scene:
    """Fix the camera for frames ``span[0]..span[-1]`` and project both clips.

    The camera looks across the main direction of the root's travel (a walk is seen from the side, as in the
    paper's Fig. 1), turned 25 degrees towards the front and 15 degrees from above; a clip that stays in place
    is seen three-quarter.  The floor is a grid at the lowest point of the clip.  When the character travels
    across more than 1.5 times the width it needs in one frame, the picture follows it.
    """
    ref = to_plot(ref_pos, up)
    cand = None if cand_pos is None else to_plot(cand_pos, up)
    window = ref[span[0]:span[-1] + 1]
    pts = window.reshape(-1, 3)
    if cand is not None:
        pts = np.concatenate([pts, cand[span[0]:span[-1] + 1].reshape(-1, 3)])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    height = max(height, float(np.max(hi - lo)) * 0.25, 1e-9)
    ground = float(lo[2])

    root = window[:, 0, :2]
    if root.shape[0] > 1 and float(np.ptp(root, axis=0).max()) > 0.25 * height:
        _, _, vt = np.linalg.svd(root - root.mean(axis=0), full_matrices=False)
        along = math.atan2(vt[0, 1], vt[0, 0])
        azim = along - math.pi / 2 + math.radians(25.0)
    else:
        azim = math.radians(-60.0)
    elev = math.radians(15.0)
    right = np.array([-math.sin(azim), math.cos(azim), 0.0])
    upv = np.array([-math.sin(elev) * math.cos(azim), -math.sin(elev) * math.sin(azim), math.cos(elev)])
    screen = np.stack([right, upv], axis=1)  # (3, 2)

    def project(p: NDArray) -> NDArray:
        return p @ screen

    def drop(p: NDArray) -> NDArray:
        q = p.copy()
        q[..., 2] = ground
        return q

    # floor: a rectangle around the travelled area, ruled at a round spacing
    margin = 0.2 * height
    fx0, fx1 = lo[0] - margin, hi[0] + margin
    fy0, fy1 = lo[1] - margin, hi[1] + margin
    step = nice_step(max(height / 3.0, max(fx1 - fx0, fy1 - fy0) / 40.0))  # at most about 40 lines a side
    gx = np.concatenate([[fx0], np.arange(math.ceil(fx0 / step), math.floor(fx1 / step) + 1) * step, [fx1]])
    gy = np.concatenate([[fy0], np.arange(math.ceil(fy0 / step), math.floor(fy1 / step) + 1) * step, [fy1]])
    segs = [[(x, fy0, ground), (x, fy1, ground)] for x in gx]
    segs += [[(fx0, y, ground), (fx1, y, ground)] for y in gy]
    floor = project(np.array(segs, dtype=np.float64))

    ref2 = project(ref)
    cand2 = None if cand is None else project(cand)
    frames = np.arange(span[0], span[-1] + 1)
    body = ref2[frames]  # (n, P, 2)
    if cand2 is not None:
        body = np.concatenate([body, cand2[frames]], axis=1)
    lo2, hi2 = body.min(axis=1), body.max(axis=1)  # (n, 2) each frame's extent on the screen
    need = float(np.max(hi2[:, 0] - lo2[:, 0])) + 0.6 * height
    shift = np.zeros((ref2.shape[0], 2))
    follows = float(hi2[:, 0].max() - lo2[:, 0].min()) > 1.5 * need
    if follows:  # keep the root's (smoothed) screen position fixed: the figure stays large, the floor moves
        centre = ref2[frames, 0, :]
        k = max(1, int(round(0.5 * fps)))  # half a second of smoothing: the camera does not shake with each step
        padded = np.concatenate([np.repeat(centre[:1], k, axis=0), centre, np.repeat(centre[-1:], k, axis=0)])
        kernel = np.ones(2 * k + 1) / (2 * k + 1)
        smooth = np.stack([np.convolve(padded[:, c], kernel, mode="valid") for c in (0, 1)], axis=1)
        shift[frames] = smooth
        lo2, hi2 = lo2 - smooth, hi2 - smooth
        x0 = float(lo2[:, 0].min()) - 0.1 * height
        x1 = float(hi2[:, 0].max()) + 0.1 * height
        y0 = float(lo2[:, 1].min()) - 0.25 * height  # a band of floor under the feet
    else:
        flo = floor.reshape(-1, 2)
        x0 = min(float(lo2[:, 0].min()), flo[:, 0].min()) - 0.03 * height
        x1 = max(float(hi2[:, 0].max()), flo[:, 0].max()) + 0.03 * height
        y0 = min(float(lo2[:, 1].min()), flo[:, 1].min()) - 0.03 * height
    y1 = float(hi2[:, 1].max()) + 0.06 * height
    return Scene(ref2, cand2, project(drop(ref)), bones, floor, (x0, x1), (y0, y1), shift, follows)
