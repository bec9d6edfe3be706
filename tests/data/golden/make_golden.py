"""Make the golden decodes of tests/test_golden_decodes.py: .mrc files of synthetic clips, encoded once, and the
SHA-256 of what the decoders of the time gave for them (issue 24: the decoders moved from numba to C and must give
the same bits).

Run with the interpreter of the checkout whose decoders are the reference (they were made with main's numba
decoders: commit 22eeb6c, and for the transform payloads of version 2 (``-v2``) commit 6c9f3a2)::

    /work/main/.venv/bin/python tests/data/golden/make_golden.py [--only transform --tag v2]

``--only`` makes the cases whose name holds that text, ``--tag`` adds ``-TAG`` to their names; the other files
and their digests are kept.  ``--stored`` (with ``--only``) encodes nothing: the digests of the stored files
whose name holds that text are made again with this checkout's decoders, and ``remade`` records the date, the
``--reason`` and which digests changed (for an intended change of what a decoder gives; the svd decoder's values between frames
since it blends decoded frames, 2026-12-07: the frames themselves and ``decompress`` kept their digests).

The encodings are stored, not redone by the test: the svd codec's SVD (LAPACK) may differ in the last bits between
machines, its decoding may not.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import subprocess
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def digest(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str(a.dtype).encode() + str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def times_of(clip, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = rng.random(700) * clip.duration
    frames = np.arange(clip.num_frames) / clip.fps
    return np.concatenate([[0.0, clip.duration, -1.0, clip.duration + 5.0], frames[::3], t])


def decodes(data: bytes) -> dict[str, str]:
    """The digests of everything a decoder gives for one file."""
    import motionrep
    from motionrep.io.container import unpack
    from motionrep.pipeline.compress import decompress
    from motionrep.plugin.codec import Payload, frame_times
    from motionrep.plugin.registry import get_codec

    container = unpack(data)
    codec = get_codec(container.codec)
    payload = Payload(arrays=container.arrays, info=container.info, version=container.codec_version)
    clip = motionrep.open(data)
    t = times_of(clip)
    u = clip.normalized_times(t)
    motion = decompress(container)
    out = {
        "features_frames": digest(codec.decode(payload, frame_times(container.num_frames))),
        "features_times": digest(codec.decode(payload, u)),
        "decompress": digest(motion.rotations, motion.root_translation, motion.joint_translations),
    }
    for dtype in (np.float64, np.float32):
        p = clip.poses(t, dtype=dtype)
        out[f"poses_{np.dtype(dtype).name}"] = digest(p.rotations, p.root_translation, p.joint_translations)
    ones = [clip.pose(x) for x in t[:40]]
    out["pose"] = digest(*[a for p in ones for a in (p.rotations, p.root_translation, p.joint_translations)])
    return out


def cases():
    from motionrep.pipeline.compress import compress_motion
    from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, synthetic_motion

    walk = synthetic_motion(humanoid_skeleton(), frames=120, fps=60.0, seed=1)
    chain = synthetic_motion(chain_skeleton(7), frames=37, fps=30.0, seed=2)
    short = synthetic_motion(humanoid_skeleton(), frames=3, fps=30.0, seed=4)
    for rep in ("root-quat-axis-angle", "euler", "ortho6d", "dual-quaternion"):
        yield f"transform-{rep}", compress_motion(walk, "transform", representation=rep).container
    yield "transform-chain", compress_motion(chain, "transform", max_error="0.5%").container
    yield "transform-3-frames", compress_motion(short, "transform").container
    yield "svd", compress_motion(walk, "svd").container
    yield "svd-float16-euler", compress_motion(walk, "svd", representation="euler",
                                               params={"dtype": "float16"}).container
    v2 = compress_motion(chain, "svd", max_error="0.5%").container
    yield "svd-v1", dataclasses.replace(v2, codec_version=1)  # as version 1 was written: decoded in float64
    fourier = {"iters": 25, "tol": 0.0}
    yield "fourier-quantised-windows", compress_motion(walk, "adaptive-fourier", max_error=None, seed=0,
                                                       params=dict(fourier, k=2, window=40)).container
    yield "fourier-quantised-ortho6d", compress_motion(walk, "adaptive-fourier", representation="ortho6d",
                                                       max_error=None, seed=0, params=dict(fourier, k=3)).container
    f32w = compress_motion(walk, "adaptive-fourier", max_error=None, seed=0,
                           params=dict(fourier, k=2, window=40, dtype="float32")).container
    yield "fourier-float32-windows", f32w
    yield "fourier-v2-float64", dataclasses.replace(f32w, codec_version=2)
    f32 = compress_motion(chain, "naive-fourier", max_error=None, seed=0,
                          params=dict(fourier, k=4, dtype="float32", window=0)).container
    yield "naive-fourier-float32", f32
    yield "naive-fourier-v1-float64", dataclasses.replace(f32, codec_version=1)


def main() -> None:
    import argparse

    from motionrep.io.container import pack

    parser = argparse.ArgumentParser()
    parser.add_argument("--only", default="")
    parser.add_argument("--tag", default="")
    parser.add_argument("--stored", action="store_true")
    parser.add_argument("--reason", default="")
    args = parser.parse_args()
    commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                            cwd=Path(__import__("motionrep").__file__).parent).stdout.strip()
    path = HERE / "golden.json"
    golden = json.loads(path.read_text()) if path.exists() and args.only else {"files": {}, "made_with": {}}
    if args.stored:
        if not args.only or not args.reason:
            parser.error("--stored needs --only and --reason")
        for name in sorted(n for n in golden["files"] if args.only in n):
            now = decodes((HERE / f"{name}.mrc").read_bytes())
            changed = sorted(k for k in now if now[k] != golden["files"][name].get(k))
            golden.setdefault("remade", {})[name] = {"date": __import__("time").strftime("%Y-%m-%d"),
                                                     "reason": args.reason, "changed": changed}
            golden["files"][name] = now
            print(name, "changed:", ", ".join(changed) or "nothing")
        path.write_text(json.dumps(golden, indent=1) + "\n")
        return
    for name, container in cases():
        if args.only not in name:
            continue
        name = f"{name}-{args.tag}" if args.tag else name
        data = pack(container)
        (HERE / f"{name}.mrc").write_bytes(data)
        golden["files"][name] = decodes(data)
        golden["made_with"][name] = commit
        print(name, len(data), "bytes")
    path.write_text(json.dumps(golden, indent=1) + "\n")


if __name__ == "__main__":
    main()
