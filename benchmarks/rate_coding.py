"""The transform payload's coding (issue 25): version 2 (the compiled adaptive coder) against version 1 (stored
static models, range coder) on the same quantised integers, and the time of each to decode them.

For every CMU clip of ../shared/data (``--clips cmu31``: the eight 31-joint clips; ``cmu``: all, with the salsa
clips) at each bound, one ``compress_motion`` with ``transform`` (the encoder's search chooses the integers; the
core checks the bound on the bytes written), then the integers of its payload are coded both ways: the row has
both sizes, their ratio and the best of ``--repeat`` decodes of each (the integers only; the inverse wavelet is
the same for both). Both decode to the same integers (checked).

Usage::

    python benchmarks/rate_coding.py [--clips cmu31|cmu] [--repeat 5] [--json results/rate_coding.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from acl import BOUNDS, DATA, RESULTS, cmu_clips  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    import numpy as np

    from motionrep.io import read
    from motionrep.pipeline.compress import compress_motion
    from motionrep_transform import _stream, _stream2

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--clips", default="cmu31", choices=("cmu31", "cmu"))
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--json", type=Path, default=RESULTS / "rate_coding.json")
    args = ap.parse_args(argv)

    def best(call) -> float:
        out = float("inf")
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            call()
            out = min(out, time.perf_counter() - t0)
        return out

    rows = []
    for path in cmu_clips(args.clips):
        motion = read(path)
        for bound in BOUNDS:
            result = compress_motion(motion, "transform", max_error=f"{bound:g}%")
            v2 = np.asarray(result.container.arrays["data"]).tobytes()
            q = _stream2.unpack(v2)
            v1 = _stream.pack(q)
            q1 = _stream.unpack(v1)
            if not all(np.array_equal(a, b) for a, b in zip(q.coefficients, q1.coefficients)):
                raise SystemExit(f"{path}: version 1 and 2 decode to different integers")
            row = {"clip": str(path.relative_to(DATA)).removesuffix(".bvh"), "bound_percent": bound,
                   "frames": motion.num_frames, "features": q.num_features, "v1_bytes": len(v1),
                   "v2_bytes": len(v2), "ratio": len(v2) / len(v1),
                   "v1_decode_seconds": best(lambda: _stream.unpack(v1)),
                   "v2_decode_seconds": best(lambda: _stream2.unpack(v2)), "load": os.getloadavg()[0]}
            rows.append(row)
            print(f"{row['clip']:40s} {bound:<7g} v1 {len(v1):7d} v2 {len(v2):7d} {row['ratio']:.3f}  decode "
                  f"v1 {1e3 * row['v1_decode_seconds']:.1f} ms v2 {1e3 * row['v2_decode_seconds']:.1f} ms", flush=True)
    for bound in BOUNDS:
        for group, keep in (("CMU without salsa", lambda c: "salsa" not in c), ("salsa", lambda c: "salsa" in c)):
            sel = [r for r in rows if r["bound_percent"] == bound and keep(r["clip"])]
            if sel:
                print(f"{bound:g} % {group}: v2 / v1 median {statistics.median(r['ratio'] for r in sel):.3f}, "
                      f"worst {max(r['ratio'] for r in sel):.3f} ({len(sel)} clips)")
    args.json.write_text(json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
