"""``MotionDataset``: windows of a motion database as a representation's features, for ``torch`` training
(``specs/dataset.md``).

Size: the dataset's options (windows, resampling, extra targets, statistics, augmentation, skeleton groups)
and its batched reading path belong together; the clip index and cache, statistics, split and augmentation
live in ``_clips``, ``_stats``, ``_split`` and ``_augment``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Iterator, Mapping, Sequence
from typing import Any

import numpy as np
import torch

from ..defaults import DEFAULT_REPRESENTATION
from ..model._pose import Motion
from ..errors import ValidationError
from ..model.kinematics import character_height, fk_arrays
from ..model.ops import resample
from ..plugin.registry import get_representation
from ..plugin.representation import Representation
from ._augment import (UP_AXES, contact_joints, foot_contacts, lateral_axis, mirror_pairs, mirror_poses,
                       rotate_poses)
from ._clips import ClipCache, ClipInfo, index_clips
from ._stats import FeatureStats

__all__ = ["MotionDataset", "WindowSampler"]

_DEFAULT_CACHE = 256 * 2 ** 20


class MotionDataset(torch.utils.data.Dataset):
    """Windows of ``length`` frames, every ``stride`` frames, of every clip of ``source``.

    ``ds[i]`` is a dict of tensors: ``"features"`` ``(length, D)`` (normalised when ``stats`` is set), and as
    asked ``"positions"`` ``(length, J + E, 3)`` world positions of joints then end sites, ``"velocities"`` (the
    same, per second), ``"contacts"`` ``(length, C)`` (1.0 = foot on the ground); ``"clip"`` (the clip's index in
    ``clip_names``) and ``"start"`` (first frame, at the dataset's rate).  ``ds[[i, j, ...]]`` gives a whole
    batch at once (leading dimension the batch), which :class:`WindowSampler` with ``DataLoader(batch_size=None)``
    uses.

    Args:
        source: a directory of motion files, a motion file, an ``.h5`` database, an ``.mrc`` archive, or a list.
        representation: a registered representation's name (or a ``Representation`` instance); features come
            from its numpy ``to_features``.
        length: frames per window (>= 1).
        stride: frames between window starts (default ``length``: no overlap).
        fps: resample every clip to this rate first (``motionrep.model.ops.resample``); None keeps each clip's own.
        clips: only these clip names (e.g. ``split_clips(...)["train"]``).
        positions, velocities, contacts: add those targets (``velocities`` are central differences of the
            positions over the whole clip, ``numpy.gradient``, times the rate).
        contact_joints: joint names for ``contacts`` (default: names with foot/toe, else ankle).
        contact_height: a contact joint is on the ground within this fraction of the character's height above
            its floor (its 5th-percentile height over the clip; default 0.04) ...
        contact_speed: ... and slower than this many character heights per second (default 0.25).
        up: ``"x"``, ``"y"``, ``"z"`` or ``"auto"`` (``motionrep.model.ops.detect_up_axis`` on the first clip).
        stats: a :class:`FeatureStats` (or the path of its file) to normalise features with.
        rotate: augment by a rotation about the up axis through the origin, uniform in ``[-rotate, rotate]``
            degrees (True: 180); 0/False: none.
        mirror: probability of mirroring a window left/right (True: 0.5).
        mirror_map: joint names paired by hand (``{"lShldr": "rShldr"}``), over what the names say.
        skeletons: ``"same"`` (every clip must give the first clip's feature columns: checked as each clip is
            prepared) or ``"group"`` (clips may differ; each is read once when indexing, and windows are grouped
            by feature columns: ``ds.group_of`` per window; :class:`WindowSampler` never mixes groups).
        dtype: of the returned tensors (features are encoded in float64 and cast).
        cache_bytes: prepared clips kept per process (default 256 MiB).
        seed: seeds augmentation (with the ``torch`` seed of each worker).
    """

    def __init__(self, source: Any, representation: str = DEFAULT_REPRESENTATION, length: int = 64,
                 stride: int | None = None, fps: float | None = None, *, clips: Iterable[str] | None = None,
                 positions: bool = False, velocities: bool = False, contacts: bool = False,
                 contact_joints: Sequence[str] | None = None, contact_height: float = 0.04,
                 contact_speed: float = 0.25, up: str = "auto", stats: FeatureStats | str | os.PathLike | None = None,
                 rotate: float | bool = 0.0, mirror: float | bool = 0.0, mirror_map: Mapping[str, str] | None = None,
                 skeletons: str = "same", dtype: torch.dtype = torch.float32, cache_bytes: int = _DEFAULT_CACHE,
                 seed: int = 0):
        self.representation = (representation if isinstance(representation, Representation)
                               else get_representation(representation))
        self.length = int(length)
        self.stride = self.length if stride is None else int(stride)
        if self.length < 1 or self.stride < 1:
            raise ValidationError(f"length and stride must be >= 1, got {length} and {stride}")
        if fps is not None and not (math.isfinite(float(fps)) and float(fps) > 0):
            raise ValidationError(f"fps must be a positive number, got {fps!r}")
        if up not in ("auto", *UP_AXES):
            raise ValidationError(f"up must be 'x', 'y', 'z' or 'auto', got {up!r}")
        if skeletons not in ("same", "group"):
            raise ValidationError(f"skeletons must be 'same' or 'group', got {skeletons!r}")
        self.fps = None if fps is None else float(fps)
        self.want = {"positions": bool(positions), "velocities": bool(velocities), "contacts": bool(contacts)}
        self.contact_names = None if contact_joints is None else list(contact_joints)
        self.contact_height, self.contact_speed = float(contact_height), float(contact_speed)
        self.rotate = math.radians(180.0 if rotate is True else float(rotate))
        self.mirror = 0.5 if mirror is True else float(mirror)
        if not 0.0 <= self.mirror <= 1.0:
            raise ValidationError(f"mirror must be a probability in [0, 1], got {mirror!r}")
        self.mirror_map = dict(mirror_map or {})
        if dtype not in (torch.float32, torch.float64):
            raise ValidationError(f"dtype must be torch.float32 or torch.float64, got {dtype}")
        self.dtype, self.seed, self.skeletons = dtype, int(seed), skeletons
        self._numpy_dtype = np.float32 if dtype == torch.float32 else np.float64
        columns = (lambda m: tuple(self.representation.feature_names(m.skeleton))) if skeletons == "group" else None
        infos = index_clips(source, self.fps, clips, columns)
        if not infos:
            raise ValidationError("the dataset's source holds no clips")
        self.clips: list[ClipInfo] = infos
        self._cache = ClipCache(infos, self._prepare, cache_bytes)
        first = self._cache.read(0)
        self.up = UP_AXES[up] if up != "auto" else UP_AXES[_detect_up(first)]
        self.feature_names = tuple(self.representation.feature_names(first.skeleton))
        layouts = [c.layout or self.feature_names for c in infos]
        keys = {k: g for g, k in enumerate(dict.fromkeys(layouts))}
        self.group_layouts = list(keys)
        self._group_of_clip = np.array([keys[k] for k in layouts], dtype=np.int64)
        counts = np.array([max(0, (c.frames - self.length) // self.stride + 1) for c in infos], dtype=np.int64)
        self.window_clip = np.repeat(np.arange(len(infos), dtype=np.int64), counts)
        offsets = np.concatenate([[0], np.cumsum(counts)[:-1]])
        self.window_start = (np.arange(int(counts.sum()), dtype=np.int64) - offsets[self.window_clip]) * self.stride
        self.group_of = self._group_of_clip[self.window_clip]
        self.stats: FeatureStats | None = None
        if stats is not None:
            self.set_stats(stats)
        self._rng: np.random.Generator | None = None
        self._rng_pid = -1
        self._cache.close()

    # -- description -------------------------------------------------------------------------------------------
    @property
    def clip_names(self) -> list[str]:
        """The clips' names, in index order (``"clip"`` of an item indexes this list)."""
        return [c.name for c in self.clips]

    @property
    def width(self) -> int:
        """``D`` of the first clip's skeleton."""
        return len(self.feature_names)

    def __len__(self) -> int:
        return int(self.window_clip.shape[0])

    def __repr__(self) -> str:
        return (f"MotionDataset({len(self)} windows of {self.length} frames from {len(self.clips)} clips, "
                f"{self.representation.name!r}, D={self.width})")

    # -- statistics --------------------------------------------------------------------------------------------
    def compute_stats(self) -> FeatureStats:
        """Mean and std per feature over every frame of every clip of this dataset (call it on the training
        split's dataset), each clip read and encoded in float64 once, one at a time; not normalised, not
        augmented, not cached."""
        if len(self.group_layouts) > 1:
            raise ValidationError("feature statistics need clips of one feature layout (skeletons='group' found "
                                  f"{len(self.group_layouts)}); make one dataset per skeleton")
        rep = self.representation
        arrays = (rep.to_features(self._resampled(self._cache.read(i))) for i in range(len(self.clips)))
        return FeatureStats.from_arrays(arrays, rep.name, rep.version, self.feature_names, self.clip_names)

    def set_stats(self, stats: FeatureStats | str | os.PathLike | None) -> None:
        """Normalise features with ``stats`` from now on (None: stop)."""
        if stats is not None and not isinstance(stats, FeatureStats):
            stats = FeatureStats.load(stats)
        if stats is not None:
            stats.check(self.representation.name, self.representation.version, self.feature_names)
        self.stats = stats

    def normalize(self, features: Any) -> Any:
        """Features as the dataset returns them from raw ones (identity without ``stats``)."""
        return features if self.stats is None else self.stats.normalize(features)

    def denormalize(self, features: Any) -> Any:
        """Raw features (for ``decode_features`` or ``features_to_motion``) from what the dataset returns."""
        return features if self.stats is None else self.stats.denormalize(features)

    # -- per clip ----------------------------------------------------------------------------------------------
    def _resampled(self, motion: Motion) -> Motion:
        return resample(motion, self.fps) if self.fps is not None and motion.fps != self.fps else motion

    def _prepare(self, motion: Motion) -> dict[str, np.ndarray]:
        motion = self._resampled(motion)
        rep = self.representation
        keep = self._numpy_dtype
        out: dict[str, Any] = {"features": np.ascontiguousarray(rep.to_features(motion), dtype=keep)}
        sk = motion.skeleton
        if self.skeletons == "same" and out["features"].shape[1] != self.width or (
                self.skeletons == "same" and tuple(rep.feature_names(sk)) != self.feature_names):
            raise ValidationError(f"clip {motion!r} has other feature columns than the dataset's first clip; "
                                  "use skeletons='group'")
        if any(self.want.values()):
            pos, _ = fk_arrays(sk, motion.rotations, motion.root_translation, motion.joint_translations)
            if self.want["positions"]:
                out["positions"] = pos.astype(keep)
            if self.want["velocities"]:
                vel = np.gradient(pos, axis=0) * motion.fps if pos.shape[0] > 1 else np.zeros_like(pos)
                out["velocities"] = vel.astype(keep)
            if self.want["contacts"]:
                joints = contact_joints(sk, self.contact_names)
                out["contacts"] = foot_contacts(pos, joints, self.up, motion.fps, character_height(sk),
                                                height_threshold=self.contact_height,
                                                speed_threshold=self.contact_speed)
        if self.rotate or self.mirror:
            out["root"] = np.asarray(motion.root_translation)
            out["rotations"] = np.asarray(motion.rotations)
            out["joint_translations"] = np.asarray(motion.joint_translations)
            out["skeleton"] = sk
            out["fps"] = motion.fps
            pairs = mirror_pairs(sk, self.mirror_map)
            out["pairs"] = pairs
            out["lateral"] = lateral_axis(sk, pairs, self.up)
            if self.want["contacts"]:
                out["contact_pairs"] = _contact_pairs(contact_joints(sk, self.contact_names), pairs)
        return out

    # -- windows -----------------------------------------------------------------------------------------------
    def __getitem__(self, index: Any) -> dict[str, torch.Tensor]:
        if np.ndim(index) == 0:  # an int, a numpy or a 0-d torch integer
            batch = self._batch(np.array([int(index)]))
            return {k: v[0] for k, v in batch.items()}
        return self._batch(np.asarray(index, dtype=np.int64).reshape(-1))

    def __getitems__(self, indices: Sequence[int]) -> list[dict[str, torch.Tensor]]:
        """For ``DataLoader(batch_size=B)``: the windows, read clip by clip (then collated as usual)."""
        batch = self._batch(np.asarray(indices, dtype=np.int64))
        return [{k: v[i] for k, v in batch.items()} for i in range(len(indices))]

    def _batch(self, index: np.ndarray) -> dict[str, torch.Tensor]:
        n = len(self)
        if index.size and (index.min() < -n or index.max() >= n):
            raise IndexError(f"window index out of range for a dataset of {n} windows")
        index = np.where(index < 0, index + n, index)
        clip, start = self.window_clip[index], self.window_start[index]
        groups = np.unique(self.group_of[index])
        if groups.size > 1:
            raise ValidationError("a batch mixes windows of clips with different feature columns; use "
                                  "WindowSampler, which batches each group apart")
        keys = ["features"] + [k for k, v in self.want.items() if v]
        order = np.argsort(clip, kind="stable")
        steps = np.arange(self.length)
        bounds = np.flatnonzero(np.diff(clip[order])) + 1
        out: dict[str, np.ndarray] = {}
        tensors: dict[str, torch.Tensor] = {}
        shared = torch.utils.data.get_worker_info() is not None  # filled in place in shared memory: no copy
        for run in np.split(order, bounds):  # to send the batch to the main process
            if run.size == 0:
                continue
            entry = self._cache.get(int(clip[run[0]]))
            rows = start[run][:, None] + steps  # (b, L): vectorised slicing of the clip's arrays
            if self.rotate or self.mirror:
                got = [self._augmented(entry, r) for r in rows[:, 0].tolist()]
                values = {k: np.stack([g[k] for g in got]) for k in keys}
            else:
                values = {k: entry[k][rows] for k in keys}
            for k in keys:
                if k not in out:
                    t = torch.empty((index.size,) + values[k].shape[1:], dtype=self.dtype)
                    tensors[k] = t.share_memory_() if shared else t
                    out[k] = tensors[k].numpy()
                out[k][run] = values[k]
        if not out:  # an empty batch
            tensors = {k: torch.zeros((0, self.length, self.width), dtype=self.dtype) for k in keys[:1]}
        elif self.stats is not None:
            f = out["features"]
            f -= self.stats.mean.astype(f.dtype)
            f /= self.stats.std.astype(f.dtype)
        tensors["clip"] = torch.from_numpy(clip.copy())
        tensors["start"] = torch.from_numpy(start.copy())
        return tensors

    def _generator(self) -> np.random.Generator:
        if self._rng is None or self._rng_pid != os.getpid():
            self._rng = np.random.default_rng([self.seed, torch.initial_seed() % 2 ** 32])
            self._rng_pid = os.getpid()
        return self._rng

    def _augmented(self, entry: dict[str, Any], s: int) -> dict[str, np.ndarray]:
        L, sk = self.length, entry["skeleton"]
        F = entry["root"].shape[0]
        lo, hi = max(0, s - 1), min(F, s + L + 1)  # one frame of margin for the velocities' central differences
        root = entry["root"][lo:hi]
        rot = entry["rotations"][lo:hi]
        jt = entry["joint_translations"][lo:hi]
        rng = self._generator()
        flipped = self.mirror and rng.random() < self.mirror
        if flipped:
            root, rot, jt = mirror_poses(sk, entry["pairs"], entry["lateral"], root, rot, jt)
        if self.rotate:
            root, rot = rotate_poses(rng.uniform(-self.rotate, self.rotate), self.up, root, rot)
        motion = Motion(sk, entry["fps"], root, rot, jt)
        cut = slice(s - lo, s - lo + L)
        out = {"features": self.representation.to_features(motion)[cut]}
        if self.want["positions"] or self.want["velocities"]:
            pos, _ = fk_arrays(sk, rot, root, jt)
            if self.want["positions"]:
                out["positions"] = pos[cut]
            if self.want["velocities"]:
                out["velocities"] = (np.gradient(pos, axis=0) * entry["fps"] if pos.shape[0] > 1
                                     else np.zeros_like(pos))[cut]
        if self.want["contacts"]:
            c = entry["contacts"][s:s + L]
            out["contacts"] = c[:, entry["contact_pairs"]] if flipped else c
        return out

    def preload(self) -> "MotionDataset":
        """Prepare every clip now, in this process, up to ``cache_bytes`` (then close the files): ``DataLoader``
        workers forked afterwards inherit the prepared clips instead of each preparing them again."""
        for i, c in enumerate(self.clips):
            if c.frames >= self.length:
                self._cache.get(i)
        for src in self._cache._sources.values():
            src.close()
        self._cache._sources = {}
        return self

    def close(self) -> None:
        """Close the files this process opened and drop its cached clips."""
        self._cache.close()


def _contact_pairs(joints: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """Column order of the contacts after mirroring: each contact joint takes its partner's column (itself when
    the partner is not a contact joint)."""
    slot = {int(j): k for k, j in enumerate(joints.tolist())}
    return np.array([slot.get(int(pairs[j]), k) for k, j in enumerate(joints.tolist())], dtype=np.int64)


def _detect_up(motion: Motion) -> str:
    from ..model.kinematics import global_positions
    from ..model.ops import detect_up_axis

    return detect_up_axis(global_positions(motion.frames(slice(0, None, max(1, motion.num_frames // 200)))))


class WindowSampler(torch.utils.data.Sampler):
    """Whole batches of window indices, for ``DataLoader(dataset, sampler=WindowSampler(...), batch_size=None)``:
    each batch is read by ``dataset[batch]`` in one vectorised pass.

    Every window appears exactly once per epoch (the last batch of a group may be shorter, unless
    ``drop_last``); a batch holds windows of one skeleton group only.  With ``shuffle``, the order is a
    permutation drawn from ``seed`` and the epoch (:meth:`set_epoch`; it also advances by itself after each
    complete pass), so runs repeat exactly.
    """

    def __init__(self, dataset: MotionDataset, batch_size: int, *, shuffle: bool = True, seed: int = 0,
                 drop_last: bool = False):
        if int(batch_size) < 1:
            raise ValidationError(f"batch_size must be >= 1, got {batch_size}")
        self.groups = np.asarray(dataset.group_of)
        self.batch_size, self.shuffle, self.seed, self.drop_last = int(batch_size), shuffle, int(seed), drop_last
        self.epoch = 0

    def set_epoch(self, epoch: int) -> None:
        """Use the permutation of ``epoch`` for the next pass."""
        self.epoch = int(epoch)

    def _batches(self) -> list[np.ndarray]:
        rng = np.random.default_rng([self.seed, self.epoch])
        out = []
        for g in np.unique(self.groups):
            idx = np.flatnonzero(self.groups == g)
            if self.shuffle:
                idx = rng.permutation(idx)
            cut = range(0, len(idx), self.batch_size)
            out.extend(idx[i:i + self.batch_size] for i in cut
                       if not self.drop_last or i + self.batch_size <= len(idx))
        if self.shuffle:
            out = [out[i] for i in rng.permutation(len(out))]
        return out

    def __iter__(self) -> Iterator[list[int]]:
        batches = self._batches()
        self.epoch += 1
        for b in batches:
            yield b.tolist()

    def __len__(self) -> int:
        sizes = np.bincount(self.groups) if self.groups.size else np.zeros(0, np.int64)
        sizes = sizes[sizes > 0]
        whole = sizes // self.batch_size
        return int(whole.sum() if self.drop_last else (whole + (sizes % self.batch_size > 0)).sum())
