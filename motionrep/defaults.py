"""The library's defaults, in one home that the command line imports without numpy (standard library only).

Every default a user can meet through more than one door (a Python call and a command-line option) is written
here once; :mod:`motionrep.pipeline.compress`, the dataset, the conformance suite and the commands' options all
read it from here.
"""

from __future__ import annotations

__all__ = ["DEFAULT_CODEC", "DEFAULT_REPRESENTATION", "DEFAULT_MAX_ERROR", "CLASH_POLICIES", "DEFAULT_ON_CLASH"]

#: Codec used when none is named.
DEFAULT_CODEC = "transform"
#: Representation used when none is named (Tojo et al. 2022, section 3).
DEFAULT_REPRESENTATION = "root-quat-axis-angle"
#: The default bound: 2 % of the character height.
DEFAULT_MAX_ERROR = "2%"
#: How a merge resolves clips of one name in two inputs (:mod:`motionrep.batch.merge`): refuse, keep the first
#: or the last input's, or keep both under prefixed names; identical bytes never clash.
CLASH_POLICIES = ("error", "first", "last", "prefix")
#: The default of those.
DEFAULT_ON_CLASH = "error"
