"""Torch forward kinematics (``motionrep.torch.global_positions``, float32, CPU) beside motionrep's compiled numpy
FK (``motionrep.model.kinematics.fk_arrays``, numba, float64 arithmetic) on the same poses.

Poses: a batch of 64 windows of 64 frames (4,096 poses) of a CMU clip with the 31-joint CMU skeleton
(``cmu/InverseKinematics/02_01.bvh``; windows start every 4 frames, wrapping round the clip).  Measured: numpy FK
of the 4,096 poses (float32 rotations, as a training batch holds them); torch FK forward on the ``(64, 64, J, 4)``
batch; torch forward plus backward (gradient of the sum of positions with respect to the rotations and the
root translation).  Torch runs with one thread (the numpy FK is one thread) and with torch's default; best of
``--repeats`` wall-clock and thread-CPU times, the three measured alternately so that they share the load; the
load average of the machine before and after is recorded.  Targets (issue 22): torch forward within 3x of numpy,
forward plus backward within 3x of forward.

    nice -n 10 python benchmarks/torch_fk.py [--repeats 30] [--out benchmarks/results/torch_fk.json]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "benchmarks"))
from speed import _cpu_best  # noqa: E402  (one best-of-N wall and thread-CPU timer for every benchmark)

CLIP = REPO.parent / "shared" / "data" / "cmu" / "InverseKinematics" / "02_01.bvh"
WINDOWS, LENGTH, STRIDE = 64, 64, 4


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=30)
    parser.add_argument("--clip", type=Path, default=CLIP)
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks" / "results" / "torch_fk.json")
    args = parser.parse_args()

    import torch

    import motionrep
    import motionrep.torch as mt
    from motionrep.model.kinematics import fk_arrays

    load_before = os.getloadavg()
    motion = motionrep.read(args.clip)
    sk = motion.skeleton
    F = motion.num_frames
    index = (np.arange(WINDOWS)[:, None] * STRIDE + np.arange(LENGTH)[None]) % F  # (64, 64) frames
    rot = motion.rotations[index].astype(np.float32)  # (64, 64, J, 4)
    root = motion.root_translation[index].astype(np.float32)
    jt = motion.joint_translations[index].astype(np.float32)
    flat_rot = np.ascontiguousarray(rot.reshape(-1, sk.num_joints, 4))
    flat_root = root.reshape(-1, 3).astype(np.float64)
    flat_jt = jt.reshape((WINDOWS * LENGTH,) + jt.shape[-2:]).astype(np.float64)
    t_rot, t_root, t_jt = (torch.tensor(a) for a in (rot, root, jt))

    def numpy_fk():
        fk_arrays(sk, flat_rot, flat_root, flat_jt)

    def torch_forward():
        with torch.no_grad():
            mt.global_positions(sk, t_root, t_rot, t_jt)

    g_rot = t_rot.clone().requires_grad_(True)
    g_root = t_root.clone().requires_grad_(True)

    def torch_backward():
        g_rot.grad = g_root.grad = None
        mt.global_positions(sk, g_root, g_rot, t_jt).sum().backward()

    # same poses: torch float32 against numpy (float64 arithmetic), to float32 rounding
    ref = fk_arrays(sk, flat_rot, flat_root, flat_jt)[0]
    got = mt.global_positions(sk, t_root, t_rot, t_jt).reshape(ref.shape).double().numpy()
    agreement = float(np.abs(got - ref).max() / motionrep.model.kinematics.character_height(sk))
    for fn in (numpy_fk, torch_forward, torch_backward):  # compile / warm up
        fn()

    results: dict[str, dict[str, float]] = {}
    default_threads = torch.get_num_threads()
    runs = [("numpy compiled FK", numpy_fk, None)]
    for threads in sorted({1, default_threads}):
        runs += [(f"torch forward ({threads} thread{'s' if threads > 1 else ''})", torch_forward, threads),
                 (f"torch forward+backward ({threads} thread{'s' if threads > 1 else ''})", torch_backward, threads)]
    best: dict[str, list[float]] = {name: [float("inf"), float("inf")] for name, _, _ in runs}
    rounds = max(1, args.repeats // 5)
    for _ in range(rounds):  # alternate, so every measurement sees the same load
        for name, fn, threads in runs:
            if threads is not None:
                torch.set_num_threads(threads)
            wall, cpu = _cpu_best(fn, 5)
            best[name] = [min(best[name][0], wall), min(best[name][1], cpu)]
    torch.set_num_threads(default_threads)
    poses = WINDOWS * LENGTH
    numpy_wall = best["numpy compiled FK"][0]
    for name, (wall, cpu) in best.items():
        results[name] = {"wall_ms": wall * 1e3, "thread_cpu_ms": cpu * 1e3, "poses_per_s": poses / wall,
                         "x_numpy": wall / numpy_wall}
    for threads in sorted({1, default_threads}):
        s = "s" if threads > 1 else ""
        fwd = results[f"torch forward ({threads} thread{s})"]
        fwd["backward_x_forward"] = results[f"torch forward+backward ({threads} thread{s})"]["wall_ms"] / fwd["wall_ms"]
    report = {
        "clip": "/".join(args.clip.parts[-3:]),
        "joints": sk.num_joints, "end_sites": sk.num_end_sites, "batch": [WINDOWS, LENGTH], "poses": poses,
        "torch": torch.__version__, "torch_default_threads": default_threads, "cuda": torch.cuda.is_available(),
        "repeats": rounds * 5, "load_before": load_before, "load_after": os.getloadavg(),
        "float32_agreement_x_height": agreement, "results": results,
        "targets": {"forward_within_3x_numpy": "x_numpy <= 3", "backward_within_3x_forward": "backward_x_forward <= 3"},
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(report, indent=2) + "\n")
    print(f"{report['clip']}: {poses} poses ({WINDOWS} x {LENGTH}), {sk.num_joints} joints + {sk.num_end_sites} "
          f"end sites; load {load_before[0]:.2f} -> {report['load_after'][0]:.2f}")
    for name, r in results.items():
        extra = f", backward/forward {r['backward_x_forward']:.2f}x" if "backward_x_forward" in r else ""
        print(f"  {name:36s} {r['wall_ms']:8.2f} ms wall {r['thread_cpu_ms']:8.2f} ms CPU  "
              f"{r['x_numpy']:5.2f}x numpy{extra}")


if __name__ == "__main__":
    main()
