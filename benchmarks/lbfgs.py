"""The Fourier codecs' hand-written L-BFGS beside ``scipy.optimize.minimize(method="L-BFGS-B")`` (issue 21).

Both optimisers run the same training (``motionrep_fourier._train``): the same network, the same variable
projection loss and gradient (float32 network, float64 optimiser vector), L-BFGS memory 10, in chunks of
``CHUNK`` iterations between which the codec looks at the loss and the stored payload.  ``scipy`` runs each
stage as one ``minimize`` call whose callback does the codec's chunk work every ``CHUNK`` iterations (raising
``StopIteration`` when the codec is done), so its memory lasts the whole stage, as the hand-written one's does;
``ftol=0, gtol=0`` leave stopping to the codec (the iteration cap, its plateau test, or no decrease found along a
line: scipy's ``ABNORMAL_TERMINATION_IN_LNSRCH``, the hand-written one's ``converged``), ``maxls=25`` as the
hand-written line search.

Two measurements, on the eight 31-joint CMU clips (those of ACL's figures, ``benchmarks/acl.py``):

- ``fixed``: one network of ``K`` frequencies 1..K (a fresh initialisation for seed 0) trained for ``--iters``
  iterations with no codec stopping rule: the loss after 100, 250, 500 and ``--iters`` iterations, the loss
  evaluations and the wall time.
- ``codec``: ``adaptive-fourier`` (quantised, the default) at ``max_error=2%``, seed 0, windows coded in this
  process (``jobs=1``, so that every loss evaluation is counted and the times compare): bytes, training
  iterations, loss evaluations (every line-search step counted), payload measurements, wall time.

Each clip runs both optimisers in one process, one after the other (the order alternates by clip), under the
same load; one BLAS thread, as the codec trains.  Usage::

    nice -n 10 python benchmarks/lbfgs.py [--mode fixed,codec] [--out benchmarks/results/lbfgs.json]
    python benchmarks/lbfgs.py --table benchmarks/results/lbfgs.json   # the Markdown tables again
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

REPO = Path(__file__).resolve().parent.parent
DATA = Path(os.environ.get("MOTIONREP_SHARED_DATA", REPO.parent / "shared" / "data"))
OPTIMISERS = ("own", "scipy")


def cmu31() -> list[Path]:
    """The eight 31-joint CMU clips (as ``benchmarks/acl.py cmu31``)."""
    from motionrep.io import read

    out = []
    for p in sorted((DATA / "cmu").rglob("*.bvh")):
        head = p.read_bytes()[:200_000].decode("latin-1")
        if head.count("JOINT") + head.count("ROOT") == 31 and read(p).num_joints == 31:
            out.append(p)
    return out


def scipy_minimise(fg: Callable, x0: np.ndarray, iterations: int, start: Callable[[float], object],
                   chunk_end: Callable[[np.ndarray, float, int, bool], bool]) -> None:
    """``motionrep_fourier._train._minimise``'s contract through ``scipy.optimize.minimize(method="L-BFGS-B")``."""
    from scipy.optimize import minimize

    from motionrep_fourier import _train

    first: list[float] = []
    seen = [0]
    stopped = [False]

    def counted(x: np.ndarray) -> tuple[float, np.ndarray]:
        f, g = fg(x)
        if not first:
            first.append(f)
            start(f)
        return f, g

    def callback(intermediate_result: Any) -> None:
        seen[0] += 1
        if seen[0] % _train.CHUNK == 0 and chunk_end(np.array(intermediate_result.x), float(intermediate_result.fun),
                                                     seen[0], False):
            stopped[0] = True
            raise StopIteration

    result = minimize(counted, x0, jac=True, method="L-BFGS-B", callback=callback,
                      options={"maxiter": iterations, "maxcor": 10, "ftol": 0.0, "gtol": 0.0, "maxls": 25,
                               "maxfun": 10 ** 9})
    if stopped[0]:
        return  # stopped by the callback: the codec is done with this stage
    chunk_end(np.array(result.x), float(result.fun), int(result.nit), True)


class Counting:
    """Wraps ``_train._minimise`` (either optimiser) to count loss evaluations."""

    def __init__(self, minimise: Callable):
        self.minimise, self.evaluations = minimise, 0

    def __call__(self, fg, x0, iterations, start, chunk_end) -> None:
        def counted(x):
            self.evaluations += 1
            return fg(x)

        self.minimise(counted, x0, iterations, start, chunk_end)


def _install(which: str) -> Counting:
    from motionrep_fourier import _train

    own = getattr(_train, "_own_minimise", None) or _train._minimise
    _train._own_minimise = own
    counting = Counting(own if which == "own" else scipy_minimise)
    _train._minimise = counting
    return counting


def features_of(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Features ``(N, D)``, weights ``(D,)`` and frame times of a clip, as the pipeline gives them to the codec."""
    from motionrep.defaults import DEFAULT_REPRESENTATION
    from motionrep.io import read
    from motionrep.plugin.codec import frame_times
    from motionrep.plugin.registry import get_representation

    motion = read(path)
    rep = get_representation(DEFAULT_REPRESENTATION)
    return rep.to_features(motion), np.asarray(rep.weights(motion), np.float64), frame_times(motion.num_frames)


def fixed(path: Path, which: str, K: int, iters: int) -> dict[str, Any]:
    """One network of ``K`` frequencies trained ``iters`` iterations by ``which``, no early stop."""
    from motionrep.plugin.coding import step_scale
    from motionrep_fourier import _train, _trainnet
    from motionrep_fourier._network import fourier_features

    Y, w, times = features_of(path)
    scale = _train.clip_scale(Y, w).indices
    mean = Y.mean(axis=0)
    target = ((Y - mean) / np.asarray(step_scale(scale), np.float64)).astype(np.float32)
    gen = np.random.default_rng(0)
    net = _trainnet.initial_net(gen, 2 * K + 1, 2 * (2 * K + 1), Y.shape[1])
    x = fourier_features(times, [float(k) for k in range(1, K + 1)]).astype(np.float32)
    counting = _install(which)
    at: dict[int, float] = {}
    wanted = {100, iters // 4, iters // 2, iters}

    def chunk_end(theta, loss, done, converged) -> bool:
        for n in sorted(wanted):
            if done >= n and n not in at:
                at[n] = loss
        if converged:
            for n in wanted:
                at.setdefault(n, loss)
        return done >= iters or converged

    with _train._one_blas_thread():
        t0, c0 = time.perf_counter(), time.process_time()
        counting(lambda theta: net.loss_and_grad(x, target, theta), net.theta[:net.nonlinear_size].astype(np.float64),
                 iters, lambda f: None, chunk_end)
        seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {"mode": "fixed", "clip": str(path.relative_to(DATA)), "optimiser": which, "K": K, "iters": iters,
            "loss": {str(n): at.get(n) for n in sorted(wanted)}, "evaluations": counting.evaluations,
            "seconds": seconds, "cpu_seconds": cpu, "load": os.getloadavg()[0]}


def codec(path: Path, which: str) -> dict[str, Any]:
    """adaptive-fourier at 2 % with ``which`` optimising."""
    from motionrep.errors import BoundNotMetError
    from motionrep.io import read
    from motionrep.pipeline.compress import compress_motion

    motion = read(path)
    counting = _install(which)
    row: dict[str, Any] = {"mode": "codec", "clip": str(path.relative_to(DATA)), "optimiser": which,
                           "load": os.getloadavg()[0]}
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        r = compress_motion(motion, "adaptive-fourier", max_error="2%", seed=0, params={"jobs": 1})
    except BoundNotMetError as exc:
        row.update(ok=False, seconds=time.perf_counter() - t0, best_error=exc.best_error, error=str(exc))
    else:
        info = r.container.info
        row.update(ok=True, seconds=time.perf_counter() - t0, bytes=len(r.data),
                   payload_bytes=r.container.payload_bytes, iterations=info.get("iterations"), K=info.get("K"),
                   payload_evaluations=r.evaluations, error_percent=r.report.max_error_percent)
    row["loss_evaluations"] = counting.evaluations
    row["cpu_seconds"] = time.process_time() - c0
    return row


def table(rows: list[dict[str, Any]]) -> str:
    out = []
    fixed_rows = [r for r in rows if r["mode"] == "fixed"]
    if fixed_rows:
        iters = fixed_rows[0]["iters"]
        keys = sorted(fixed_rows[0]["loss"], key=int)
        out += [f"### Fixed network (K={fixed_rows[0]['K']}, {iters} iterations, no early stop)", "",
                "| clip | optimiser | " + " | ".join(f"loss @{k}" for k in keys) + " | evaluations | CPU s | wall s |",
                "|---|---|" + "---|" * len(keys) + "---|---|---|"]
        for r in fixed_rows:
            loss = r["loss"]
            out.append(f"| {r['clip']} | {r['optimiser']} | " + " | ".join(
                f"{loss[k]:.4e}" if loss[k] is not None else "-" for k in keys)
                       + f" | {r['evaluations']} | {r['cpu_seconds']:.2f} | {r['seconds']:.2f} |")
        out.append("")
        for k in keys:
            ratios = _ratios(fixed_rows, lambda r: r["loss"][k])
            out.append(f"- median loss @{k}, scipy / own: {statistics.median(ratios):.3f} "
                       f"(range {min(ratios):.3f}-{max(ratios):.3f})")
        for what in ("evaluations", "cpu_seconds", "seconds"):
            ratios = _ratios(fixed_rows, lambda r: r[what])
            out.append(f"- median {what}, scipy / own: {statistics.median(ratios):.3f} "
                       f"(range {min(ratios):.3f}-{max(ratios):.3f})")
        out.append("")
    codec_rows = [r for r in rows if r["mode"] == "codec"]
    if codec_rows:
        out += ["### adaptive-fourier at 2 % (quantised, seed 0, jobs=1)", "",
                "| clip | optimiser | bytes | K | iterations | loss evaluations | payload measurements | CPU s | wall s |",
                "|---|---|---|---|---|---|---|---|---|"]
        for r in codec_rows:
            if r["ok"]:
                out.append(f"| {r['clip']} | {r['optimiser']} | {r['bytes']} | {r['K']} | {r['iterations']} | "
                           f"{r['loss_evaluations']} | {r['payload_evaluations']} | {r['cpu_seconds']:.1f} | "
                           f"{r['seconds']:.1f} |")
            else:
                out.append(f"| {r['clip']} | {r['optimiser']} | FAIL (best {r['best_error']:.4g}) | | | "
                           f"{r['loss_evaluations']} | | {r['cpu_seconds']:.1f} | {r['seconds']:.1f} |")
        out.append("")
        for which in OPTIMISERS:
            mine = [r for r in codec_rows if r["optimiser"] == which]
            ok = [r for r in mine if r["ok"]]
            out.append(f"- {which}: {len(ok)}/{len(mine)} met the bound, total bytes {sum(r['bytes'] for r in ok)}, "
                       f"total CPU seconds {sum(r['cpu_seconds'] for r in mine):.1f}, "
                       f"total wall seconds {sum(r['seconds'] for r in mine):.1f}, "
                       f"loss evaluations {sum(r['loss_evaluations'] for r in mine)}")
        both = _ratios([r for r in codec_rows if r["ok"]], lambda r: r["bytes"])
        if both:
            out.append(f"- median bytes, scipy / own: {statistics.median(both):.4f} "
                       f"(range {min(both):.4f}-{max(both):.4f})")
        for what in ("cpu_seconds", "seconds"):
            secs = _ratios(codec_rows, lambda r: r[what])
            out.append(f"- median {what}, scipy / own: {statistics.median(secs):.3f} "
                       f"(range {min(secs):.3f}-{max(secs):.3f})")
        loads = [r["load"] for r in rows]
        out.append(f"- load average during the runs: {min(loads):.1f}-{max(loads):.1f}")
    return "\n".join(out)


def _ratios(rows: list[dict[str, Any]], key: Callable[[dict[str, Any]], float]) -> list[float]:
    by = {(r["clip"], r["optimiser"]): key(r) for r in rows}
    return [by[(c, "scipy")] / by[(c, "own")] for c, o in by if o == "own" and (c, "scipy") in by
            and by[(c, "own")] and by[(c, "scipy")] is not None and not math.isnan(by[(c, "own")])]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mode", default="fixed,codec")
    ap.add_argument("--out", type=Path, default=REPO / "benchmarks" / "results" / "lbfgs.json")
    ap.add_argument("--K", type=int, default=8, help="frequencies of the fixed network")
    ap.add_argument("--iters", type=int, default=1000, help="iterations of the fixed network")
    ap.add_argument("--only", default=None, help="substring filter on clip paths")
    ap.add_argument("--table", type=Path, default=None, help="print the tables of a results file")
    args = ap.parse_args()
    if args.table is not None:
        print(table(json.loads(args.table.read_text())))
        return
    clips = [p for p in cmu31() if args.only is None or args.only in str(p)]
    if not clips:
        sys.exit(f"no CMU-31 clips under {DATA}")
    for which in OPTIMISERS:  # one-time costs (imports, compiled kernels) before anything is timed
        fixed(clips[0], which, 1, 30)
    rows: list[dict[str, Any]] = []
    for mode in args.mode.split(","):
        for n, path in enumerate(clips):
            for which in (OPTIMISERS if n % 2 == 0 else OPTIMISERS[::-1]):
                row = fixed(path, which, args.K, args.iters) if mode == "fixed" else codec(path, which)
                print(json.dumps(row), flush=True)
                rows.append(row)
                args.out.write_text(json.dumps(rows, indent=1) + "\n")
    print(table(rows))


if __name__ == "__main__":
    main()
