"""The grid of a benchmark: codec x representation x bound (or a sweep of fixed parameters) x clip.

Sweeps (``-p k=1..12``, ``-p rank=1,2,4``): :func:`parse_sweep` expands ranges ``a..b`` (integers, inclusive)
and comma lists (which may mix both: ``1..4,8``).  A parameter applies to every codec whose ``Params`` has a
field of that name; the values of several swept parameters of one codec are combined (cartesian product).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from itertools import product
from typing import Any, Iterable, Mapping, Sequence

from ...errors import ParameterError
from ...pipeline.sources import ClipRef

__all__ = ["DEFAULT_DECODE_POSES", "BenchTask", "is_sweep", "parse_sweep", "codec_parameter_names", "bench_tasks"]

#: Poses decoded (at random times) to measure decode throughput.
DEFAULT_DECODE_POSES = 20_000


def is_sweep(value: str) -> bool:
    """True if a ``-p`` value is a range or a list (``1..12``, ``1,2,4``): a sweep, which turns the default bound
    off."""
    return ".." in value or "," in value


def _expand(key: str, text: str) -> list[str]:
    out: list[str] = []
    for part in text.split(","):
        part = part.strip()
        if not part:
            raise ParameterError(f"-p {key}={text}: empty item in the list")
        if ".." in part:
            a, _, b = part.partition("..")
            try:
                lo, hi = int(a), int(b)
            except ValueError:
                raise ParameterError(f"-p {key}={text}: a range is two integers a..b, got {part!r}") from None
            if hi < lo:
                raise ParameterError(f"-p {key}={text}: empty range {part!r} (the end is below the start)")
            if hi - lo >= 10_000:
                raise ParameterError(f"-p {key}={text}: range {part!r} has more than 10000 values")
            out.extend(str(v) for v in range(lo, hi + 1))
        else:
            out.append(part)
    return list(dict.fromkeys(out))


def parse_sweep(pairs: Iterable[str]) -> dict[str, list[str]]:
    """Parse ``-p KEY=VALUES`` options into ``{key: [value, ...]}`` (values as strings, in order, duplicates
    dropped).

    ``VALUES`` is one value (``4``, ``float16``), a range ``a..b`` of integers (both ends included), or a comma
    list whose items are values or ranges (``1..4,8,16``).

    Raises:
        ParameterError: for a pair without ``=``, an empty key, a key given twice, an empty or reversed range, or
            a range whose ends are not integers.
    """
    out: dict[str, list[str]] = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        key = key.strip()
        if not sep or not key:
            raise ParameterError(f"expected KEY=VALUE (or KEY=a..b, KEY=a,b,c), got {pair!r}")
        if key in out:
            raise ParameterError(f"parameter {key!r} given twice; give all its values in one -p {key}=a,b,...")
        out[key] = _expand(key, value.strip())
    return out


@dataclass(frozen=True)
class BenchTask:
    """One run of the grid: a clip, codec, representation, bound and fixed parameters.

    Attributes:
        index: position in the grid (rows are reported in this order).
        clip: the input clip.
        codec: codec name.
        representation: representation name.
        max_error: the requested bound as given (``"2%"``, ``"1.5"``), or None for none.
        params: codec parameters (strings, as from the command line), in the order given.
        seed: random seed of the codec.
        decode_poses: poses decoded to measure decode throughput (0: not measured).
        pipeline: the :class:`~motionrep.pipeline.compress.Pipeline` these settings resolve to (built by
            :func:`bench_tasks`, shared by the tasks of one setting); None: built when the task runs.
    """

    index: int
    clip: ClipRef
    codec: str
    representation: str
    max_error: str | None
    params: tuple[tuple[str, str], ...] = ()
    seed: int = 0
    decode_poses: int = DEFAULT_DECODE_POSES
    pipeline: Any = field(default=None, compare=False, repr=False)

    def resolved(self) -> Any:
        """The task's :class:`~motionrep.pipeline.compress.Pipeline` (``pipeline``, or built from the settings)."""
        from ...pipeline.compress import Pipeline

        if self.pipeline is not None:
            return self.pipeline
        return Pipeline.build(self.codec, self.representation, dict(self.params), self.max_error, self.seed)


def codec_parameter_names(codec: str) -> list[str]:
    """Names of the fields of ``codec``'s ``Params`` (what ``-p`` may set).

    Raises:
        UnknownPluginError: for an unknown codec.
    """
    from ...plugin.registry import get_codec

    return [f.name for f in dataclasses.fields(get_codec(codec).Params)]


def bench_tasks(clips: Sequence[ClipRef], codecs: Sequence[str], representations: Sequence[str],
                max_errors: Sequence[str | None], sweep: Mapping[str, Sequence[str]] | None = None, *,
                seed: int = 0, decode_poses: int = DEFAULT_DECODE_POSES) -> list[BenchTask]:
    """The grid, clip by clip, then representation, codec, parameter combination and bound.

    Each parameter of ``sweep`` applies to the codecs whose ``Params`` has a field of that name; a codec's
    combinations are the cartesian product of the values of the parameters that apply to it.  Every
    setting is resolved once, before any work, to the :class:`~motionrep.pipeline.compress.Pipeline` its tasks share
    (which validates the names, the parameters and the bound).

    Raises:
        UnknownPluginError: for an unknown codec or representation.
        ParameterError: for a parameter no codec has, an invalid value, or an invalid bound.
    """
    from ...pipeline.compress import Pipeline

    sweep = dict(sweep or {})
    if not codecs:
        raise ParameterError("no codec to run")
    used: set[str] = set()
    combos: dict[str, list[tuple[tuple[str, str], ...]]] = {}
    for codec in dict.fromkeys(codecs):
        names = [k for k in sweep if k in codec_parameter_names(codec)]
        used.update(names)
        combos[codec] = [tuple(zip(names, values)) for values in product(*(sweep[k] for k in names))]
    unused = [k for k in sweep if k not in used]
    if unused:
        known = sorted({f for c in combos for f in codec_parameter_names(c)})
        raise ParameterError(f"parameter {unused[0]!r} is not a parameter of codec(s) {', '.join(combos)}; their "
                             f"parameters: {', '.join(known)}")
    # each setting resolved once (the bound's text parsed there, by Pipeline.build); a bound keeps the text it was
    # given as its label, None for none
    pipelines: dict[tuple, Any] = {}
    for rep in dict.fromkeys(representations):
        for codec in combos:
            for combo in combos[codec]:
                for m in dict.fromkeys(max_errors):
                    pipeline = Pipeline.build(codec, rep, dict(combo), m, seed)
                    label = None if pipeline.max_error is None else str(m).strip()
                    pipelines.setdefault((rep, codec, combo, label), pipeline)
    settings = list(pipelines)
    tasks: list[BenchTask] = []
    for clip in clips:
        for key in settings:
            rep, codec, combo, bound = key
            tasks.append(BenchTask(len(tasks), clip, codec, rep, bound, combo, seed, decode_poses, pipelines[key]))
    return tasks
