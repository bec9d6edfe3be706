"""A deterministic train / validation / test split of clips by name (``specs/dataset.md``, "Split").

Each clip gets a key, the SHA-256 of ``"<seed>:<group>"`` (the group is the clip's name unless ``group`` says
otherwise); groups are ordered by key, and the first ``round(n * train)`` groups go to the training part, the
next ``round(n * val)`` to validation, the rest to test.  The split therefore depends only on the names and the
seed -- not on the order in which the clips are listed, the machine, Python's hash seed or numpy's generator --
and every clip of one group (for example both dancers of a couple's trial) lands in the same part.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable, Iterable

from ..errors import ValidationError

__all__ = ["split_clips", "SPLIT_PARTS"]

#: The parts :func:`split_clips` returns, in order.
SPLIT_PARTS = ("train", "val", "test")


def _key(seed: int, group: str) -> bytes:
    return hashlib.sha256(f"{seed}:{group}".encode("utf-8")).digest()


def split_clips(names: Iterable[str], fractions: tuple[float, float, float] = (0.8, 0.1, 0.1), seed: int = 0,
                group: Callable[[str], str] | None = None) -> dict[str, list[str]]:
    """Split clip ``names`` into ``{"train": [...], "val": [...], "test": [...]}``, deterministically.

    Args:
        names: the clips' names (unique), e.g. ``MotionDataset.clip_names`` or ``motionrep.io.list_clips(db)``.
        fractions: shares of train, validation and test (non-negative, summing to 1); counted in groups.
        seed: any integer; another seed gives another split.
        group: maps a clip name to a group name; the clips of one group stay together (default: each clip is
            its own group).

    Returns:
        The three lists, each in the order of ``names``.  With at least three groups, every part whose fraction
        is above zero gets at least one group.

    Raises:
        ValidationError: for fractions that are negative or do not sum to 1, a name given twice, or no names.
    """
    names = list(names)
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise ValidationError(f"clip name {dup!r} is given twice")
    if not names:
        raise ValidationError("split_clips needs at least one clip name")
    fr = [float(f) for f in fractions]
    if len(fr) != 3 or any(not math.isfinite(f) or f < 0 for f in fr) or abs(sum(fr) - 1.0) > 1e-9:
        raise ValidationError(f"fractions must be three non-negative numbers summing to 1, got {tuple(fractions)}")
    of = {n: (group(n) if group is not None else n) for n in names}
    groups = sorted(set(of.values()), key=lambda g: _key(int(seed), g))
    n = len(groups)
    counts = [int(math.floor(n * f + 0.5)) for f in fr[:2]]
    if n >= 3:  # a part asked for gets at least one group; taken from the largest part
        for i in range(2):
            if fr[i] > 0 and counts[i] == 0:
                counts[i] = 1
        if fr[2] > 0 and n - sum(counts) <= 0:
            counts[counts.index(max(counts))] -= 1
    counts[1] = min(counts[1], n - counts[0])
    part = {}
    for i, g in enumerate(groups):
        part[g] = 0 if i < counts[0] else (1 if i < counts[0] + counts[1] else 2)
    out: dict[str, list[str]] = {p: [] for p in SPLIT_PARTS}
    for name in names:
        out[SPLIT_PARTS[part[of[name]]]].append(name)
    return out
