"""The compression pipeline: motion -> features -> codec -> ``.mrc`` bytes, checked, and back.

:func:`compress_motion` is the one place where a codec's promise is enforced:

1. the codec and representation are looked up and the codec parameters validated, before any work;
2. the representation turns the motion into ``(F, D)`` features and ``(D,)`` weights (Tojo et al. eq. 3);
3. ``codec.encode(features, weights, context)`` runs with a real :class:`EncodeContext`: the bound in file
   units, the seed, the frame times, the shared evaluator (``context.evaluate`` / ``evaluate_payload``) and a
   progress callback;
4. the payload is packed into container bytes, **decoded again from those bytes** and measured with the shared
   evaluator; above the bound this raises :class:`~motionrep.errors.BoundNotMetError` and nothing is written;
5. that measurement is stored in the container, which is packed again, decoded again and measured again (the
   two measurements must agree exactly, or decoding is not deterministic and this raises
   :class:`~motionrep.errors.CodecError`).

``--max-error`` and fixed-size parameters: the bound applies whenever one is given (the default is ``2%``),
also when a parameter fixes the size (``rank=5``, ``k=4``); the codec then encodes at that size and the file
is written only if the bound is met.  ``max_error=None`` (``--max-error none``) removes the bound; a codec that
needs one to choose its size (``svd`` without ``rank``, the Fourier codecs without ``k``) then raises
:class:`~motionrep.errors.ParameterError`.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._model import Motion
from .codec import Codec, Payload, frame_times
from .container import Container, pack, read_container, unpack
from .errors import (BoundNotMetError, CodecError, ContainerError, FormatError, MotionrepError, ParameterError,
                     UnknownPluginError)
from .evaluate import CompressionFigures, ErrorReport, Evaluator, compression_figures
from .kinematics import character_height, global_positions
from .representation import Representation

__all__ = [
    "DEFAULT_CODEC",
    "DEFAULT_REPRESENTATION",
    "DEFAULT_MAX_ERROR",
    "MaxError",
    "parse_max_error",
    "CompressResult",
    "compress_motion",
    "compress_file",
    "decode_container",
    "decompress",
    "decompress_file",
    "resample_times",
    "fixed_axes_restored",
    "write_decoded",
    "BOUND_MARGIN",
    "ProgressCallback",
    "ARCHIVE_FORMAT",
    "write_archive",
    "is_archive",
    "read_archive",
    "archive_sizes",
]

#: Codec used when none is named.
DEFAULT_CODEC = "adaptive-fourier"
#: Representation used when none is named (Tojo et al. 2022, section 3).
DEFAULT_REPRESENTATION = "root-quat-axis-angle"
#: The default bound: 2 % of the character height.
DEFAULT_MAX_ERROR = "2%"

#: Codecs are given ``bound * (1 - BOUND_MARGIN)`` as ``context.bound``; the core enforces ``bound`` itself.
BOUND_MARGIN = 1e-6

#: ``progress(stage, fields)``: called by codecs through ``context.progress``.
ProgressCallback = Callable[[str, Mapping[str, Any]], None]


# ---------------------------------------------------------------------------------------------------------------
# the bound
# ---------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class MaxError:
    """A requested L-infinity bound: a percentage of the character height, or a distance in file units."""

    value: float
    percent: bool

    def bound(self, height: float) -> float:
        """The bound in file units for a character of ``height``.

        Raises:
            ParameterError: for a percentage of a character whose height is 0.
        """
        if not self.percent:
            return self.value
        if height <= 0:
            raise ParameterError("the character height is 0, so a bound in % of it means nothing; give "
                                 "--max-error as a distance in file units")
        return self.value / 100.0 * height

    def __str__(self) -> str:
        return f"{self.value:g}%" if self.percent else f"{self.value:g}"


_MAX_ERROR_RE = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*(%?)\s*$")


def parse_max_error(value: str | float | MaxError | None) -> MaxError | None:
    """Parse ``"2%"`` (percent of character height), ``"3.5"`` (file units), ``"none"`` or None (no bound).

    Raises:
        ParameterError: for anything else, or a bound that is not > 0.
    """
    if value is None or isinstance(value, MaxError):
        return value
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        number, percent = float(value), False
    else:
        text = str(value)
        if text.strip().lower() in ("none", "off", ""):
            return None
        m = _MAX_ERROR_RE.match(text)
        if not m:
            raise ParameterError(f"invalid --max-error {text!r}: give a percentage of the character height "
                                 "('2%'), a distance in file units ('1.5'), or 'none'")
        number, percent = float(m.group(1)), bool(m.group(2))
    if not math.isfinite(number) or number <= 0:
        raise ParameterError(f"--max-error must be > 0, got {value!r}")
    return MaxError(number, percent)


def fixed_axes_restored(motion: Motion) -> Motion:
    """``motion`` with every translation axis that has no position channel set back to the joint's OFFSET.

    A skeleton whose root (or another translated joint) lacks a position channel on some axis cannot move along
    it: the pose model requires that axis to equal the OFFSET.  Features decoded from a lossy payload carry
    small deviations there; they are removed here (before evaluation and before writing), so every decoded
    motion is a valid motion of its skeleton and can be written to BVH.
    """
    sk = motion.skeleton
    root_axes = sk.position_axes[0]
    root = motion.root_translation
    if len(root_axes) < 3:
        root = root.copy()
        for i, axis in enumerate("XYZ"):
            if axis not in root_axes:
                root[:, i] = sk.offsets[0, i]
    jt = motion.joint_translations
    if jt is not None and jt.shape[1]:
        partial = [(k, j) for k, j in enumerate(sk.translated_joints.tolist()) if len(sk.position_axes[j]) < 3]
        if partial:
            jt = jt.copy()
            for k, j in partial:
                for i, axis in enumerate("XYZ"):
                    if axis not in sk.position_axes[j]:
                        jt[:, k, i] = sk.offsets[j, i]
    if root is motion.root_translation and jt is motion.joint_translations:
        return motion
    return motion.replace(root_translation=root, joint_translations=jt)


# ---------------------------------------------------------------------------------------------------------------
# the encode context
# ---------------------------------------------------------------------------------------------------------------
class _Context:
    """The real :class:`motionrep.codec.EncodeContext` handed to ``codec.encode``."""

    def __init__(self, *, evaluator: Evaluator, representation: Representation, codec: Codec, params: Any,
                 bound: float | None, seed: int, progress: ProgressCallback | None):
        self.params = params
        self.bound = bound
        self.seed = int(seed)
        self.times = frame_times(evaluator.reference.num_frames)
        self.evaluations = 0
        self._evaluator = evaluator
        self._rep = representation
        self._codec = codec
        self._progress = progress
        self.times.flags.writeable = False

    def evaluate(self, features: ArrayLike) -> ErrorReport:
        return self._evaluator(self._decoded(features))

    def evaluate_payload(self, payload: Payload) -> ErrorReport:
        return self.evaluate(self._codec.decode(payload, self.times))

    def evaluate_frames(self, features: ArrayLike, first: int) -> ErrorReport:
        return self._evaluator.positions_error(global_positions(self._decoded(features)), first=int(first))

    def _decoded(self, features: ArrayLike) -> Motion:
        """Candidate features as the valid motion they decode to (counted in ``evaluations``)."""
        ref = self._evaluator.reference
        self.evaluations += 1
        return fixed_axes_restored(self._rep.from_features(features, ref.skeleton, ref.fps))

    def progress(self, stage: str, **fields: Any) -> None:
        if self._progress is not None:
            self._progress(stage, fields)


# ---------------------------------------------------------------------------------------------------------------
# compress
# ---------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class CompressResult:
    """What :func:`compress_motion` produced.

    Attributes:
        data: the ``.mrc`` bytes.
        container: the container those bytes hold.
        report: the shared evaluation of the payload decoded from ``data`` (also stored in it).
        figures: the four compression figures.
        bound: the bound that was enforced, in file units (None: no bound).
        seconds: wall-clock time of encoding and checking.
        evaluations: how many candidate evaluations the codec asked for.
    """

    data: bytes
    container: Container
    report: ErrorReport
    figures: CompressionFigures
    bound: float | None
    seconds: float
    evaluations: int

    def as_dict(self) -> dict[str, Any]:
        """A JSON-serialisable summary (what ``motionrep compress --json`` prints)."""
        c = self.container
        return {
            "codec": c.codec, "codec_version": c.codec_version, "params": dict(c.params), "info": dict(c.info),
            "representation": c.representation, "representation_version": c.representation_version,
            "frames": c.num_frames, "joints": c.skeleton.num_joints, "end_sites": c.skeleton.num_end_sites,
            "fps": c.fps, "bound": self.bound, "max_error_request": c.extra.get("max_error"),
            "evaluation": self.report.as_dict(), "figures": self.figures.as_dict(), "bytes": len(self.data),
            "seconds": self.seconds, "evaluations": self.evaluations,
        }


def _resolve(codec: str | Codec, representation: str | Representation,
             params: Mapping[str, Any] | None) -> tuple[Codec, Representation, Any]:
    from .plugins import get_codec, get_representation

    codec_obj = codec if isinstance(codec, Codec) else get_codec(codec)
    rep = representation if isinstance(representation, Representation) else get_representation(representation)
    parsed = params if dataclasses.is_dataclass(params) and not isinstance(params, type) else \
        codec_obj.parse_params(dict(params or {}))
    return codec_obj, rep, parsed


def compress_motion(motion: Motion, codec: str | Codec = DEFAULT_CODEC, *,
                    representation: str | Representation = DEFAULT_REPRESENTATION,
                    max_error: str | float | MaxError | None = DEFAULT_MAX_ERROR,
                    params: Mapping[str, Any] | None = None, seed: int = 0,
                    progress: ProgressCallback | None = None, source_bytes: int | None = None) -> CompressResult:
    """Compress ``motion`` into ``.mrc`` bytes whose decoded motion meets the bound.

    Args:
        motion: the clip.
        codec: codec name (or instance).
        representation: representation name (or instance).
        max_error: the bound: ``"2%"`` of the character height, a distance in file units, or None for none.
        params: codec parameters (strings from the command line are converted and validated).
        seed: random seed; the same motion, options and seed give the same bytes.
        progress: called as ``progress(stage, fields)`` while the codec works.
        source_bytes: size of the source file, for compression figure (d).

    Returns:
        A :class:`CompressResult`.

    Raises:
        UnknownPluginError: unknown codec or representation.
        ParameterError: invalid parameters or bound (before any work).
        BoundNotMetError: the bound was not met (measured on the payload decoded from the bytes).
    """
    from . import __version__
    from .plugins import provider_of

    codec_obj, rep, parsed = _resolve(codec, representation, params)
    limit = parse_max_error(max_error)
    bound = None if limit is None else limit.bound(character_height(motion.skeleton))
    start = time.perf_counter()
    features = rep.to_features(motion)
    weights = np.asarray(rep.weights(motion), dtype=np.float64)
    evaluator = Evaluator(motion)
    # codecs aim a hair below the bound (relative 1e-6), so that text formats' rounding of the decoded motion
    # (BVH_DECIMALS) cannot push a result that sits right at the bound over it
    aim = None if bound is None else bound * (1.0 - BOUND_MARGIN)
    context = _Context(evaluator=evaluator, representation=rep, codec=codec_obj, params=parsed, bound=aim,
                       seed=seed, progress=progress)
    payload = codec_obj.encode(features, weights, context)
    if not isinstance(payload, Payload):
        raise CodecError(f"codec {codec_obj.name!r} returned {type(payload).__name__}, not a Payload")
    container = Container(
        codec=codec_obj.name, codec_version=codec_obj.format_version,
        codec_plugin=provider_of(codec_obj.name, "codec"),
        params=dataclasses.asdict(parsed), info=dict(payload.info),
        representation=rep.name, representation_version=rep.version,
        representation_plugin=provider_of(rep.name, "representation"),
        skeleton=motion.skeleton, fps=motion.fps, num_frames=motion.num_frames,
        arrays=dict(payload.arrays), evaluation=None,
        extra={"motionrep_version": __version__, "seed": int(seed), "max_error": None if limit is None else str(limit)},
    )
    report = evaluator(decode_container(unpack(pack(container)), codec=codec_obj, representation=rep))
    if bound is not None and report.max_error > bound:
        raise BoundNotMetError(
            f"codec {codec_obj.name!r} did not meet --max-error {limit}: the stored payload decodes with an "
            f"L-inf error of {report.max_error:.4g} ({report.max_error_percent:.3g}% of height), above the bound "
            f"{bound:.4g}", best_error=report.max_error, bound=bound)
    evaluation = dict(report.as_dict(), bound=bound)
    container = dataclasses.replace(container, evaluation=evaluation)
    data = pack(container)
    again = evaluator(decode_container(unpack(data), codec=codec_obj, representation=rep))
    if again != report:
        raise CodecError(f"codec {codec_obj.name!r} does not decode deterministically: the same payload measured "
                         f"{report.max_error!r} and then {again.max_error!r}")
    figures = compression_figures(
        num_frames=motion.num_frames, feature_width=features.shape[1], num_parameters=container.num_parameters,
        num_channels=motion.skeleton.num_channels, num_joints=motion.skeleton.num_joints,
        compressed_bytes=len(data), source_bytes=source_bytes)
    return CompressResult(data=data, container=container, report=report, figures=figures, bound=bound,
                          seconds=time.perf_counter() - start, evaluations=context.evaluations)


def compress_file(source: str | os.PathLike[str], target: str | os.PathLike[str] | None,
                  codec: str | Codec = DEFAULT_CODEC, *, clip: str | None = None, **options: Any) -> CompressResult:
    """Read ``source``, compress it with :func:`compress_motion` and write ``target`` atomically.

    The codec, representation, parameters and bound are validated before the file is read.  Nothing is
    written if anything fails.  ``target=None`` writes nothing (the result still holds the bytes).

    Args:
        source: a motion file (``.bvh``, ``.npz``, ``.h5``).
        target: the ``.mrc`` file to write, or None.
        codec: codec name.
        clip: the clip to read from an HDF5 database.
        **options: as for :func:`compress_motion` (``representation``, ``max_error``, ``params``, ``seed``,
            ``progress``).
    """
    from .io import read
    from .container import write_container

    codec_obj, rep, parsed = _resolve(codec, options.pop("representation", DEFAULT_REPRESENTATION),
                                      options.pop("params", None))
    parse_max_error(options.get("max_error", DEFAULT_MAX_ERROR))
    motion = read(source, clip=clip) if clip is not None else read(source)
    size = Path(source).stat().st_size if clip is None else None
    result = compress_motion(motion, codec_obj, representation=rep, params=parsed, source_bytes=size, **options)
    if target is not None:
        write_container(result.data, target)
    return result


# ---------------------------------------------------------------------------------------------------------------
# decompress
# ---------------------------------------------------------------------------------------------------------------
def _codec_for(container: Container, path) -> Codec:
    from .plugins import get_codec

    codec = get_codec(container.codec, provided_by=container.codec_plugin)
    readable = tuple(codec.readable_versions) or (codec.format_version,)
    if container.codec_version not in readable:
        plugin = f" (plugin {container.codec_plugin!r})" if container.codec_plugin else ""
        raise ContainerError(f"codec {container.codec!r} payload version {container.codec_version} is not readable "
                             f"by the installed codec{plugin}, which reads versions "
                             f"{', '.join(map(str, readable))}", path)
    return codec


def _representation_for(container: Container, path) -> Representation:
    from .plugins import get_representation

    try:
        rep = get_representation(container.representation)
    except UnknownPluginError as exc:
        hint = (f" (provided by plugin {container.representation_plugin!r}, which is not installed or not loaded)"
                if container.representation_plugin else "")
        raise UnknownPluginError(f"{path or '<memory>'}: unknown representation {container.representation!r}{hint}; "
                                 + str(exc).split("; ", 1)[-1]) from None
    if rep.version != container.representation_version:
        raise ContainerError(f"representation {rep.name!r} version {container.representation_version} in the file, "
                             f"but the installed one is version {rep.version}", path)
    return rep


def resample_times(num_frames: int, fps: float, new_fps: float) -> NDArray[np.float64]:
    """Normalised times of the frames of a clip resampled from ``fps`` to ``new_fps``.

    The first frame stays at t = 0; frames follow every ``1 / new_fps`` seconds up to the last source frame
    (``(num_frames - 1) / fps`` seconds), which is included when it falls on the new grid.
    """
    if not (math.isfinite(new_fps) and new_fps > 0):
        raise ParameterError(f"--fps must be > 0, got {new_fps!r}")
    if num_frames == 1:
        return np.zeros(1)
    duration = (num_frames - 1) / fps
    count = int(math.floor(duration * new_fps + 1e-9)) + 1
    return np.minimum(np.arange(count) / new_fps / duration, 1.0)


def decode_container(container: Container, fps: float | None = None, *, codec: Codec | None = None,
                     representation: Representation | None = None, path=None) -> Motion:
    """The motion a container holds, at its own frame rate or resampled to ``fps``.

    Raises:
        UnknownPluginError: naming the codec or representation (and its plugin) when it is not installed.
        ContainerError: for a payload or representation version the installed plugin cannot read.
    """
    codec = codec or _codec_for(container, path)
    rep = representation or _representation_for(container, path)
    payload = Payload(arrays=container.arrays, info=container.info)
    if fps is None or math.isclose(fps, container.fps, rel_tol=1e-12):
        times, out_fps = frame_times(container.num_frames), container.fps
    else:
        times, out_fps = resample_times(container.num_frames, container.fps, float(fps)), float(fps)
    try:
        features = codec.decode(payload, times)
    except MotionrepError:
        raise
    except (KeyError, ValueError, IndexError, TypeError) as exc:
        raise ContainerError(f"codec {codec.name!r} cannot decode this payload: {type(exc).__name__}: {exc}",
                             path) from None
    return fixed_axes_restored(rep.from_features(features, container.skeleton, out_fps))


def decompress(data: bytes | Container, fps: float | None = None) -> Motion:
    """Decode ``.mrc`` bytes (or a parsed container) to a motion, optionally resampled to ``fps``."""
    container = data if isinstance(data, Container) else unpack(data)
    return decode_container(container, fps)


def decompress_file(source: str | os.PathLike[str], target: str | os.PathLike[str] | None = None,
                    fps: float | None = None) -> Motion:
    """Read a ``.mrc`` file, decode it (resampled to ``fps`` if given) and write ``target`` (any motion format).

    Raises:
        ContainerError: the file is not a valid ``.mrc`` file (truncated, altered, unknown version).
        UnknownPluginError: its codec or representation is not installed (naming the plugin that provides it).
    """
    container = read_container(source)
    motion = decode_container(container, fps, path=source)
    if target is not None:
        write_decoded(motion, target)
    return motion


#: Decimals of BVH channel values written by :func:`write_decoded`: enough that text rounding (at most
#: 5e-10 units or degrees) cannot move a decoded motion measurably closer to or past its bound.
BVH_DECIMALS = 9


def write_decoded(motion: Motion, target: str | os.PathLike[str]) -> None:
    """Write a decoded motion; BVH with :data:`BVH_DECIMALS` decimals, so the file keeps the decoded values."""
    from .io import format_of, write

    if format_of(target) == "bvh":
        write(motion, target, decimals=BVH_DECIMALS)
    else:
        write(motion, target)


# ---------------------------------------------------------------------------------------------------------------
# many clips
# ---------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ClipJob:
    """One clip of a batch: its name in the output, its file and (for HDF5 databases) its clip name."""

    name: str
    path: str
    clip: str | None = None


def _job_run(job: ClipJob, options: dict[str, Any]) -> tuple[str, bytes | None, dict[str, Any]]:
    """Worker entry point (a top-level function, so it works with the ``spawn`` start method)."""
    try:
        result = compress_file(job.path, None, clip=job.clip, **options)
    except MotionrepError as exc:
        return job.name, None, {"error": str(exc), "type": type(exc).__name__}
    return job.name, result.data, result.as_dict()


def _init_worker() -> None:
    try:
        import torch

        torch.set_num_threads(1)
    except ImportError:  # pragma: no cover - decoding-only installs
        pass


def batch_jobs(source: str | os.PathLike[str]) -> list[ClipJob]:
    """The clips of a directory (every ``.bvh``/``.npz`` file below it, sorted) or of an HDF5 database.

    Names: a database's clip names; for a directory, the path relative to it without suffix, ``/`` replaced by
    ``__``.

    Raises:
        FormatError: if ``source`` holds no clips.
    """
    from .io import list_clips

    src = Path(source)
    if src.is_dir():
        files = sorted(p for p in src.rglob("*") if p.is_file() and p.suffix.lower() in (".bvh", ".npz"))
        jobs = [ClipJob(str(p.relative_to(src).with_suffix("")).replace(os.sep, "__"), str(p)) for p in files]
    else:
        jobs = [ClipJob(name, str(src), name) for name in list_clips(src)]
    if not jobs:
        raise FormatError("no motion clips found (looked for .bvh and .npz files)", source)
    return jobs


def compress_batch(jobs: Iterable[ClipJob], *, jobs_count: int = 1,
                   on_done: Callable[[str, bytes | None, dict[str, Any]], None] | None = None,
                   **options: Any) -> dict[str, tuple[bytes | None, dict[str, Any]]]:
    """Compress many clips, in ``jobs_count`` worker processes (spawned) when > 1.

    Returns ``{name: (bytes or None, summary)}`` in job order; a clip that failed has None and
    ``summary["error"]``.  ``on_done(name, bytes, summary)`` is called as each clip finishes.
    """
    jobs = list(jobs)
    options = {k: v for k, v in options.items() if k != "progress"}
    results: dict[str, tuple[bytes | None, dict[str, Any]]] = {}

    def done(name: str, data: bytes | None, summary: dict[str, Any]) -> None:
        results[name] = (data, summary)
        if on_done is not None:
            on_done(name, data, summary)

    if jobs_count <= 1 or len(jobs) <= 1:
        for job in jobs:
            done(*_job_run(job, options))
    else:
        import concurrent.futures as cf
        import multiprocessing

        env_key = "OPENBLAS_NUM_THREADS"
        old = os.environ.get(env_key)
        os.environ[env_key] = "1"  # workers: one BLAS thread each (they inherit the environment)
        try:
            with cf.ProcessPoolExecutor(max_workers=jobs_count, mp_context=multiprocessing.get_context("spawn"),
                                        initializer=_init_worker) as pool:
                futures = [pool.submit(_job_run, job, options) for job in jobs]
                for fut in cf.as_completed(futures):
                    done(*fut.result())
        finally:
            if old is None:
                os.environ.pop(env_key, None)
            else:
                os.environ[env_key] = old
    return {job.name: results[job.name] for job in jobs}


#: Identifies an HDF5 archive of ``.mrc`` containers (``specs/container.md``).
ARCHIVE_FORMAT = "motionrep-mrc-archive"
ARCHIVE_VERSION = 1


def write_archive(clips: Mapping[str, bytes], path: str | os.PathLike[str]) -> None:
    """Write ``{name: .mrc bytes}`` to one HDF5 archive, atomically (layout in ``specs/container.md``)."""
    import h5py

    from .io import atomic_path

    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as f:
            f.attrs["format"] = ARCHIVE_FORMAT
            f.attrs["format_version"] = np.int64(ARCHIVE_VERSION)
            group = f.create_group("clips")
            for name, data in clips.items():
                if not name or "/" in name or name in (".", ".."):
                    raise FormatError(f"invalid clip name {name!r} for an archive", path)
                group.create_dataset(name, data=np.frombuffer(data, dtype=np.uint8))


def is_archive(path: str | os.PathLike[str]) -> bool:
    """True if ``path`` is an HDF5 archive of ``.mrc`` containers."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            return f.attrs.get("format") == ARCHIVE_FORMAT
    except OSError:
        return False


def archive_sizes(path: str | os.PathLike[str]) -> dict[str, int]:
    """``{clip name: bytes of its .mrc container}`` of an HDF5 archive, in name order, without reading them.

    Raises:
        ContainerError: naming the file if it is not an archive.
    """
    import h5py

    try:
        with h5py.File(path, "r") as f:
            if f.attrs.get("format") != ARCHIVE_FORMAT or "clips" not in f:
                raise ContainerError("not a motionrep archive of .mrc containers", path)
            group = f["clips"]
            return {name: int(group[name].shape[0]) for name in sorted(group)}
    except OSError as exc:
        raise ContainerError(f"cannot read archive: {exc}", path) from None


def read_archive(path: str | os.PathLike[str], clip: str | None = None) -> dict[str, Container]:
    """The containers of an HDF5 archive (all, or only ``clip``), each verified like a ``.mrc`` file.

    Raises:
        ContainerError: naming the file and clip when one is missing or fails its checks.
    """
    import h5py

    out: dict[str, Container] = {}
    try:
        with h5py.File(path, "r") as f:
            if f.attrs.get("format") != ARCHIVE_FORMAT:
                raise ContainerError("not a motionrep archive of .mrc containers", path)
            version = int(f.attrs.get("format_version", -1))
            if version != ARCHIVE_VERSION:
                raise ContainerError(f"unsupported archive version {version} (this motionrep reads "
                                     f"{ARCHIVE_VERSION})", path)
            group = f["clips"]
            names = [clip] if clip is not None else sorted(group)
            for name in names:
                if name not in group:
                    raise ContainerError(f"no clip {name!r} in archive; clips: {', '.join(sorted(group))}", path)
                out[name] = unpack(group[name][()].tobytes(), f"{path}[{name}]")
    except OSError as exc:
        raise ContainerError(f"cannot read archive: {exc}", path) from None
    return out
