"""The feature-edits kernel (``motionrep/_c/edits.c``) alone, replayed: what one ``transform`` encode asks of it.

``capture CLIP BOUND OUT.pkl``
    encodes ``CLIP`` (a BVH file) with ``transform`` at ``BOUND`` (e.g. ``0.0588%``) and keeps every call the slack
    search makes to the kernel: the state it starts from and each batch of edits (columns, frames, deltas, bound,
    and the frames the search names to check first).

``replay OUT.pkl [SO ...] [--repeat N]``
    runs those calls again through each compiled core given (a ``_ccore*.so`` built from another ``edits.c``;
    none: this tree's), each in turn, and prints the CPU time of the calls (best of ``N``) and a hash of every
    decision and of the final state: two kernels that decide alike print the same hash. Run it under
    ``valgrind --tool=cachegrind`` for instruction counts that do not depend on the machine's load.

Results: ``results/rate6.md``.
"""

from __future__ import annotations

import argparse
import hashlib
import importlib.util
import pickle
import time

import numpy as np


def capture(clip: str, bound: str, out: str) -> None:
    from motionrep.io import read
    from motionrep.pipeline import edits
    from motionrep.pipeline.compress import compress_motion

    record: dict = {"calls": []}
    kernel = edits._edits

    def spy(layout, *rest):
        # rest: plan_i, plan_f, geom, state, edits, deltas, bound, commit, accepted[, leads]
        if rest[4] is None:  # the state set up from the features
            record["init"] = (np.array(layout), [np.array(a) if isinstance(a, np.ndarray) else a for a in rest])
            record["calls"] = []
        else:
            leads = rest[9] if len(rest) > 9 else None
            record["calls"].append((np.array(rest[4]), np.array(rest[5]), rest[6], rest[7],
                                    None if leads is None else np.array(leads)))
        return kernel(layout, *rest)

    edits._edits = spy
    try:
        compress_motion(read(clip), "transform", max_error=bound)
    finally:
        edits._edits = kernel
    with open(out, "wb") as f:
        pickle.dump(record, f)


def _kernel(path: str | None):
    if path is None:
        from motionrep._ccore import edits

        return edits
    spec = importlib.util.spec_from_file_location("motionrep._ccore", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.edits


def replay(record: str, sos: list[str], repeat: int) -> None:
    with open(record, "rb") as f:
        rec = pickle.load(f)
    layout, args = rec["init"]
    for so in sos or [None]:
        kernel = _kernel(so)
        best, digest = float("inf"), ""
        for _ in range(repeat):
            a = [x.copy() if isinstance(x, np.ndarray) else x for x in args]
            state = a[-6]
            kernel(layout, *a)
            h = hashlib.sha256()
            t0 = time.thread_time()
            for edits, deltas, bound, commit, *leads in rec["calls"]:  # leads (the frames to check first): since 2026-12
                accepted = np.zeros(edits.shape[0], np.uint8)
                lead = leads[0].copy() if leads and leads[0] is not None else None
                kernel(layout, *a[:-6], state, edits, deltas, bound, commit, accepted, *([] if lead is None else [lead]))
                h.update(accepted.tobytes())
            best = min(best, time.thread_time() - t0)
            h.update(state.tobytes())
            digest = h.hexdigest()[:16]
        print(f"{so or 'this tree'}: {len(rec['calls'])} calls, {best:.4f} s CPU (best of {repeat}), {digest}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    c = sub.add_parser("capture")
    c.add_argument("clip")
    c.add_argument("bound")
    c.add_argument("out")
    r = sub.add_parser("replay")
    r.add_argument("record")
    r.add_argument("sos", nargs="*")
    r.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    if args.command == "capture":
        capture(args.clip, args.bound, args.out)
    else:
        replay(args.record, args.sos, args.repeat)


if __name__ == "__main__":
    main()
