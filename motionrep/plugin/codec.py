"""The motion-codec interface.

A codec compresses a ``(F, D)`` feature matrix (from a :class:`~motionrep.plugin.representation.Representation`) into a
:class:`Payload` of arrays, and decodes a payload back to features at any normalised times ``t`` in [0, 1]
(frame ``i`` of ``F`` is at ``t = i / (F - 1)``; a one-frame clip is at ``t = 0``).

Codecs never measure their own error or compression ratio: the :class:`EncodeContext` they are given asks the
shared evaluator (FK-based L-infinity over all joints and end sites, ``motionrep.pipeline.evaluate``) for the error of
candidate features or payloads, and the core measures the final payload again, decoded from the bytes written.

Plugins subclass :class:`Codec` and register an instance through the ``register_codecs`` hook.

Size: one concern, the codec interface; the helpers its methods call (parameters, outcome and payload checks,
descriptions) stay beside it, as they are each method's documented default or tool.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Mapping, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ParameterError, PayloadError

__all__ = ["Codec", "Payload", "EncodeContext", "CompiledDecoder", "frame_times", "parse_params", "params_help",
           "describe_info", "describe_progress", "codec_problems", "check_info_numbers", "check_decode_work",
           "check_frames"]


@dataclass(frozen=True)
class Payload:
    """What a codec stores: named arrays plus a few facts about the outcome.

    Attributes:
        arrays: the stored arrays (dtype is the codec's choice, e.g. float32 or float16).  The number of stored
            parameters is the total number of array elements; it is what the paper's compression ratio divides by.
        info: small JSON-serialisable facts about the outcome, shown to users and kept in the container
            (``{"K": 4, "omega": [3, 7, 1, 12]}`` or ``{"rank": 9}``); never needed to decode.
        version: the payload format version it was written with (a file's ``codec_version``), or None for a
            payload the codec has just encoded (its ``format_version``).  A codec whose decoding changed between
            versions decodes each version as it was when files of it were written and measured
            (:meth:`Codec.payload_version`).
    """

    arrays: Mapping[str, NDArray[Any]]
    info: Mapping[str, Any] = field(default_factory=dict)
    version: int | None = None

    @property
    def num_parameters(self) -> int:
        """Total number of stored numbers (every array element)."""
        return int(sum(int(np.asarray(a).size) for a in self.arrays.values()))

    @property
    def nbytes(self) -> int:
        """Bytes of array data (without container overhead)."""
        return int(sum(int(np.asarray(a).nbytes) for a in self.arrays.values()))


class EncodeContext(Protocol):
    """What the core gives a codec's ``encode``.

    Attributes:
        params: the codec's validated ``Params`` instance.
        bound: the L-infinity joint-position error to meet, in file units, or ``None`` when no bound applies (a
            fixed-size encoding, e.g. ``rank`` or ``k`` given for a sweep).  ``motionrep.pipeline.compress`` passes the
            requested bound times ``1 - BOUND_MARGIN`` (1e-6) and enforces the requested bound itself.
        seed: random seed; the same input and seed must give the same payload, byte for byte.
        times: ``(F,)`` normalised times of the frames (see :func:`frame_times`).
    """

    params: Any
    bound: float | None
    seed: int
    times: NDArray[np.float64]

    def evaluate(self, features: ArrayLike) -> "ErrorReportLike":
        """L-infinity error (and where it is) of candidate ``(F, D)`` features, decoded through the
        representation and FK and compared with the reference motion."""

    def evaluate_payload(self, payload: Payload) -> "ErrorReportLike":
        """The same for a candidate payload, decoded with the codec at the frame times: use it so that what is
        evaluated is what would be stored (after float32 / float16 rounding)."""

    def evaluate_frames(self, features: ArrayLike, first: int) -> "ErrorReportLike":
        """The same for candidate ``(n, D)`` features of the frames ``first .. first + n - 1`` only (a codec
        that codes a clip in pieces); frames are measured independently, so this is the error those frames
        would have in the whole clip."""

    def progress(self, stage: str, **fields: Any) -> None:
        """Report progress (``stage`` like ``"train"``; fields like ``K=3, loss=..., error=...``); with
        ``diagnostic=True`` the report is the codec's internal detail, which the command line shows only with
        ``--verbose``."""


class ErrorReportLike(Protocol):
    max_error: float
    max_error_percent: float


class Codec(ABC):
    """A motion compressor.

    Class attributes:
        name: unique name on the command line and in ``.mrc`` files (``"adaptive-fourier"``).
        format_version: integer >= 1 written into every payload; bump it whenever the payload layout or its
            meaning changes, and never reuse a number.  ``decode`` must keep reading every version listed in
            ``readable_versions``.
        readable_versions: payload versions ``decode`` accepts (default: only ``format_version``).
        description: one line for ``motionrep plugins``.
        min_frames: the fewest frames of a clip the codec can code (default 1); the core refuses a shorter clip
            before any work, with one line naming the codecs that can code it.
        Params: a frozen dataclass of the codec's parameters with documented defaults (each field's
            ``metadata["help"]``); its ``__post_init__`` raises :class:`~motionrep.errors.ParameterError`
            for invalid values, before any work is done.
    """

    name: ClassVar[str]
    format_version: ClassVar[int]
    readable_versions: ClassVar[tuple[int, ...]] = ()
    description: ClassVar[str] = ""
    min_frames: ClassVar[int] = 1
    Params: ClassVar[type]

    @abstractmethod
    def encode(self, features: NDArray[np.float64], weights: NDArray[np.float64],
               context: EncodeContext) -> Payload:
        """Compress ``(F, D)`` features with per-feature weights ``(D,)``.

        Must meet ``context.bound`` when it is not None, measured with ``context.evaluate_payload``, or raise
        :class:`~motionrep.errors.BoundNotMetError` with the best error reached.
        """

    @abstractmethod
    def decode(self, payload: Payload, times: ArrayLike) -> NDArray[np.float64]:
        """Features ``(T, D)`` float64 at normalised ``times`` ``(T,)`` in [0, 1].  Must not import torch."""

    def decoder(self, payload: Payload) -> Callable[..., NDArray[np.floating]]:
        """``payload`` prepared for decoding many times (arrays checked and converted once).

        Returns a callable ``decoder(times, out=None)`` giving ``(T, D)`` features at normalised ``times``,
        float32 or float64 (the codec's working precision), equal value for value to ``decode(payload, times)``
        and written into ``out`` (an array of that shape and dtype) when given.  The default wraps
        :meth:`decode`; a codec whose decoding has set-up work overrides this and implements ``decode`` with it
        (one path).

        **Compiled decoders.**  The runtime decoder (``motionrep.open``) decodes block after block of poses; a
        decoder that also has the attributes ``width`` (``D``), ``kernel`` (a C function, or one compiled with
        ``motionrep.jit.jit``) and ``kernel_args`` (a tuple) is called as ``kernel(times, out, *kernel_args)``
        instead, with ``times`` ``(m,)`` float64 normalised times (clamped to [0, 1]) and ``out`` a
        C-contiguous ``(D, >= m)`` float64 array to write **feature-major** (feature ``d`` of time ``i`` at
        ``out[d, i]``: the layout in which a codec computes a block, and in which the representations' compiled
        conversions read it, ``motionrep.model.poseplan``).  It must write the values ``__call__`` gives, and keep no
        state between calls; subclassing :class:`CompiledDecoder` gives the plain call from the kernel.  A decoder
        whose kernel is C may also offer ``sampler``: a capsule of the same kernel for C callers
        (``motionrep/_c/include/motionrep/sampler.h``), which ``motionrep.open`` then calls block by block without
        Python between the codec and the pose plan.  The shipped codecs' decoders do.
        """
        return _DecodeCall(self, payload)

    def payload_version(self, payload: Payload) -> int:
        """The format version of ``payload``: its ``version``, or :attr:`format_version` for a payload that has
        none (one the codec has just encoded)."""
        return self.format_version if payload.version is None else int(payload.version)

    def parse_params(self, raw: Mapping[str, Any]) -> Any:
        """Validated ``Params`` from ``raw`` (values may be strings from the command line)."""
        return parse_params(self.Params, raw, self.name)

    def describe(self, info: Mapping[str, Any], detail: bool = False) -> str:
        """One line describing an outcome (a payload's ``info``) to people: ``K=5``, ``rank=9``.

        Every command shows an outcome through this method: the short form (``detail=False``) in tables and
        lists (``bench``, ``compress`` of many clips, ``info`` of an archive), the detailed form where one clip is
        shown (``compress`` of one clip, ``info``), which may add what is too long for a table row (every
        frequency, a value per window).  Default: :func:`describe_info`.
        """
        return describe_info(info, detail)

    def check_info(self, info: Mapping[str, Any]) -> None:
        """Refuse an outcome this codec never writes, read from a file (``.mrc``, an archive's clip).

        A file's ``codec.info`` is untrusted: the core has checked only that it is a JSON object of plain values
        nested at most 32 levels, within the metadata size limit, because its keys are each codec's vocabulary.
        The core calls this method of the installed codec named in the file before the file's contents are used,
        and turns the error into a one-line :class:`~motionrep.errors.ContainerError` naming the file.  Accept
        every outcome any of :attr:`readable_versions` wrote; keys the codec does not know are not its concern.
        :func:`check_info_numbers` checks one key.  Default: accepts any outcome (the description falls back to
        :func:`describe_info` when :meth:`describe` fails on a crafted value).

        Raises:
            PayloadError: naming the key and what it must be.
        """

    def check_payload(self, payload: Payload, num_frames: int) -> None:
        """Refuse a payload, read from a file, whose declared sizes disagree with the clip or the limits, before
        anything is decoded or allocated for it.

        The core calls this (``motionrep.pipeline.runtime.Clip``, the one decode path) with the clip's frame count from the
        container's metadata before :meth:`decoder`.  A codec whose payload states a frame count (or window
        edges, segments...) checks it against ``num_frames``, naming both numbers; one whose decoding costs more
        than the payload's size suggests (frames x network size) checks the declared work with
        :func:`check_decode_work`.  Read only headers here: this must cost little more than the payload's size.
        Default: accepts every payload.

        Raises:
            PayloadError: ``payload declares 450 frames, the clip has 900``.
        """

    def describe_progress(self, stage: str, fields: Mapping[str, Any]) -> str:
        """One line for a progress report ``context.progress(stage, **fields)``.  Default:
        :func:`describe_progress`."""
        return describe_progress(stage, fields)

    def warm_up(self) -> None:
        """Pay one-time costs (imports, caches) now: called before encodes are timed (``motionrep bench``) and
        once in each worker process of a batch, before its first clip.  Default: nothing."""

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r} v{self.format_version}>"


def codec_problems(codec: Any, *, complete: bool = False) -> list[str]:
    """What is wrong with ``codec`` as a plugin object, one phrase each (empty: nothing).

    Checked when a codec is registered (:mod:`motionrep.plugin.registry`, which raises ``PluginError``): an instance of
    :class:`Codec`; a non-empty ``name`` without surrounding spaces; an integer ``format_version`` >= 1 that
    ``readable_versions`` includes; an integer ``min_frames`` >= 1; a ``Params`` dataclass.  With ``complete``
    (the conformance suite, :func:`motionrep.testing.check_codec`), also: every parameter has a default and a
    help text.
    """
    if not isinstance(codec, Codec):
        return ["is not a motionrep.plugin.codec.Codec"]
    out = []
    name = getattr(codec, "name", None)
    if not isinstance(name, str) or not name or name != name.strip():
        out.append("name must be a non-empty string without surrounding spaces")
    fv = getattr(codec, "format_version", None)
    if isinstance(fv, bool) or not isinstance(fv, int) or fv < 1:
        out.append(f"format_version must be an integer >= 1, got {fv!r}")
    elif codec.readable_versions and fv not in codec.readable_versions:
        out.append(f"readable_versions {tuple(codec.readable_versions)} must include format_version {fv}")
    mf = getattr(codec, "min_frames", 1)
    if isinstance(mf, bool) or not isinstance(mf, int) or mf < 1:
        out.append(f"min_frames must be an integer >= 1, got {mf!r}")
    params = getattr(codec, "Params", None)
    if not (isinstance(params, type) and dataclasses.is_dataclass(params)):
        out.append("Params must be a dataclass")
    elif complete:
        for f in dataclasses.fields(params):
            if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                out.append(f"parameter {f.name!r} has no default")
            if not f.metadata.get("help"):
                out.append(f"parameter {f.name!r} has no help text (field metadata['help'])")
    return out


def _numbers_at(value: Any, level: int, integers: bool) -> bool:
    """``value`` is a number (an integer with ``integers``) inside exactly ``level`` levels of arrays."""
    if level:
        return isinstance(value, list) and all(_numbers_at(v, level - 1, integers) for v in value)
    if isinstance(value, bool):
        return False
    return isinstance(value, int) or (not integers and isinstance(value, float) and math.isfinite(value))


def check_info_numbers(info: Mapping[str, Any], key: str, *, integers: bool = False,
                       arrays: tuple[int, int] = (0, 0)) -> None:
    """Check ``info[key]``, when present, for :meth:`Codec.check_info`: a finite number (an integer, never a
    boolean, with ``integers``) inside between ``arrays[0]`` and ``arrays[1]`` levels of arrays, e.g. ``(0, 1)``
    for ``5`` or ``[4, 6]``, ``(1, 2)`` for ``[1.5, 3]`` or ``[[1.5], [2, 3]]``.

    Raises:
        PayloadError: ``'omega' must be an array of numbers or an array of arrays of numbers``.
    """
    if key not in info:
        return
    least, most = arrays
    if any(_numbers_at(info[key], level, integers) for level in range(least, most + 1)):
        return
    what = "integers" if integers else "numbers"
    one = "an integer" if integers else "a number"
    shapes = [f"an array of {'arrays of ' * (level - 1)}{what}" if level else one for level in range(least, most + 1)]
    raise PayloadError(f"{key!r} must be {' or '.join(shapes)}")


def check_frames(declared: int, num_frames: int, what: str = "payload") -> None:
    """For :meth:`Codec.check_payload`: the frame count a payload declares must be the clip's.

    Raises:
        PayloadError: ``payload declares 450 frames, the clip (metadata num_frames) has 900``.
    """
    if int(declared) != int(num_frames):
        raise PayloadError(f"{what} declares {int(declared)} frames, the clip (metadata num_frames) has "
                           f"{int(num_frames)}")


def check_decode_work(work: int, payload: Payload, what: str) -> None:
    """For :meth:`Codec.check_payload`: ``work`` units of decode work (one multiply-add of a network at one frame,
    ``what`` saying what declared it) within ``max_decode_work`` per byte of ``payload``
    (:func:`motionrep.limits.check_decode_work`, ``specs/limits.md``).

    Raises:
        PayloadError: naming the work, the limit and its environment variable.
    """
    from ..limits import check_decode_work as check

    reason = check(work, payload.nbytes, what)
    if reason:
        raise PayloadError(reason)


def _number(v: Any) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def describe_info(info: Mapping[str, Any], detail: bool = False) -> str:
    """The generic description of a codec's outcome: ``key=value`` for every number and string; lists and
    mappings only with ``detail`` (lists as ``key=[a, b, c]``).  ``"-"`` when there is nothing to show."""
    parts = []
    for key, value in info.items():
        if isinstance(value, (list, tuple)):
            if detail:
                parts.append(f"{key}=[{', '.join(_number(v) for v in value)}]")
        elif isinstance(value, Mapping):
            if detail:
                parts.append(f"{key}={dict(value)}")
        elif not isinstance(value, bool):
            parts.append(f"{key}={_number(value)}")
    return ", ".join(parts) or "-"


def describe_progress(stage: str, fields: Mapping[str, Any]) -> str:
    """The generic progress line: the stage, then ``key=value`` per field (lists left out); ``loss`` in
    scientific notation, ``error`` (with ``error_percent``) as ``L-inf=0.52 (1.97%)``; ``done`` (the share, 0-1,
    of the most work the encode can take, see ``specs/plugins.md``) as ``23%``; ``diagnostic`` (the report is an
    internal diagnostic, shown only with ``--verbose``) left out."""
    parts = [stage]
    for key, value in fields.items():
        if key == "diagnostic":
            continue
        if key == "done" and isinstance(value, (int, float)):
            parts.append(f"{100 * value:.0f}%")
            continue
        if key == "error_percent" or isinstance(value, (list, tuple, Mapping)):
            continue
        if key == "error" and isinstance(value, (int, float)):
            pct = fields.get("error_percent")
            parts.append(f"L-inf={value:.4g}" + (f" ({pct:.2f}%)" if isinstance(pct, (int, float)) else ""))
        elif key == "loss" and isinstance(value, float):
            parts.append(f"loss={value:.3e}")
        elif isinstance(value, float):
            parts.append(f"{key}={value:.4g}")
        else:
            parts.append(f"{key}={value}")
    return " ".join(parts)


class CompiledDecoder:
    """Base of a prepared decoder with a compiled kernel (see :meth:`Codec.decoder`): a subclass sets, in its
    ``__init__``, ``width`` (features per time ``D``), ``dtype`` (its arithmetic, float32 or float64), ``kernel``
    (a C function, or one compiled with ``motionrep.jit.jit``) and ``kernel_args`` (a tuple), and optionally
    ``sampler`` (the same kernel for C callers), and this class gives the ``decoder(times, out=None)`` call from
    them, so the runtime decoder's blocks and a plain call run one kernel.
    """

    width: int
    dtype: np.dtype
    kernel: Any
    kernel_args: tuple

    def __call__(self, times: ArrayLike, out: NDArray[np.floating] | None = None) -> NDArray[np.floating]:
        """``(T, D)`` features at normalised ``times`` ``(T,)`` in :attr:`dtype` (into ``out`` when given)."""
        t = np.ascontiguousarray(times, dtype=np.float64).reshape(-1)
        features = np.empty((self.width, t.size))
        kernel = self.kernel
        getattr(kernel, "dispatcher", kernel)(t, features, *self.kernel_args)  # a numba kernel: its dispatcher
        if out is None:
            return features.T.astype(self.dtype)
        out[...] = features.T
        return out


class _DecodeCall:
    """The default :meth:`Codec.decoder`: ``decode`` on every call."""

    def __init__(self, codec: Codec, payload: Payload):
        self._codec, self._payload = codec, payload

    def __call__(self, times: ArrayLike, out: NDArray[np.floating] | None = None) -> NDArray[np.floating]:
        features = self._codec.decode(self._payload, times)
        if out is None:
            return features
        out[...] = features
        return out


def frame_times(num_frames: int) -> NDArray[np.float64]:
    """``(F,)`` normalised times of ``num_frames`` frames: ``i / (F - 1)``, or ``[0.0]`` for one frame."""
    if num_frames < 1:
        raise ParameterError(f"num_frames must be >= 1, got {num_frames}")
    if num_frames == 1:
        return np.zeros(1)
    return np.arange(num_frames) / (num_frames - 1)


def _convert(value: Any, annotation: Any, key: str, codec: str) -> Any:
    """Convert a (possibly string) value to the annotated type."""
    if isinstance(annotation, str):
        annotation = {"int": int, "float": float, "str": str, "bool": bool}.get(annotation.split("|")[0].strip(),
                                                                                annotation)
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        if value is None or (isinstance(value, str) and value.lower() in ("none", "")):
            return None
        annotation = args[0]
    if origin is typing.Literal:
        allowed = typing.get_args(annotation)
        if value not in allowed:
            raise ParameterError(f"{codec}: parameter {key} must be one of {', '.join(map(str, allowed))}, "
                                 f"got {value!r}")
        return value
    try:
        if annotation is bool:
            if isinstance(value, str):
                low = value.lower()
                if low in ("1", "true", "yes", "on"):
                    return True
                if low in ("0", "false", "no", "off"):
                    return False
                raise ValueError(value)
            return bool(value)
        if annotation is int:
            if isinstance(value, float) and not value.is_integer():
                raise ValueError(value)
            return int(value)
        if annotation is float:
            return float(value)
        if annotation is str:
            return str(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{codec}: parameter {key} must be {annotation.__name__}, got {value!r}") from None
    return value


def parse_params(params_cls: type, raw: Mapping[str, Any], codec: str) -> Any:
    """Build and validate a ``Params`` dataclass from ``raw``.

    Raises:
        ParameterError: for an unknown key (listing the known ones), a value of the wrong type, or a value the
            dataclass's ``__post_init__`` rejects.
    """
    fields = {f.name: f for f in dataclasses.fields(params_cls)}
    unknown = sorted(set(raw) - set(fields))
    if unknown:
        known = ", ".join(fields) or "(none)"
        raise ParameterError(f"{codec}: unknown parameter {unknown[0]!r}; known parameters: {known}")
    hints = typing.get_type_hints(params_cls)
    kwargs = {k: _convert(v, hints.get(k, fields[k].type), k, codec) for k, v in raw.items()}
    try:
        return params_cls(**kwargs)
    except ParameterError:
        raise
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{codec}: {exc}") from None


def params_help(params_cls: type) -> list[dict[str, Any]]:
    """``[{name, type, default, help}]`` for each parameter, for ``motionrep plugins`` and documentation."""
    out = []
    hints = typing.get_type_hints(params_cls)
    for f in dataclasses.fields(params_cls):
        default = f.default if f.default is not dataclasses.MISSING else None
        t = hints.get(f.name, f.type)
        if typing.get_origin(t) is typing.Literal:
            shown = " | ".join(str(a) for a in typing.get_args(t))
        else:
            shown = getattr(t, "__name__", str(t))
        out.append({"name": f.name, "type": shown, "default": default,
                    "help": f.metadata.get("help", "")})
    return out
