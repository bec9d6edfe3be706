"""Writes ``plugins/motionrep_transform/_c/mrprior3.h``: the start states of payload version 3's fixed-context
counters (specs/codecs.md, "Payload version 3"), trained on clips that are not the CMU clips of the issue's
targets (those are held out: ``benchmarks/results/rate5.md``).

    python benchmarks/prior3.py [DIR]      # default: $MOTIONREP_SHARED_DATA/other (../shared/data/other)

Every ``*.bvh`` under DIR (sorted), each encoded by ``transform`` at 2 %, 0.588 % and 0.0588 % (the bounds of
``acl.py``); the integers of each payload coded by version 2's models (``_ccoder.states``: no trained start), and
the final state of each fixed-context counter kept: its probability in stretch units (1/256 of a natural-log odds,
mrcoder.c's table) and its update count n (capped at 63). A counter's start state is the n-weighted mean of its
stretches over the clips, rounded to the nearest integer (integer arithmetic: the same table on every machine);
a counter no clip updated keeps version 2's start (``MRC_PRIOR3_NONE``). Every trained counter starts with
``MRC_PRIOR3_COUNT`` = 16 updates seen (the rate it adapts at; 16 measured best of 1, 2, 4, 8, 16 on these clips).

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
    seen = weight > 0
    start = np.full(total.size, -32768, np.int64)
    start[seen] = (2 * total[seen] + weight[seen]) // (2 * weight[seen])  # nearest, halves up
    rows = [", ".join(str(int(v)) for v in start[i:i + 16]) for i in range(0, start.size, 16)]
    HEADER.write_text(
        "/* Start states of payload version 3's fixed-context counters (mrcoder.c, models_prior; specs/codecs.md,\n"
        " * \"Payload version 3\"), in the order of mrcoder.c's fixed_spans: P(1) in stretch units, MRC_PRIOR3_NONE for\n"
        f" * a counter that keeps version 2's start. Written by benchmarks/prior3.py from {len(paths)} clips x "
        f"{len(BOUNDS)} bounds\n"
        " * (../shared/data/other); part of the format: never edit, a new table is a new payload version. */\n"
        "#ifndef MRPRIOR3_H\n#define MRPRIOR3_H\n\n#include <stdint.h>\n\n"
        f"#define MRC_PRIOR3_SIZE {start.size}\n#define MRC_PRIOR3_NONE (-32768)\n#define MRC_PRIOR3_COUNT {COUNT}\n\n"
        "static const int16_t MRC_PRIOR3_STRETCH[MRC_PRIOR3_SIZE] = {\n"
        + "".join(f"    {r},\n" for r in rows) + "};\n\n#endif\n")
    print(f"prior3: {int(seen.sum())} of {start.size} counters trained -> {HEADER}")


if __name__ == "__main__":
    main()
