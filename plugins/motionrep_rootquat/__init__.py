"""Shipped plugin: the ``root-quat-axis-angle`` pose representation of Tojo et al. (2022), section 3.

See ``specs/representations.md`` for the column layout, units and weights.
"""

from __future__ import annotations

from motionrep import __version__
from motionrep.plugin.hookspecs import hookimpl

from ._rep import RootQuatAxisAngle

__all__ = ["RootQuatAxisAngle", "register_representations", "__version__"]


@hookimpl
def register_representations(register):
    """Register :class:`RootQuatAxisAngle`."""
    register(RootQuatAxisAngle())
