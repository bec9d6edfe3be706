"""motionrep-keyframe: an example third-party motionrep plugin.

Declared in ``pyproject.toml`` under ``[project.entry-points.motionrep]``; motionrep imports this module and
calls the two hooks below, exactly as it does for its shipped plugins.
"""

from __future__ import annotations

from motionrep.plugin.hookspecs import hookimpl

from ._codec import KeyframeCodec, KeyframeParams
from ._representation import LocalQuaternion

__version__ = "0.1.0"

__all__ = ["LocalQuaternion", "KeyframeCodec", "KeyframeParams", "register_representations", "register_codecs",
           "__version__"]


@hookimpl
def register_representations(register):
    """Register the ``local-quaternion`` representation."""
    register(LocalQuaternion())


@hookimpl
def register_codecs(register):
    """Register the ``keyframe`` codec."""
    register(KeyframeCodec())
