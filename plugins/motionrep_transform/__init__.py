"""Shipped plugin: the ``transform`` codec, error-bounded wavelet coding with a range coder.

See ``specs/codecs.md`` for the payload layout and parameters.
"""

from __future__ import annotations

from motionrep import __version__
from motionrep.plugin.hookspecs import hookimpl

from ._codec import TransformCodec, TransformParams
from ._decoder import TransformDecoder, interpolate_rows

__all__ = ["TransformCodec", "TransformParams", "TransformDecoder", "interpolate_rows", "register_codecs",
           "__version__"]


@hookimpl
def register_codecs(register):
    """Register :class:`TransformCodec`."""
    register(TransformCodec())
