"""MotionDataset throughput and memory (issue 22, item 5): windows of 64 frames per second from an ``.h5``
database of every real clip in ``../shared/data``, read through ``DataLoader(num_workers=2)``, and the peak memory
(PSS, summed over the main process and its workers) while doing it.

    python benchmarks/dataset.py [--epochs 3] [--batch 256] [--stride 8] [--representation root-quat-axis-angle]

Targets: >= 5,000 windows/s, < 1 GB peak.  Writes ``benchmarks/results/dataset.json`` and ``dataset.md``.
The database is built once under ``$TMPDIR`` (not in the repository: the clips stay in ../shared).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
DATA = Path(os.environ.get("MOTIONREP_SHARED_DATA", REPO.parent / "shared" / "data"))
RESULTS = REPO / "benchmarks" / "results"


def build_database(path: Path) -> tuple[int, int]:
    """Every valid real BVH clip of ../shared/data in one database; returns (clips, frames)."""
    from motionrep.errors import FormatError
    from motionrep.io import read_bvh, write_database

    files = sorted(p for p in DATA.rglob("*.bvh") if "malformed" not in p.parts)
    count = {"clips": 0, "frames": 0}

    def clips():
        for p in files:
            try:
                m = read_bvh(p)
            except FormatError:
                continue
            count["clips"] += 1
            count["frames"] += m.num_frames
            yield "__".join(p.relative_to(DATA).with_suffix("").parts), m

    write_database(clips(), path)
    return count["clips"], count["frames"]


def _pss(pid: int) -> int:
    """Proportional set size of a process in bytes (RSS where smaps_rollup is missing)."""
    try:
        text = Path(f"/proc/{pid}/smaps_rollup").read_text()
        key = "Pss:"
    except OSError:
        try:
            text = Path(f"/proc/{pid}/status").read_text()
        except OSError:
            return 0
        key = "VmRSS:"
    for line in text.splitlines():
        if line.startswith(key):
            return int(line.split()[1]) * 1024
    return 0


def _family(pid: int) -> list[int]:
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        try:
            for t in Path(f"/proc/{p}/task").iterdir():
                kids = (t / "children").read_text().split()
                todo.extend(int(k) for k in kids)
        except OSError:
            pass
    return out


class PeakMemory(threading.Thread):
    """Samples the summed PSS of this process and its descendants every ``interval`` seconds."""

    def __init__(self, interval: float = 0.05):
        super().__init__(daemon=True)
        self.interval, self.peak, self.peak_processes, self.stop_event = interval, 0, 0, threading.Event()

    def run(self) -> None:
        while not self.stop_event.is_set():
            pids = _family(os.getpid())
            total = sum(_pss(p) for p in pids)
            if total > self.peak:
                self.peak, self.peak_processes = total, len(pids)
            self.stop_event.wait(self.interval)

    def stop(self) -> None:
        self.stop_event.set()
        self.join()


def transfer_ceiling(torch, batches: int, shape: tuple[int, ...], workers: int) -> int:
    """Windows/s of a DataLoader whose workers only allocate and fill shared tensors of ``shape`` (no dataset):
    what moving batches of this size between processes costs on this machine now."""

    class Blank(torch.utils.data.Dataset):
        def __len__(self):
            return batches

        def __getitem__(self, i):
            t = torch.empty(shape).share_memory_()
            t.numpy()[:] = 1.0
            return {"features": t}

    loader = torch.utils.data.DataLoader(Blank(), batch_size=None, num_workers=workers,
                                         multiprocessing_context="fork")
    t = time.perf_counter()
    n = sum(b["features"].shape[0] for b in loader)
    return round(n / (time.perf_counter() - t))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--epochs", type=int, default=6)
    ap.add_argument("--batch", type=int, default=256)
    ap.add_argument("--length", type=int, default=64)
    ap.add_argument("--stride", type=int, default=8)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--representation", default="root-quat-axis-angle")
    ap.add_argument("--database", type=Path, default=Path(tempfile.gettempdir()) / "motionrep_bench_all_clips.h5")
    ap.add_argument("--no-preload", dest="preload", action="store_false",
                    help="let each worker prepare the clips it meets instead of MotionDataset.preload() before forking")
    ap.add_argument("--no-write", action="store_true", help="print, do not write benchmarks/results/")
    args = ap.parse_args(argv)
    if not DATA.is_dir():
        print(f"real clips not found at {DATA}", file=sys.stderr)
        return 1
    load_before = os.getloadavg()
    t0 = time.perf_counter()
    if not args.database.exists():
        clips, frames = build_database(args.database)
        print(f"built {args.database}: {clips} clips, {frames} frames in {time.perf_counter() - t0:.1f} s")
    import torch

    from motionrep.torch import MotionDataset, WindowSampler

    torch.set_num_threads(1)
    monitor = PeakMemory()
    monitor.start()
    t = time.perf_counter()
    ds = MotionDataset(args.database, representation=args.representation, length=args.length, stride=args.stride,
                       skeletons="group")
    index_s = time.perf_counter() - t
    t = time.perf_counter()
    if args.preload:
        ds.preload()
    preload_s = time.perf_counter() - t
    sampler = WindowSampler(ds, args.batch, shuffle=True, seed=0)
    loader = torch.utils.data.DataLoader(ds, sampler=sampler, batch_size=None, num_workers=args.workers,
                                         persistent_workers=True, multiprocessing_context="fork")
    epochs = []
    checksum = 0.0
    for e in range(args.epochs):
        t = time.perf_counter()
        windows = 0
        for batch in loader:
            windows += batch["features"].shape[0]
            checksum += float(batch["features"][:, 0, 0].sum())
        dt = time.perf_counter() - t
        epochs.append({"epoch": e, "windows": windows, "seconds": round(dt, 3), "windows_per_s": round(windows / dt)})
        print(f"epoch {e}: {windows} windows in {dt:.2f} s = {windows / dt:,.0f} windows/s")
    del loader
    t = time.perf_counter()
    inproc = sum(ds[b]["features"].shape[0] for b in sampler)  # the dataset's own cost: no workers, no transfer
    inproc_rate = round(inproc / (time.perf_counter() - t))
    print(f"in this process, no workers: {inproc_rate:,} windows/s")
    mean_width = float(np.mean([len(ds.group_layouts[g]) for g in ds.group_of]))
    ceiling = transfer_ceiling(torch, max(8, len(sampler)), (args.batch, args.length, round(mean_width)), args.workers)
    print(f"transfer ceiling (workers only fill shared tensors of the mean window size): {ceiling:,} windows/s")
    monitor.stop()
    warm = [r["windows_per_s"] for r in epochs[1:]] or [epochs[0]["windows_per_s"]]
    result = {
        "database": {"clips": len(ds.clips), "frames": int(sum(c.frames for c in ds.clips)),
                     "bytes": args.database.stat().st_size, "skeleton_groups": len(ds.group_layouts)},
        "settings": {"representation": args.representation, "length": args.length, "stride": args.stride,
                     "batch": args.batch, "workers": args.workers, "windows": len(ds),
                     "sampler": "WindowSampler, DataLoader(batch_size=None)", "preload": args.preload},
        "index_seconds": round(index_s, 2),
        "preload_seconds": round(preload_s, 2) if args.preload else None,
        "epochs": epochs,
        "warm_windows_per_s": min(warm),
        "warm_windows_per_s_median": round(float(np.median(warm))),
        "warm_windows_per_s_best": max(warm),
        "cold_windows_per_s": epochs[0]["windows_per_s"],
        "in_process_windows_per_s": inproc_rate,
        "transfer_ceiling_windows_per_s": ceiling,
        "peak_pss_mb": round(monitor.peak / 1e6, 1),
        "peak_processes": monitor.peak_processes,
        "targets": {"windows_per_s": 5000, "peak_mb": 1000},
        "machine": {"cpus": os.cpu_count(), "load_before": [round(x, 2) for x in load_before],
                    "load_after": [round(x, 2) for x in os.getloadavg()], "python": platform.python_version(),
                    "torch": torch.__version__, "platform": platform.platform()},
    }
    print(json.dumps(result, indent=1))
    if not args.no_write:
        RESULTS.mkdir(parents=True, exist_ok=True)
        (RESULTS / "dataset.json").write_text(json.dumps(result, indent=1) + "\n")
        met = lambda ok: "met" if ok else "NOT met"  # noqa: E731
        lines = [
            "# MotionDataset throughput and memory (`benchmarks/dataset.py`)", "",
            f"Database: every real clip of ../shared/data, {result['database']['clips']} clips, "
            f"{result['database']['frames']:,} frames, {result['database']['skeleton_groups']} skeletons "
            f"(`skeletons=\"group\"`), {result['database']['bytes'] / 1e6:.0f} MB. Windows of {args.length} frames, "
            f"stride {args.stride} ({len(ds):,} windows), `{args.representation}` features, batches of "
            f"{args.batch} from `WindowSampler`, `DataLoader(num_workers={args.workers}, batch_size=None)`.", "",
            "| epoch | windows | seconds | windows/s |", "|---|---|---|---|",
            *[f"| {r['epoch']} | {r['windows']:,} | {r['seconds']} | {r['windows_per_s']:,} |" for r in epochs], "",
            f"- epochs after the first: median **{round(float(np.median(warm))):,} windows/s**, "
            f"{min(warm):,} to {max(warm):,} (target >= 5,000: "
            f"{met(min(warm) >= 5000)} for the slowest, {met(max(warm) >= 5000)} for the fastest); first epoch: "
            f"{epochs[0]['windows_per_s']:,} windows/s. The spread is the shared machine (see its load below).",
            f"- the same epoch read in the main process without workers (`ds[batch]` per batch: the dataset's own "
            f"cost, no transfer between processes): {inproc_rate:,} windows/s",
            f"- the transfer ceiling now: a `DataLoader` whose two workers only allocate and fill shared tensors "
            f"of the mean window's size ({args.length} x {round(mean_width)} float32), no dataset: {ceiling:,} "
            "windows/s",
            f"- peak memory, PSS summed over {monitor.peak_processes} processes: **{result['peak_pss_mb']} MB** "
            f"(target < 1,000 MB: {met(monitor.peak < 1e9)})",
            (f"- `ds.preload()` before the workers fork (every clip read and encoded once, in the main process): "
             f"{preload_s:.1f} s" if args.preload else "- no preload: each worker prepares the clips it meets"),
            f"- indexing the database (clip summaries; `skeletons=\"group\"` reads each clip once): {index_s:.1f} s",
            f"- machine: {os.cpu_count()} CPUs shared with other jobs, load average {load_before[0]:.2f} before "
            f"and {os.getloadavg()[0]:.2f} after; torch {torch.__version__}, Python {platform.python_version()}",
        ]
        (RESULTS / "dataset.md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
