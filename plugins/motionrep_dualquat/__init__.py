"""Shipped plugin: the ``dual-quaternion`` pose representation of Andreou et al. (2022), sections 3-5.

Besides the representation, this package exposes the dual-quaternion algebra it is built on (numpy,
vectorised over any leading dimensions; ``(..., 8)`` arrays ``[real xyzw, dual xyzw]``) and the diagnostic
:func:`dual_part_offset_error`.  See ``specs/representations.md``.
"""

from __future__ import annotations

from motionrep import __version__
from motionrep.plugin.hookspecs import hookimpl

from ._algebra import (dualquat_conjugate, dualquat_from_rotation_translation, dualquat_make_continuous,
                       dualquat_multiply, dualquat_normalize, dualquat_to_rotation_translation)
from ._rep import DualQuaternion, OffsetError, dual_part_offset_error, dual_part_offsets

__all__ = [
    "DualQuaternion",
    "OffsetError",
    "dual_part_offsets",
    "dual_part_offset_error",
    "dualquat_multiply",
    "dualquat_conjugate",
    "dualquat_normalize",
    "dualquat_from_rotation_translation",
    "dualquat_to_rotation_translation",
    "dualquat_make_continuous",
    "register_representations",
    "__version__",
]


@hookimpl
def register_representations(register):
    """Register :class:`DualQuaternion`."""
    register(DualQuaternion())
