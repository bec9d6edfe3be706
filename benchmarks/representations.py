"""Andreou et al. (2022), Table 1, at the scale of a 2-core CPU (issue 22, item 7): one small recurrent predictor
trained once per pose input on the CMU salsa clips (subjects 60 and 61), the errors of its predictions.

    python benchmarks/representations.py                 # the reproduction, --budget 2400 s (about 45 min in all)
    python benchmarks/representations.py --quick         # a smoke run (< 2 min): tiny model, few steps
    python benchmarks/representations.py --budget 600    # shorter

Setting (what the paper's acRNN becomes here; see ``benchmarks/results/representations.md`` for the numbers):

- data: the 24 salsa clips of ``../shared/data/cmu/beemsoft_salsa`` (CMU 60_* and 61_*, Second-Life 43-joint rig
  in metres, 120 fps), resampled to 30 fps, the root translation set to zero (the paper ignores the global
  displacement: poses only); split by clip with ``motionrep.torch.split_clips`` (seed 0, 70/15/15 %, the two
  dancers of one trial kept in the same part, so a test couple is never half seen in training);
- model: a 2-layer GRU (``--hidden`` units) and a linear head predicting the next frame's normalised features
  as a residual of the current ones; trained auto-conditioned as acRNN is (sequences of 50 frames: 10 seed frames
  from the data, then alternately 5 frames of its own output and 5 of the data), Adam, one seed for all inputs,
  the same number of steps for all (the slowest input's step time sets it so that the whole run fits
  ``--budget`` seconds);
- inputs (``INPUTS``): positions (MSE), quaternions (MSE), quaternions with an FK loss, ortho6D (MSE), dual
  quaternions (MSE) and dual quaternions with all of eq. 14-16 (``motionrep.torch.dq_*_loss``); features come from
  ``motionrep.torch.MotionDataset`` (the registered representations' numpy encoders; local quaternions, which no
  shipped representation is, from a small representation defined here), normalised by ``FeatureStats`` of the
  training clips; the structural losses work on the de-normalised output;
- evaluation on the test clips, as the paper's section 7.1.2: seeds of 10 frames every 7 frames (at most 400),
  the joint-position error (mean Euclidean distance over joints and end sites, FK with the root at the origin) at
  100, 400 and 1000 ms; the acceleration measure over 300 generated frames (10 s): the mean acceleration of the
  prediction's points against the data's, ``|mean |a_pred| - mean |a_data||``; NPSS (Gopalakrishnan et al. 2019)
  on the positions' coordinates at each duration.

Results: ``benchmarks/results/representations.json`` and ``.md`` (``--quick``: ``representations_quick.*``), with
the machine's load.  The paper's absolute numbers come from another rig scale, network and 150,000 iterations:
compare the ranking, which the report states.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
DATA = Path(os.environ.get("MOTIONREP_SHARED_DATA", REPO.parent / "shared" / "data"))
SALSA = DATA / "cmu" / "beemsoft_salsa"
RESULTS = REPO / "benchmarks" / "results"
FPS = 30.0
SEED_FRAMES = 10
HORIZONS_MS = (100, 400, 1000)
ACC_FRAMES = 300
#: The FK loss and the dual-quaternion losses see every this many-th predicted frame (the MSE sees every frame).
STRUCTURE_EVERY = 4
#: Trials (both dancers each) a --quick run uses.
QUICK_TRIALS = ("01", "02", "04", "05")

#: input -> (representation, extra loss); the paper's Table 1 row it stands beside (None: not in the table).
INPUTS = {
    "positions (MSE)": ("positions", None),
    "quaternions (MSE)": ("quaternions", None),
    "quaternions-FK": ("quaternions", "fk"),
    "ortho6D (MSE)": ("ortho6d", None),
    "dual-quaternions (MSE)": ("dual-quaternion", None),
    "dual-quaternions (all)": ("dual-quaternion", "all"),
}

#: Andreou et al. 2022, Table 1: NPSS at 100/400/1000, Euclidean at 100/400/1000, acceleration (x 1e4).
PAPER = {
    "quaternions (MSE)": (0.49, 0.70, 1.19, 2.29, 2.28, 2.41, 0.18),
    "quaternions-FK": (0.38, 0.52, 1.03, 1.96, 1.98, 2.19, 0.10),
    "quaternions-positions (MSE)": (0.50, 0.69, 1.15, 2.09, 2.09, 2.22, 0.25),
    "ortho6D (MSE)": (0.42, 0.55, 0.86, 1.93, 1.87, 2.05, 0.13),
    "ortho6D-positions (MSE)": (0.40, 0.48, 0.81, 1.57, 1.57, 1.79, 0.11),
    "dual-quaternions (MSE)": (0.44, 0.53, 0.87, 1.62, 1.63, 1.86, 0.10),
    "dual-quaternions (all)": (0.30, 0.36, 0.70, 1.36, 1.46, 1.78, 0.08),
}


# ---------------------------------------------------------------------------------------------------------------
# data
# ---------------------------------------------------------------------------------------------------------------
def quaternion_representation():
    """Local quaternions of every joint (xyzw, made continuous over frames) after the root translation: the
    paper's "quaternions" input, which no shipped representation is."""
    from motionrep import Motion
    from motionrep.plugin.representation import Representation

    class Quaternions(Representation):
        name = "bench-quaternions"
        version = 1
        description = "root translation, then every joint's local quaternion (xyzw)"

        def width(self, skeleton):
            return 3 + 4 * skeleton.num_joints

        def feature_names(self, skeleton):
            return ["root/tx", "root/ty", "root/tz"] + [f"{n}/q{c}" for n in skeleton.names for c in "xyzw"]

        def to_features(self, motion):
            q = np.array(motion.rotations)
            flip = np.cumsum(np.einsum("fjc,fjc->fj", q[1:], q[:-1]) < 0, axis=0) % 2 == 1
            q[1:][flip] *= -1.0  # each quaternion on the hemisphere of the previous frame's
            return np.concatenate([motion.root_translation, q.reshape(len(q), -1)], axis=1)

        def from_features(self, features, skeleton, fps):
            f = np.asarray(features, dtype=np.float64)
            q = f[:, 3:].reshape(len(f), -1, 4)
            q = q / np.linalg.norm(q, axis=-1, keepdims=True)
            return Motion(skeleton, fps, f[:, :3], q)

        def weights(self, motion):
            return np.ones(self.width(motion.skeleton))

    return Quaternions()


def salsa_database(path: Path, trials: tuple[str, ...] | None = None) -> list[str]:
    """The salsa clips (of ``trials`` only, if given) at 30 fps with the root at the origin, in one database;
    returns the clip names."""
    from motionrep import Motion
    from motionrep.io import read_bvh, write_database
    from motionrep.model.ops import resample

    files = sorted(p for p in SALSA.glob("6[01]_*.bvh") if trials is None or trial(p.stem) in trials)
    if not files:
        raise SystemExit(f"no salsa clips (60_*.bvh, 61_*.bvh) in {SALSA}")

    def clips():
        for p in files:
            m = resample(read_bvh(p), FPS)
            yield p.stem, Motion(m.skeleton, FPS, np.zeros_like(m.root_translation), m.rotations,
                                 m.joint_translations)

    return write_database(clips(), path)


def trial(name: str) -> str:
    """``60_01_scaled`` -> ``01``: both dancers of a trial form one group of the split."""
    return name.split("_")[1]


# ---------------------------------------------------------------------------------------------------------------
# model and losses
# ---------------------------------------------------------------------------------------------------------------
def make_model(torch, width: int, hidden: int):
    class Predictor(torch.nn.Module):
        """2-layer GRU; the next frame is the current one plus the head's output (normalised features)."""

        def __init__(self):
            super().__init__()
            self.gru = torch.nn.GRU(width, hidden, num_layers=2, batch_first=True)
            self.head = torch.nn.Linear(hidden, width)

        def step(self, x, h):
            y, h = self.gru(x[:, None], h)
            return x + self.head(y[:, 0]), h

        def rollout(self, frames, own):
            """Predictions of frames 1..T-1 of ``frames`` (B, T, D): the input at t is the data where ``own[t]``
            is False, else the previous prediction (auto-conditioning)."""
            h, out, prev = None, [], None
            for t in range(frames.shape[1] - 1):
                x = prev if (own[t] and prev is not None) else frames[:, t]
                prev, h = self.step(x, h)
                out.append(prev)
            return torch.stack(out, dim=1)

        def generate(self, seed, count):
            """``count`` frames after the (B, S, D) seed, each fed back."""
            h, x = None, None
            for t in range(seed.shape[1]):
                x, h = self.step(seed[:, t], h)
            out = [x]
            for _ in range(count - 1):
                x, h = self.step(x, h)
                out.append(x)
            return torch.stack(out, dim=1)

    return Predictor()


class Input:
    """One input of the comparison: how its features are made, decoded to positions and scored by its loss."""

    def __init__(self, label, rep, extra, db, split, skeleton, args):
        import torch

        import motionrep.torch as mt

        self.label, self.rep_name, self.extra, self.skeleton = label, rep, extra, skeleton
        self.torch, self.mt = torch, mt
        representation = {"positions": "root-quat-axis-angle", "quaternions": quaternion_representation()}.get(rep, rep)
        common = dict(representation=representation, length=args.sequence, stride=args.stride, positions=True)
        self.train = mt.MotionDataset(db, clips=split["train"], **common).preload()
        if rep == "positions":
            arrays = [self.train._cache.get(i)["positions"].reshape(-1, self.points * 3).astype(np.float64)
                      for i in range(len(self.train.clips))]
            names = [f"p{i}" for i in range(self.points * 3)]
            self.stats = mt.FeatureStats.from_arrays(arrays, "positions", 1, names)
        else:
            self.stats = self.train.compute_stats()
            self.train.set_stats(self.stats)
        self.width = self.stats.width
        self.test = mt.MotionDataset(db, clips=split["test"], representation=representation,
                                     length=SEED_FRAMES + args.generate, stride=7, positions=True)
        if rep != "positions":
            self.test.set_stats(self.stats)

    @property
    def points(self) -> int:
        return self.skeleton.num_joints + self.skeleton.num_end_sites

    def inputs(self, batch):
        """(B, T, D) normalised network inputs of a dataset batch."""
        if self.rep_name == "positions":
            p = batch["positions"].reshape(*batch["positions"].shape[:2], -1)
            return self.stats.normalize(p)
        return batch["features"]

    def positions(self, normalised):
        """(B, T, J + E, 3) world positions of normalised outputs (root at the origin)."""
        torch, mt, sk = self.torch, self.mt, self.skeleton
        f = self.stats.denormalize(normalised)
        if self.rep_name == "positions":  # the root point held at the origin, as in the data
            p = f.reshape(*f.shape[:2], self.points, 3)
            return p - p[..., :1, :]
        # the root translation (columns 0-2 in every layout used here) is zero in the data: held there, so
        # that only the pose is judged, as in the paper
        f = torch.cat([torch.zeros_like(f[..., :3]), f[..., 3:]], dim=-1)
        if self.rep_name == "quaternions":
            q = f[..., 3:].reshape(*f.shape[:2], sk.num_joints, 4)
            q = q / q.norm(dim=-1, keepdim=True).clamp_min(1e-8)
            return mt.global_positions(sk, f[..., :3], q, None)
        return mt.global_positions(sk, *mt.decode_features(self.rep_name, f, sk))

    def loss(self, predicted, target, positions):
        """MSE on the normalised features, plus the input's structural losses on the de-normalised ones, on every
        ``STRUCTURE_EVERY``-th frame (FK and dual-quaternion algebra cost far more than the network on a CPU);
        ``positions`` are the data's (B, T, J + E, 3)."""
        torch, mt, sk = self.torch, self.mt, self.skeleton
        loss = torch.mean((predicted - target) ** 2)
        some = slice(STRUCTURE_EVERY - 1, None, STRUCTURE_EVERY)
        if self.extra == "fk":
            loss = loss + torch.mean(torch.linalg.vector_norm(self.positions(predicted[:, some]) - positions[:, some],
                                                              dim=-1))
        elif self.extra == "all":
            p = mt.dualquats_of_features(self.stats.denormalize(predicted[:, some]), sk)
            t = mt.dualquats_of_features(self.stats.denormalize(target[:, some]), sk)
            loss = (loss + mt.dq_quat_loss(p, t, sk) + mt.dq_pos_loss(p, t) + mt.dq_offset_loss(p, t, sk)
                    + mt.dq_reg_loss(p))
        return loss


# ---------------------------------------------------------------------------------------------------------------
# measures
# ---------------------------------------------------------------------------------------------------------------
def npss(truth: np.ndarray, pred: np.ndarray) -> float:
    """Normalized Power Spectrum Similarity (Gopalakrishnan et al. 2019) of (N, T, C) sequences: per sequence and
    coordinate, the earth mover's distance between the normalised power spectra over time, averaged with the
    truth's power as weights."""
    pt = np.abs(np.fft.fft(np.asarray(truth, np.float64), axis=1)) ** 2
    pp = np.abs(np.fft.fft(np.asarray(pred, np.float64), axis=1)) ** 2
    wt = pt.sum(axis=1)
    nt = pt / np.maximum(wt[:, None], 1e-300)
    npp = pp / np.maximum(pp.sum(axis=1)[:, None], 1e-300)
    emd = np.abs(np.cumsum(nt, axis=1) - np.cumsum(npp, axis=1)).sum(axis=1)
    return float((emd * wt).sum() / max(wt.sum(), 1e-300))


def evaluate(inp: Input, model, seeds: int, generate: int) -> dict:
    torch = inp.torch
    n = len(inp.test)
    chosen = np.linspace(0, n - 1, min(seeds, n)).round().astype(int).tolist() if n else []
    errors = {h: [] for h in HORIZONS_MS}
    truth_all, pred_all = [], []
    with torch.no_grad():
        for i in range(0, len(chosen), 50):
            batch = inp.test[chosen[i:i + 50]]
            x = inp.inputs(batch)
            out = model.generate(x[:, :SEED_FRAMES], generate)
            pred = inp.positions(out).numpy()
            truth = batch["positions"][:, SEED_FRAMES:SEED_FRAMES + generate].numpy()
            truth_all.append(truth)
            pred_all.append(pred)
    truth, pred = np.concatenate(truth_all), np.concatenate(pred_all)
    dist = np.linalg.norm(pred - truth, axis=-1)  # (N, T, P)
    out = {"seeds": int(truth.shape[0])}
    for h in HORIZONS_MS:
        k = min(generate, max(1, int(round(h / 1000 * FPS))))
        out[f"euclidean_{h}ms"] = float(dist[:, k - 1].mean())
        out[f"npss_{h}ms"] = npss(truth[:, :k].reshape(len(truth), k, -1), pred[:, :k].reshape(len(pred), k, -1))
    acc = lambda p: np.linalg.norm(np.diff(p, 2, axis=1), axis=-1).mean() * FPS ** 2  # noqa: E731
    out["acceleration_data"] = float(acc(truth))
    out["acceleration_pred"] = float(acc(pred))
    out["acceleration_error"] = abs(out["acceleration_pred"] - out["acceleration_data"])
    return out


# ---------------------------------------------------------------------------------------------------------------
# run
# ---------------------------------------------------------------------------------------------------------------
def _short_runs(rows: dict, steps: int) -> str:
    """The inputs that stopped at their time cap before ``steps`` (the machine slowed down), said in the table's
    header so that a row trained for fewer steps is never read as an equal budget."""
    short = [f"{k}: {r['steps']}" for k, r in rows.items() if r["steps"] < steps]
    return f" (stopped at the time cap of 1.5x its calibrated time, so fewer steps: {'; '.join(short)})" if short else ""


def train(inp: Input, args, steps: int, seed: int, seconds: float | None = None):
    """Train for ``steps`` steps, or until ``seconds`` have passed (a guard against the machine slowing down:
    the row then reports the steps it made)."""
    torch = inp.torch
    torch.manual_seed(seed)
    model = make_model(torch, inp.width, args.hidden)
    opt = torch.optim.Adam(model.parameters(), lr=args.lr)
    sampler = inp.mt.WindowSampler(inp.train, args.batch, seed=seed, drop_last=True)
    own = [t >= SEED_FRAMES and (t - SEED_FRAMES) % 10 < 5 for t in range(args.sequence)]
    losses, done, t0 = [], 0, time.perf_counter()
    while done < steps:
        for b in sampler:
            batch = inp.train[b]
            x = inp.inputs(batch)
            loss = inp.loss(model.rollout(x, own), x[:, 1:], batch["positions"][:, 1:])
            opt.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
            opt.step()
            losses.append(float(loss.detach()))
            done += 1
            if done >= steps or (seconds is not None and time.perf_counter() - t0 > seconds):
                break
        if seconds is not None and time.perf_counter() - t0 > seconds:
            break
    return model, {"steps": done, "seconds": round(time.perf_counter() - t0, 1),
                   "final_loss": float(np.mean(losses[-10:])) if losses else None}


def kendall(a: list[float], b: list[float]) -> float:
    n, s = len(a), 0
    for i in range(n):
        for j in range(i + 1, n):
            s += np.sign(a[i] - a[j]) * np.sign(b[i] - b[j])
    return float(s / (n * (n - 1) / 2)) if n > 1 else float("nan")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=float, default=2400.0, help="seconds for the whole run (default 2400)")
    ap.add_argument("--quick", action="store_true", help="a smoke run: tiny model, few steps, few seeds (< 2 min)")
    ap.add_argument("--hidden", type=int, default=None)
    ap.add_argument("--batch", type=int, default=32)
    ap.add_argument("--lr", type=float, default=1e-3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--only", nargs="*", default=None, help="run only these inputs (labels of INPUTS)")
    args = ap.parse_args(argv)
    if not SALSA.is_dir():
        print(f"salsa clips not found at {SALSA}", file=sys.stderr)
        return 1
    args.hidden = args.hidden or (32 if args.quick else 128)
    args.sequence = 30 if args.quick else 50
    args.stride = 10
    args.generate = 60 if args.quick else ACC_FRAMES
    seeds = 24 if args.quick else 400
    budget = 60.0 if args.quick else args.budget
    start = time.perf_counter()
    load_before = os.getloadavg()

    import torch

    import motionrep.torch as mt

    # one thread: on this shared 2-core machine two torch threads contend and a step takes 10 times longer
    torch.set_num_threads(1)
    scratch = tempfile.TemporaryDirectory(prefix="motionrep_salsa_")  # removed when the run ends
    db = Path(scratch.name) / "salsa30.h5"
    names = salsa_database(db, QUICK_TRIALS if args.quick else None)
    fractions = (0.5, 0.25, 0.25) if args.quick else (0.7, 0.15, 0.15)
    split = mt.split_clips(names, fractions, seed=args.seed, group=trial)
    from motionrep.io import read

    skeleton = read(db, names[0]).skeleton
    labels = [k for k in INPUTS if args.only is None or k in args.only]
    runs = {label: Input(label, *INPUTS[label], db, split, skeleton, args) for label in labels}
    prep = time.perf_counter() - start
    # calibration: the inputs' step times set the common number of steps (none in a smoke run)
    per_step = {}
    if args.quick:
        steps = 3
    else:
        for label, inp in runs.items():
            _, info = train(inp, args, 3, args.seed)
            per_step[label] = info["seconds"] / 3
        eval_share = 0.15 * budget
        left = budget - (time.perf_counter() - start) - eval_share
        steps = max(3, int(0.85 * left / max(sum(per_step.values()), 1e-9)))  # 15 % margin for the load
    print(f"data and datasets {prep:.0f} s; {steps} steps per input (step times {per_step})", flush=True)
    rows = {}
    for label, inp in runs.items():
        cap = None if args.quick else 1.5 * steps * per_step[label]
        model, info = train(inp, args, steps, args.seed, cap)
        rows[label] = {**info, **evaluate(inp, model, seeds, args.generate)}
        print(label, json.dumps(rows[label]), flush=True)
    total = time.perf_counter() - start
    ours = [k for k in rows if k in PAPER]
    tau = kendall([rows[k]["euclidean_1000ms"] for k in ours], [PAPER[k][5] for k in ours])
    best = min(rows, key=lambda k: rows[k]["euclidean_1000ms"])
    paper_best = min(ours, key=lambda k: PAPER[k][5]) if ours else None
    if len(ours) < 2:
        statement = "Ranking not compared: fewer than two of the inputs that ran are in the paper's table."
    else:
        holds = tau > 0.6 and best == paper_best
        statement = (f"Ranking by the 1000 ms joint error over the {len(ours)} inputs in both tables: Kendall tau "
                     f"{tau:+.2f} against the paper's (1 = same order). Best here: {best}; best in the paper: "
                     f"{paper_best}. The paper's ranking {'holds' if holds else 'does not hold'} at this scale "
                     "(holds: tau above 0.6 and the same best input).")
    result = {"quick": args.quick, "settings": {"hidden": args.hidden, "layers": 2, "cell": "GRU",
                                                 "sequence": args.sequence, "batch": args.batch, "lr": args.lr,
                                                 "steps": steps, "seed": args.seed, "fps": FPS,
                                                 "seed_frames": SEED_FRAMES, "generate": args.generate,
                                                 "budget_s": budget},
              "split": split, "rows": rows, "paper": {k: dict(zip(
                  ["npss_100", "npss_400", "npss_1000", "euclid_100", "euclid_400", "euclid_1000", "accel_1e4"], v))
                  for k, v in PAPER.items()},
              "ranking": {"kendall_tau_euclidean_1000ms": tau, "best": best, "paper_best": paper_best,
                          "statement": statement},
              "seconds": round(total, 1),
              "machine": {"cpus": os.cpu_count(), "load_before": [round(x, 2) for x in load_before],
                          "load_after": [round(x, 2) for x in os.getloadavg()], "torch": torch.__version__,
                          "python": platform.python_version()}}
    stem = "representations_quick" if args.quick else "representations"
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / f"{stem}.json").write_text(json.dumps(result, indent=1) + "\n")
    units = skeleton.units or "m"  # the salsa conversion is in metres (../shared/data/PROVENANCE.md)
    from motionrep import character_height

    command = "benchmarks/representations.py" + (" --quick" if args.quick else "")
    lines = [f"# Andreou et al. 2022, Table 1, on this machine (`{command}`)",
             "", ("**Smoke run (`--quick`): a tiny model trained for a few steps; the numbers say only that the run "
                  "works end to end.**" if args.quick else ""), "",
             f"2-layer GRU ({args.hidden} units), {steps} steps of {args.batch} sequences of {args.sequence} frames at "
             f"30 fps for every input{_short_runs(rows, steps)}, seed {args.seed}; salsa clips split by trial: train {len(split['train'])}, "
             f"val {len(split['val'])} (not used: no early stopping), test {len(split['test'])} clips; "
             f"{rows[labels[0]]['seeds']} test seeds of 10 "
             f"frames. Joint error in {units} (rig height "
             f"{character_height(skeleton):.2f} {units}), root at the origin.", "",
             "| input | NPSS 100 | 400 | 1000 | error 100 ms | 400 ms | 1000 ms | accel. error | | paper NPSS 100 | "
             "400 | 1000 | paper Eucl. 100 | 400 | 1000 | paper accel. |", "|" + "---|" * 17]
    for k, r in rows.items():
        p = PAPER.get(k)
        ptxt = " | ".join(f"{v:.2f}" for v in p) if p else " | ".join(["-"] * 7)
        lines.append(f"| {k} | {r['npss_100ms']:.3f} | {r['npss_400ms']:.3f} | {r['npss_1000ms']:.3f} | "
                     f"{r['euclidean_100ms']:.4f} | {r['euclidean_400ms']:.4f} | {r['euclidean_1000ms']:.4f} | "
                     f"{r['acceleration_error']:.3f} | | {ptxt} |")
    for k in PAPER:
        if k not in rows:
            lines.append(f"| {k} (not run here) | | | | | | | | | " + " | ".join(f"{v:.2f}" for v in PAPER[k]) + " |")
    lines += ["", statement, "",
              "Acceleration error: |mean |a| of the prediction - mean |a| of the data| over "
              f"{args.generate} generated frames, {units}/s^2 (the paper's column is in its own units x 1e4).",
              f"Run time {total / 60:.1f} min; machine: {os.cpu_count()} CPUs shared with other jobs, load average "
              f"{load_before[0]:.2f} before, {os.getloadavg()[0]:.2f} after; torch {torch.__version__}."]
    (RESULTS / f"{stem}.md").write_text("\n".join(lines) + "\n")
    print(statement)
    print(f"total {total:.0f} s; results in {RESULTS / stem}.md")
    for inp in runs.values():
        inp.train.close()
        inp.test.close()
    scratch.cleanup()
    return 0


if __name__ == "__main__":
    sys.exit(main())
