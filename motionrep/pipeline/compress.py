"""The compression pipeline: motion -> features -> codec -> ``.mrc`` bytes, checked, and the one way back.

Encoding.  A :class:`Pipeline` is a compression setting resolved once: the codec and representation objects,
the codec's validated ``Params``, the bound and the seed (:meth:`Pipeline.build` checks them all before any
work).  :meth:`Pipeline.compress` is the one place where a codec's promise is enforced:

1. the representation turns the motion into ``(F, D)`` features and ``(D,)`` weights (Tojo et al. eq. 3);
2. ``codec.encode(features, weights, context)`` runs with a :class:`~motionrep.pipeline.evaluate.MotionContext`: the bound in file units, the
   seed, the frame times, the shared evaluator (``context.evaluate`` / ``evaluate_payload`` /
   ``evaluate_frames``, each an :class:`~motionrep.pipeline.evaluate.ErrorReport`) and a progress callback;
3. the payload is packed into container bytes, **decoded again from those bytes** and measured with the shared
   evaluator; above the bound this raises :class:`~motionrep.errors.BoundNotMetError` and nothing is written;
4. that measurement is stored in the container, which is packed again, decoded again and measured again (the
   two measurements must agree exactly, or decoding is not deterministic and this raises
   :class:`~motionrep.errors.CodecError`).

``--max-error`` and fixed-size parameters: the bound applies whenever one is given (the default is ``2%``),
also when a parameter fixes the size (``rank=5``, ``k=4``); the codec then encodes at that size and the file
is written only if the bound is met.  ``max_error=None`` (``--max-error none``) removes the bound; a codec that
needs one to choose its size (``svd`` without ``rank``, the Fourier codecs without ``k``) then raises
:class:`~motionrep.errors.ParameterError`.

Decoding (:mod:`motionrep.pipeline.decode`, its names public here too).  :func:`decode_at` is the one decode path (codec,
then representation, then :func:`~motionrep.model.ops.fixed_axes_restored`), at any normalised times;
:func:`decompress` decodes at the clip's own frame times or resampled to another frame rate.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import time
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..model._pose import Motion
from .._threads import one_blas_thread
from ..plugin.codec import Codec, Payload
from ..io.container import Container, pack
from ..errors import BoundNotMetError, CodecError, UncodableClipError, naming
from ..model.bound import MaxError, StoredBound, parse_max_error  # public here too, as before motionrep.model.bound existed
from .decode import BVH_DECIMALS, decode_at, decompress, decompress_file, write_decoded  # public here too
from .evaluate import ErrorReport, MotionContext, ProgressCallback
from .figures import CompressionFigures, compression_figures
from ..model.kinematics import character_height
from ..plugin.representation import Representation

__all__ = [
    "DEFAULT_CODEC",
    "DEFAULT_REPRESENTATION",
    "DEFAULT_MAX_ERROR",
    "BOUND_MARGIN",
    "BVH_DECIMALS",
    "MaxError",
    "parse_max_error",
    "Pipeline",
    "CompressResult",
    "SETTING_KEYS",
    "setting_digest",
    "compress_motion",
    "compress_clip",
    "compress_file",
    "decode_at",
    "decompress",
    "decompress_file",
    "write_decoded",
]

# the defaults live in motionrep.defaults (one home, light enough for the command line); named here too
from ..defaults import DEFAULT_CODEC, DEFAULT_MAX_ERROR, DEFAULT_REPRESENTATION  # noqa: E402

#: Codecs are given ``bound * (1 - BOUND_MARGIN)`` as ``context.bound``; the core enforces ``bound`` itself.
BOUND_MARGIN = 1e-6

#: What identifies a compression setting (:meth:`Pipeline.setting`): what ``Pipeline.spec()`` states, with the
#: codec's payload version and the representation's version.
SETTING_KEYS = ("codec", "codec_version", "representation", "representation_version", "params", "max_error", "seed")


def setting_digest(setting: Mapping[str, Any]) -> str:
    """The SHA-256 (hex) of a compression setting: its :data:`SETTING_KEYS` as canonical JSON (sorted keys, no
    whitespace, tuples as lists, the bound as ``str(MaxError)``).  Two settings that give the same bytes for the
    same clip have the same digest; what ``--resume`` compares (``specs/databases.md``)."""
    plain = json.loads(json.dumps({k: setting.get(k) for k in SETTING_KEYS},
                                  default=lambda v: v.item() if hasattr(v, "item") else str(v)))
    text = json.dumps(plain, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


# ---------------------------------------------------------------------------------------------------------------
# compress
# ---------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class CompressResult:
    """What :meth:`Pipeline.compress` produced.

    Attributes:
        data: the ``.mrc`` bytes.
        container: the container those bytes hold.
        report: the shared evaluation of the payload decoded from ``data`` (also stored in it).
        figures: the four compression figures.
        bound: the bound that was enforced, in file units (None: no bound).
        seconds: wall-clock time of encoding and checking.
        evaluations: how many candidate evaluations the codec asked for.
        outcome: the codec's one-line description of its outcome (``Codec.describe``: ``K=5``, ``rank=9``).
    """

    data: bytes
    container: Container
    report: ErrorReport
    figures: CompressionFigures
    bound: float | None
    seconds: float
    evaluations: int
    outcome: str = ""

    def bound_read_as(self) -> str | None:
        """How ``--max-error`` was read for this clip (:meth:`MaxError.read_as`); None without a bound."""
        stored = self.container.bound
        if stored is None or self.bound is None:
            return None
        return stored.read_as(self.report.height, self.report.units)

    def as_dict(self) -> dict[str, Any]:
        """A JSON-serialisable summary (what ``motionrep compress --json`` prints)."""
        c = self.container
        return {
            "codec": c.codec, "codec_version": c.codec_version, "params": dict(c.params), "info": dict(c.info),
            "outcome": self.outcome,
            "representation": c.representation, "representation_version": c.representation_version,
            "frames": c.num_frames, "joints": c.skeleton.num_joints, "end_sites": c.skeleton.num_end_sites,
            "fps": c.fps, "bound": self.bound,
            "max_error_request": None if c.bound is None or c.bound.asked is None else str(c.bound.asked),
            "max_error_read_as": self.bound_read_as(),
            "evaluation": self.report.as_dict(), "figures": self.figures.as_dict(), "bytes": len(self.data),
            "seconds": self.seconds, "evaluations": self.evaluations,
        }


def _check_codable(codec: Codec, motion: Motion) -> None:
    """Refuse, before any work, a clip shorter than ``codec.min_frames``, naming the codecs that can code it."""
    from ..plugin.registry import codecs

    need = int(getattr(codec, "min_frames", 1))
    if motion.num_frames >= need:
        return
    frames = f"{motion.num_frames} frame{'s' if motion.num_frames != 1 else ''}"
    able = [name for name, c in codecs().items() if int(getattr(c, "min_frames", 1)) <= motion.num_frames]
    can = (f"; {', '.join(able)} can (codec={able[0] if 'transform' not in able else 'transform'})" if able
           else "; no installed codec can")
    raise naming(UncodableClipError(f"{codec.name} cannot code a clip of {frames}: it needs at least {need} "
                                    f"frames{can}"), *(("codec=",) if able else ()))


@dataclass(frozen=True, eq=False)
class Pipeline:
    """A compression setting, resolved once: build it with :meth:`build`, then :meth:`compress` any number of
    motions with it.  It pickles by names (the codec and representation are looked up again in the process that
    unpickles it), so it can be sent to worker processes.

    Attributes:
        codec: the codec.
        representation: the representation it compresses.
        params: the codec's validated ``Params``.
        max_error: the requested bound, or None for none.
        seed: random seed; the same motion, pipeline and seed give the same bytes.
    """

    codec: Codec
    representation: Representation
    params: Any
    max_error: MaxError | None
    seed: int = 0

    @classmethod
    def build(cls, codec: str | Codec = DEFAULT_CODEC, representation: str | Representation = DEFAULT_REPRESENTATION,
              params: Mapping[str, Any] | Any = None, max_error: str | float | MaxError | None = DEFAULT_MAX_ERROR,
              seed: int = 0) -> "Pipeline":
        """Look up the codec and representation, validate the parameters and parse the bound.

        Args:
            codec: codec name (or instance).
            representation: representation name (or instance).
            params: codec parameters (strings from the command line are converted), or a ``Params`` instance.
            max_error: ``"2%"`` of the character height, a distance in file units, or None / ``"none"``.
            seed: random seed.

        Raises:
            UnknownPluginError: unknown codec or representation.
            ParameterError: invalid parameters or bound.
        """
        from ..plugin.registry import get_codec, get_representation

        codec_obj = codec if isinstance(codec, Codec) else get_codec(codec)
        rep = representation if isinstance(representation, Representation) else get_representation(representation)
        parsed = params if dataclasses.is_dataclass(params) and not isinstance(params, type) else \
            codec_obj.parse_params(dict(params or {}))
        return cls(codec_obj, rep, parsed, parse_max_error(max_error), int(seed))

    def spec(self) -> dict[str, Any]:
        """The setting as plain data (names, parameters, bound, seed): ``Pipeline.build(**spec)`` rebuilds it."""
        return {"codec": self.codec.name, "representation": self.representation.name,
                "params": dataclasses.asdict(self.params), "max_error": None if self.max_error is None else
                str(self.max_error), "seed": self.seed}

    def setting(self) -> dict[str, Any]:
        """:meth:`spec` with the codec's payload version and the representation's version: everything that makes
        the bytes of a clip (:data:`SETTING_KEYS`)."""
        return dict(self.spec(), codec_version=self.codec.format_version,
                    representation_version=self.representation.version)

    def digest(self) -> str:
        """The SHA-256 (hex) identifying this setting (:func:`setting_digest` of :meth:`setting`); stored in every
        container as ``extra.setting_sha256``."""
        return setting_digest(self.setting())

    def __reduce__(self):
        # the bound travels as the MaxError it is (a worker never parses it again)
        return (_pipeline_from_spec, (dict(self.spec(), max_error=self.max_error),))

    def bound_for(self, motion: Motion) -> float | None:
        """The bound in file units for ``motion`` (None without one).

        Raises:
            ParameterError: for a bound in % of a character whose height is 0.
        """
        return None if self.max_error is None else self.max_error.bound(character_height(motion.skeleton))

    def compress(self, motion: Motion, *, progress: ProgressCallback | None = None,
                 source_bytes: int | None = None, extra: Mapping[str, Any] | None = None) -> CompressResult:
        """Compress ``motion`` into ``.mrc`` bytes whose decoded motion meets the bound.

        Args:
            motion: the clip.
            progress: called as ``progress(stage, fields)`` while the codec works.
            source_bytes: size of the source file, for compression figure (d).
            extra: more keys for the container's ``extra`` metadata (a batch records the source's checksum,
                ``motionrep.pipeline.checksum.SOURCE_CHECKSUM_KEY``); they cannot replace the keys written here.

        Raises:
            ParameterError: a bound in % of a character of height 0, or parameters the codec refuses.
            BoundNotMetError: the bound was not met (measured on the payload decoded from the bytes).
            CodecError: the codec returned something else than a payload, or does not decode deterministically.

        The work runs with one BLAS thread (:func:`motionrep._threads.one_blas_thread`): the bytes never depend
        on how many threads the process, or a batch worker, has.
        """
        with one_blas_thread():
            return self._compress(motion, progress, source_bytes, extra)

    def _compress(self, motion: Motion, progress: ProgressCallback | None, source_bytes: int | None,
                  extra: Mapping[str, Any] | None) -> CompressResult:
        from .._version import __version__
        from ..plugin.registry import provider_of

        codec, rep = self.codec, self.representation
        _check_codable(codec, motion)
        bound = self.bound_for(motion)
        start = time.perf_counter()
        features = rep.to_features(motion)
        weights = np.asarray(rep.weights(motion), dtype=np.float64)
        # codecs aim a hair below the bound (relative 1e-6), so that text formats' rounding of the decoded motion
        # (BVH_DECIMALS) cannot push a result that sits right at the bound over it
        aim = None if bound is None else bound * (1.0 - BOUND_MARGIN)
        context = MotionContext(motion, rep, codec, self.params, aim, self.seed, progress)
        payload = codec.encode(features, weights, context)
        if not isinstance(payload, Payload):
            raise CodecError(f"codec {codec.name!r} returned {type(payload).__name__}, not a Payload")
        container = Container(
            codec=codec.name, codec_version=codec.format_version, codec_plugin=provider_of(codec.name, "codec"),
            params=dataclasses.asdict(self.params), info=dict(payload.info),
            representation=rep.name, representation_version=rep.version,
            representation_plugin=provider_of(rep.name, "representation"),
            skeleton=motion.skeleton, fps=motion.fps, num_frames=motion.num_frames,
            arrays=dict(payload.arrays), evaluation=None,
            extra={**dict(extra or {}), "motionrep_version": __version__, "seed": self.seed,
                   "setting_sha256": self.digest()},
            bound=StoredBound(self.max_error, bound),
        )
        evaluator = context.evaluator
        report = evaluator(decompress(pack(container), codec=codec, representation=rep))
        if bound is not None and report.max_error > bound:
            raise naming(BoundNotMetError(
                f"codec {codec.name!r} did not meet max_error={self.max_error}: the stored payload decodes with "
                f"an L-inf error of {report.max_error:.4g} ({report.max_error_percent:.3g}% of height), above the "
                f"bound {bound:.4g}", best_error=report.max_error, bound=bound), "max_error=")
        # The stored evaluation is always a strict comparison of every point and frame: its ``comparison`` (what
        # a cross-tool comparison left out) is None and is not stored, so the container's metadata is unchanged.
        stored = {k: v for k, v in report.as_dict().items() if k != "comparison"}
        container = dataclasses.replace(container, evaluation=dict(stored, bound=bound))
        data = pack(container)
        again = evaluator(decompress(data, codec=codec, representation=rep))
        if again != report:
            raise CodecError(f"codec {codec.name!r} does not decode deterministically: the same payload measured "
                             f"{report.max_error!r} and then {again.max_error!r}")
        figures = compression_figures(
            num_frames=motion.num_frames, feature_width=features.shape[1], num_parameters=container.num_parameters,
            num_channels=motion.skeleton.num_channels, num_joints=motion.skeleton.num_joints,
            compressed_bytes=len(data), source_bytes=source_bytes, num_end_sites=motion.skeleton.num_end_sites,
            payload_bytes=container.payload_bytes)
        return CompressResult(data=data, container=container, report=report, figures=figures, bound=bound,
                              seconds=time.perf_counter() - start, evaluations=context.evaluations,
                              outcome=describe_outcome(container, codec=codec))


def _pipeline_from_spec(spec: dict[str, Any]) -> Pipeline:
    return Pipeline.build(**spec)


def describe_outcome(container: Container, *, detail: bool = False, codec: Codec | None = None) -> str:
    """The codec's one-line description of a container's outcome (``Codec.describe``), or the generic one
    (:func:`motionrep.plugin.codec.describe_info`) when the codec is not installed."""
    from ..plugin.codec import describe_info

    if codec is None:
        from ..errors import PluginError
        from ..plugin.registry import get_codec

        try:
            codec = get_codec(container.codec)
        except PluginError:
            return describe_info(container.info, detail)
    try:
        return codec.describe(container.info, detail)
    except (TypeError, ValueError, KeyError, IndexError, AttributeError):
        # the info of a file is untrusted and never needed to decode: a value the codec did not write (a crafted
        # `"step": ["x", null]`) gets the generic description, not a traceback
        return describe_info(container.info, detail)


def compress_motion(motion: Motion, codec: str | Codec = DEFAULT_CODEC, *,
                    representation: str | Representation = DEFAULT_REPRESENTATION,
                    max_error: str | float | MaxError | None = DEFAULT_MAX_ERROR,
                    params: Mapping[str, Any] | None = None, seed: int = 0,
                    progress: ProgressCallback | None = None, source_bytes: int | None = None) -> CompressResult:
    """Compress ``motion`` into ``.mrc`` bytes whose decoded motion meets the bound: ``Pipeline.build(codec,
    representation, params, max_error, seed).compress(motion, ...)`` (see :class:`Pipeline`).

    Raises:
        UnknownPluginError: unknown codec or representation.
        ParameterError: invalid parameters or bound (before any work).
        BoundNotMetError: the bound was not met (measured on the payload decoded from the bytes).
    """
    pipeline = Pipeline.build(codec, representation, params, max_error, seed)
    return pipeline.compress(motion, progress=progress, source_bytes=source_bytes)


def compress_clip(pipeline: Pipeline, ref: Any, *, read: tuple[Motion, str | None] | None = None,
                  progress: ProgressCallback | None = None) -> CompressResult:
    """The one path that compresses one clip of a file (:func:`compress_file`, ``motionrep compress``, every batch
    worker): read it, then :meth:`Pipeline.compress` it with its source's size, and its source checksum when
    known.

    Args:
        pipeline: the setting.
        ref: the clip, a :class:`motionrep.pipeline.sources.ClipRef` (its ``source_bytes``, when None, are read
            from the file).
        read: ``(motion, source checksum or None)`` already read (a batch worker reads them first, to skip a clip
            ``--resume`` keeps); None: read ``ref`` here, its file opened once.
        progress: as for :meth:`Pipeline.compress`.

    Raises:
        FormatError: the clip cannot be read.
        and what :meth:`Pipeline.compress` raises.
    """
    from .checksum import SOURCE_CHECKSUM_KEY

    size = ref.source_bytes
    if read is None:
        with ref.open() as src:
            motion, checksum = src.read(ref.clip), None
            if size is None:
                size = src.size(ref.clip)
    else:
        motion, checksum = read
    return pipeline.compress(motion, progress=progress, source_bytes=size,
                             extra=None if checksum is None else {SOURCE_CHECKSUM_KEY: checksum})


def compress_file(source: str | os.PathLike[str], target: str | os.PathLike[str] | None,
                  codec: str | Codec | Pipeline = DEFAULT_CODEC, *, clip: str | None = None,
                  progress: ProgressCallback | None = None, **options: Any) -> CompressResult:
    """Read one clip of ``source``, compress it and write ``target`` atomically.

    The setting is validated before the file is read; nothing is written if anything fails.  ``target=None``
    writes nothing (the result still holds the bytes).

    Args:
        source: any clip-bearing file (:func:`motionrep.pipeline.sources.open_source`).
        target: the ``.mrc`` file to write, or None.
        codec: codec name, or a whole :class:`Pipeline`.
        clip: the clip to read from a database or archive.
        progress: as for :meth:`Pipeline.compress`.
        **options: as for :meth:`Pipeline.build` (``representation``, ``max_error``, ``params``, ``seed``).
    """
    from ..io.container import write_container
    from .sources import ClipRef

    pipeline = codec if isinstance(codec, Pipeline) else Pipeline.build(codec, **options)
    result = compress_clip(pipeline, ClipRef(str(clip or os.fspath(source)), os.fspath(source), clip),
                           progress=progress)
    if target is not None:
        write_container(result.data, target)
    return result
