"""Shipped plugin: the ``svd`` codec, a rank-r truncated SVD of the feature matrix (Tojo et al. 2022, §4.1).

See ``specs/codecs.md`` for the payload layout and parameters.
"""

from __future__ import annotations

from motionrep import __version__
from motionrep.plugin.hookspecs import hookimpl

from ._codec import SVDCodec, SVDParams

__all__ = ["SVDCodec", "SVDParams", "register_codecs", "__version__"]


@hookimpl
def register_codecs(register):
    """Register :class:`SVDCodec`."""
    register(SVDCodec())
