"""Shipped plugin: the ``euler`` pose representation, the file's own Euler channels (for comparison).

See ``specs/representations.md`` for the column layout, units and weights.
"""

from __future__ import annotations

from motionrep import __version__
from motionrep.plugin.hookspecs import hookimpl

from ._rep import Euler

__all__ = ["Euler", "register_representations", "__version__"]


@hookimpl
def register_representations(register):
    """Register :class:`Euler`."""
    register(Euler())
