"""Writes ``plugins/motionrep_transform/_c/mrprior3.h``: the start states of payload version 3's fixed-context
counters (specs/codecs.md, "Payload version 3"), trained on clips that are not the CMU clips of the issue's
targets (those are held out: ``benchmarks/results/rate5.md``).

    python benchmarks/prior3.py [DIR]      # default: $MOTIONREP_SHARED_DATA/other (../shared/data/other)

Every ``*.bvh`` under DIR (sorted), each encoded by ``transform`` at 2 %, 0.588 % and 0.0588 % (the bounds of
``acl.py``); the integers of each payload coded by version 2's models (``_ccoder.states``: no trained start), and
the final state of each fixed-context counter kept: its probability in stretch units (1/256 of a natural-log odds,
mrcoder.c's table) and its update count n (capped at 63). A counter's start is the n-weighted mean ``s`` of its
stretches over the clips, rounded to the nearest integer, as ``P(1) = 16 squash(s)`` in 1/65536 (mrcoder.c's
squash, :func:`squash` here, clamped to ``[16, 65520]``) with ``COUNT`` = 16 updates seen (the rate it adapts at;
16 measured best of 1, 2, 4, 8, 16 on these clips); a counter no clip updated keeps version 2's start (``P(1) =
32768``, 0 updates). Integer arithmetic throughout: the same table on every machine.

The table depends on the encoder's integers (its rate search); it is part of the format once files are written
with it: a new table is a new payload version.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

BOUNDS = (2.0, 0.588, 0.0588)
COUNT = 16
#: mrcoder.c's SQUASH_T: PAQ's squash at 33 points of the stretch domain
SQUASH_T = (1, 2, 3, 6, 10, 16, 27, 45, 73, 120, 194, 310, 488, 747, 1101, 1546, 2047, 2549, 2994, 3348, 3607, 3785,
            3901, 3975, 4022, 4050, 4068, 4079, 4085, 4089, 4092, 4093, 4094)


def squash(d: int) -> int:
    """mrcoder.c's squash: the 12-bit probability of stretch ``d`` (1/256 of a natural-log odds), by linear
    interpolation of :data:`SQUASH_T` in integers."""
    if d > 2047:
        return 4095
    if d < -2047:
        return 1
    u = d + 2048
    i, w = u >> 7, u & 127
    return (SQUASH_T[i] * (128 - w) + SQUASH_T[i + 1] * w + 64) >> 7
HEADER = Path(__file__).resolve().parents[1] / "plugins/motionrep_transform/_c/mrprior3.h"


def main() -> None:
    from motionrep.io import read
    from motionrep.pipeline.compress import compress_motion
    from motionrep_transform import _ccoder
    from motionrep_transform._decoder import unpack

    shared = Path(os.environ.get("MOTIONREP_SHARED_DATA", Path(__file__).resolve().parents[2] / "shared/data"))
    root = Path(sys.argv[1]) if len(sys.argv) > 1 else shared / "other"
    paths = sorted(root.rglob("*.bvh"))
    if not paths:
        raise SystemExit(f"prior3: no .bvh under {root}")
    total = weight = None
    for path in paths:
        motion = read(path)
        for bound in BOUNDS:
            result = compress_motion(motion, "transform", max_error=f"{bound:g}%")
            q = unpack(result.container.arrays["data"].tobytes(), result.container.codec_version)
            coef = np.ascontiguousarray(np.concatenate([np.asarray(c, np.int64) for c in q.coefficients], 0))
            raw = _ccoder.states(int(q.num_frames), int(q.num_features), int(q.region_frames),
                                 np.ascontiguousarray(q.feature_exponents, np.int64),
                                 np.ascontiguousarray(q.region_exponents, np.int64), coef)
            n_states = len(raw) // 4
            stretch = np.frombuffer(raw[:2 * n_states], np.int16).astype(np.int64)
            count = np.frombuffer(raw[2 * n_states:], np.uint16).astype(np.int64)
            if total is None:
                total, weight = np.zeros(n_states, np.int64), np.zeros(n_states, np.int64)
            total += stretch * count
            weight += count
            print(f"{path.relative_to(root)} {bound:g}%: {int(result.container.payload_bytes)} B", flush=True)
    states = []
    for t, w in zip(total.tolist(), weight.tolist()):
        if w == 0:
            states.append("{32768, 0}")
            continue
        p = 16 * squash((2 * t + w) // (2 * w))  # the mean stretch, nearest (halves up)
        states.append(f"{{{min(max(p, 16), 65520)}, {COUNT}}}")
    rows = [", ".join(states[i:i + 8]) for i in range(0, len(states), 8)]
    HEADER.write_text(
        "/* Start states of payload version 3's fixed-context counters (mrcoder.c, fixed_init; specs/codecs.md,\n"
        " * \"Payload version 3\"), in the order of mrcoder.c's fixed_spans: {P(1) in 1/65536, updates seen};\n"
        f" * {{32768, 0}} is version 2's start. Written by benchmarks/prior3.py from {len(paths)} clips x {len(BOUNDS)} bounds\n"
        " * (../shared/data/other); part of the format: never edit, a new table is a new payload version. */\n"
        "#ifndef MRPRIOR3_H\n#define MRPRIOR3_H\n\n#include <stdint.h>\n\n"
        f"#define MRC_PRIOR3_SIZE {len(states)}\n\n"
        "static const uint16_t MRC_PRIOR3[MRC_PRIOR3_SIZE][2] = {\n"
        + "".join(f"    {r},\n" for r in rows) + "};\n\n#endif\n")
    seen = weight > 0
    print(f"prior3: {int(seen.sum())} of {len(states)} counters trained -> {HEADER}")


if __name__ == "__main__":
    main()
