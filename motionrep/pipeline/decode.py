"""The one way back from ``.mrc`` bytes: :func:`decode_at` (codec, then representation, then
:func:`~motionrep.model.ops.fixed_axes_restored`) at any normalised times, :func:`decompress` at the clip's own frame
times or resampled to another frame rate, and :func:`write_decoded`.

Below both the compression pipeline (:mod:`motionrep.pipeline.compress`, which decodes every payload it writes again from
its bytes, and re-exports these names) and the sources (:mod:`motionrep.pipeline.sources`, which decodes a ``.mrc`` clip
when it is read): neither imports the other to decode.
"""

from __future__ import annotations

import math
import os
from typing import Any

from numpy.typing import ArrayLike

from ..model._pose import Motion
from .._threads import one_blas_thread
from ..plugin.codec import Codec, frame_times
from ..io.container import Container, read_container, unpack
from ..model.ops import resample_times
from ..plugin.representation import Representation

__all__ = ["BVH_DECIMALS", "decode_at", "decompress", "decompress_file", "write_decoded"]

#: Decimals of BVH channel values written by :func:`write_decoded`: enough that text rounding (at most
#: 5e-10 units or degrees) cannot move a decoded motion measurably closer to or past its bound.
BVH_DECIMALS = 9


def decode_at(container: Container, times: ArrayLike, *, fps: float | None = None, path: Any = None,
              codec: Codec | None = None, representation: Representation | None = None) -> Motion:
    """The motion a container holds at normalised ``times`` ``(T,)`` in [0, 1] (the clip's first to last frame):
    the codec decodes features at those times, the representation turns them into poses, and translation axes
    without a position channel are restored (:func:`motionrep.model.ops.fixed_axes_restored`).  This is the one decode
    path: decompression, evaluation, rendering and benchmarks all decode through it, and it is the runtime
    decoder's (:meth:`motionrep.pipeline.runtime.Clip.motion_at`; ``motionrep.open`` samples poses with the same steps).

    Args:
        container: the compressed clip.
        times: ``(T,)`` normalised times.
        fps: frame rate of the result (default: the container's).
        path: the file it came from, named in errors.
        codec, representation: the plugins to decode with (default: looked up by the names and versions the
            container stores).

    Raises:
        UnknownPluginError: naming the codec or representation (and its plugin) when it is not installed.
        PluginVersionError: for a payload or representation version the installed plugin cannot read.
        ContainerError: for a payload the codec cannot decode.
    """
    from .runtime import Clip

    with one_blas_thread():  # the decoded values never depend on the thread count
        return Clip(container, path, codec=codec, representation=representation).motion_at(times, fps)


def decompress(data: bytes | Container, fps: float | None = None, *, path: Any = None, codec: Codec | None = None,
               representation: Representation | None = None) -> Motion:
    """Decode ``.mrc`` bytes (or a parsed container) to a motion at its own frame rate, or resampled to ``fps``
    (decoded at the new frame times, :func:`motionrep.model.ops.resample_times`).

    Raises:
        ContainerError: for bytes that are not a valid ``.mrc`` file; see also :func:`decode_at`.
    """
    container = data if isinstance(data, Container) else unpack(data, path)
    if fps is None or math.isclose(fps, container.fps, rel_tol=1e-12):
        times, fps = frame_times(container.num_frames), None
    else:
        times = resample_times(container.num_frames, container.fps, float(fps))
    return decode_at(container, times, fps=fps, path=path, codec=codec, representation=representation)


def decompress_file(source: str | os.PathLike[str], target: str | os.PathLike[str] | None = None,
                    fps: float | None = None) -> Motion:
    """Read a ``.mrc`` file, decode it (resampled to ``fps`` if given) and write ``target`` (any motion format).

    Raises:
        ContainerError: the file is not a valid ``.mrc`` file (truncated, altered, unknown version).
        UnknownPluginError: its codec or representation is not installed (naming the plugin that provides it).
    """
    motion = decompress(read_container(source), fps, path=source)
    if target is not None:
        write_decoded(motion, target)
    return motion


def write_decoded(motion: Motion, target: str | os.PathLike[str], **options: Any) -> None:
    """Write a decoded motion; BVH with :data:`BVH_DECIMALS` decimals, so the file keeps the decoded values;
    ``options`` are the format's write options (glTF ``scale``)."""
    from ..io import format_of, write

    if format_of(target) == "bvh":
        write(motion, target, decimals=BVH_DECIMALS, **options)
    else:
        write(motion, target, **options)
