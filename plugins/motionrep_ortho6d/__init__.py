"""Shipped plugin: the ``ortho6d`` pose representation (Zhou et al. 2019, as used by NeMF, He et al. 2022).

See ``specs/representations.md`` for the column layout, units and weights.
"""

from __future__ import annotations

from motionrep import __version__
from motionrep.plugin.hookspecs import hookimpl

from ._rep import Ortho6D

__all__ = ["Ortho6D", "register_representations", "__version__"]


@hookimpl
def register_representations(register):
    """Register :class:`Ortho6D`."""
    register(Ortho6D())
