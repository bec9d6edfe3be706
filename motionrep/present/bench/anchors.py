"""ACL 2.1's strict-bound sizes, the anchor points ``motionrep bench --plot`` overlays where a run's clip is one
ACL was measured on (``motionrep/data/acl_strict.csv``: the figures, their source and how they were measured).

The sizes are payload bits per bone per frame at a bound in % of the character's height
(:data:`motionrep.pipeline.figures.PAYLOAD_BPBF`'s definition; bones = joints + end sites), so they sit on the plot's
axes beside the codecs' runs.  A clip is matched by its source path: the file ends with the anchor's clip path
(``cmu/bvh11/131_01`` matches ``.../data/cmu/bvh11/131_01.bvh``), never by a bare name.
"""

from __future__ import annotations

import csv
from functools import lru_cache
from importlib import resources
from pathlib import PurePath
from typing import Iterable, NamedTuple

__all__ = ["AclAnchor", "acl_strict", "acl_anchors_for"]


class AclAnchor(NamedTuple):
    """One ACL figure: ``clip`` (a path below the data root, no suffix), ``bound_percent``,
    ``payload_bits_per_bone_frame``."""

    clip: str
    bound_percent: float
    payload_bits_per_bone_frame: float


@lru_cache(maxsize=1)
def acl_strict() -> tuple[AclAnchor, ...]:
    """Every ACL 2.1 strict-bound figure the project has (comment lines of the CSV skipped)."""
    text = resources.files("motionrep").joinpath("data", "acl_strict.csv").read_text(encoding="utf-8")
    rows = csv.DictReader(line for line in text.splitlines() if not line.startswith("#"))
    return tuple(AclAnchor(r["clip"], float(r["bound_percent"]), float(r["acl_bits_per_bone_frame"])) for r in rows)


def acl_anchors_for(sources: Iterable[str], bounds_percent: Iterable[float] | None = None) -> list[AclAnchor]:
    """The ACL figures of the clips whose source files are ``sources`` (at ``bounds_percent`` only, when
    given), in the order of :func:`acl_strict`."""
    stems = {PurePath(s).with_suffix("").as_posix() for s in sources}
    wanted = None if bounds_percent is None else {round(float(b), 6) for b in bounds_percent}
    out = []
    for a in acl_strict():
        if wanted is not None and round(a.bound_percent, 6) not in wanted:
            continue
        if any(s == a.clip or s.endswith("/" + a.clip) for s in stems):
            out.append(a)
    return out
