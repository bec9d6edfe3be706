"""Payload fuzz benchmark (issue 27): mutants of the ``transform`` (versions 2 and 1) and quantised Fourier
payloads inside ``.mrc`` files whose CRC-32 is recomputed (the container is packed again around the mutated payload), so that
the payloads' own consistency checks, not the checksum, meet the damage.

    python tests/fuzz/payloads.py --mutants 20000 [--seconds 240] [--seed 0] [--json results.json]

Each mutant (``tests/fuzz/mutate.py``'s ``mutate_bytes`` on the payload's ``data`` array: bytes overwritten,
inserted, removed, truncated; half of the seeds also overwrite bytes of the head, where the declared frame and
feature counts, window edges and frequency counts live) is unpacked and decoded in this process
(``motionrep.io.container.unpack`` then ``motionrep.pipeline.compress.decompress``) under an address-space limit
(``--memory``) and classified:

- ``refused``: a ``ContainerError`` naming the file;
- ``identical``: it decodes to exactly the original motion (the damage was in bytes the decoder does not use);
  compared bit for bit on purpose: the decoders are compiled loops without BLAS, deterministic on one machine;
- ``consistent``: it decodes to another motion that the file really describes: the clip's frame count, the
  skeleton's joints, finite values, unit quaternions (the payload's numbers changed, its counts did not);
- ``inconsistent``: it decodes to something else (a frame count or shape that is not the clip's, values that
  are not finite): a failure;
- ``traceback``: any other exception (``MemoryError`` included), or an error not naming the file: a failure;
- ``slow``: a decode that took longer than ``--slow`` seconds (reported with the longest time): a failure.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import random
import resource
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from fuzz.mutate import mutate_bytes  # noqa: E402


def _originals() -> dict[str, object]:
    from motionrep.pipeline.compress import Pipeline
    from motionrep.model.synthetic import synthetic_motion
    from motionrep_transform import _stream, _stream2

    motion = synthetic_motion(frames=120, seed=3)
    transform = Pipeline.build("transform").compress(motion).container
    # the same integers in a payload of version 1, which files in the wild hold
    old = np.frombuffer(_stream.pack(_stream2.unpack(np.asarray(transform.arrays["data"]).tobytes())), np.uint8)
    return {
        "transform": transform,
        "transform-v1": dataclasses.replace(transform, arrays={"data": old}, codec_version=1),
        "fourier-quantised": Pipeline.build("adaptive-fourier", params={"k": 2, "iters": 25, "window": 40},
                                            max_error=None).compress(motion).container,
    }


def _mutant(data: bytes, rng: random.Random) -> bytes:
    out = mutate_bytes(data, rng)
    if rng.random() < 0.5:  # the head: declared counts
        head = bytearray(out[:16])
        for _ in range(rng.randrange(1, 4)):
            if head:
                head[rng.randrange(len(head))] = rng.randrange(256)
        out = bytes(head) + out[16:]
    return out


def _classify(container, original, data: bytes, name: str) -> str:
    from motionrep.pipeline.compress import decompress
    from motionrep.io.container import pack, unpack
    from motionrep.errors import ContainerError

    mutated = dataclasses.replace(container, arrays={"data": np.frombuffer(data, np.uint8)})
    blob = pack(mutated)
    try:
        motion = decompress(unpack(blob, name), path=name)
    except ContainerError as exc:
        return "refused" if name in str(exc) else "traceback"
    except Exception:  # noqa: BLE001 - the benchmark counts them
        return "traceback"
    if (motion.num_frames != original.num_frames or motion.rotations.shape != original.rotations.shape
            or motion.root_translation.shape != original.root_translation.shape):
        return "inconsistent"
    values = (motion.rotations, motion.root_translation, motion.joint_translations)
    if not all(np.all(np.isfinite(v)) for v in values):
        return "inconsistent"
    if not np.allclose(np.linalg.norm(motion.rotations, axis=-1), 1.0, atol=1e-6):
        return "inconsistent"
    same = all(np.array_equal(a, b) for a, b in zip(values, (original.rotations, original.root_translation,
                                                                original.joint_translations)))
    return "identical" if same else "consistent"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mutants", type=int, default=10_000, help="mutants per payload kind")
    ap.add_argument("--seconds", type=float, default=None, help="stop each kind after this many seconds")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--slow", type=float, default=30.0, help="seconds after which a decode counts as slow")
    ap.add_argument("--memory", type=int, default=4 << 30, help="address-space limit (bytes)")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    from motionrep.pipeline.compress import decompress

    originals = _originals()
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    resource.setrlimit(resource.RLIMIT_AS, (args.memory, hard))
    report = {}
    for kind, container in originals.items():
        original = decompress(container)
        data = np.asarray(container.arrays["data"]).tobytes()
        counts: Counter[str] = Counter()
        longest = 0.0
        start = time.monotonic()
        failures = []
        n = 0
        for n in range(1, args.mutants + 1):
            rng = random.Random(f"{args.seed}:{kind}:{n}")
            t = time.monotonic()
            outcome = _classify(container, original, _mutant(data, rng), f"{kind}-{n}.mrc")
            took = time.monotonic() - t
            longest = max(longest, took)
            if took > args.slow:
                outcome = "slow"
            counts[outcome] += 1
            if outcome in ("inconsistent", "traceback", "slow") and len(failures) < 20:
                failures.append({"seed": n, "outcome": outcome})
            if args.seconds is not None and time.monotonic() - start > args.seconds:
                break
        report[kind] = {"mutants": n, "payload_bytes": len(data), "counts": dict(counts),
                        "longest_decode_seconds": round(longest, 4),
                        "seconds": round(time.monotonic() - start, 1), "failures": failures}
        print(kind, json.dumps(report[kind]), flush=True)
    if args.json is not None:
        args.json.write_text(json.dumps(report, indent=2) + "\n")
    bad = sum(r["counts"].get(k, 0) for r in report.values() for k in ("inconsistent", "traceback", "slow"))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
