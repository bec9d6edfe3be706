"""Batch compression at scale: clips per second on one machine and on a Dask cluster, and what the single writer
(the client) costs per clip.

Measurements, on the CMU clips of ``../shared/data/cmu`` (every ``.bvh``), with a fast codec (``svd`` at 2 %,
or ``--codec``), each through the one batch engine (:func:`motionrep.batch.engine.compress_clips`) into an archive
through the store that ``motionrep compress`` uses (:mod:`motionrep.batch.store`: a journal commit per clip, the
archive written at the end):

1. ``local-1``: in this process (``--jobs 1``);
2. ``local-2``: two spawned worker processes (``--jobs 2``);
3. ``dask-2``: a ``dask.distributed.LocalCluster`` of two worker processes of one thread each
   (``--scheduler``), cluster start-up not counted, worker warm-up (imports) counted as for the local pool.

Each is run ``--repeats`` times (the best is kept, the machine being shared); the figures are clips per second,
source MB per second, and the time of the first clip (start-up).  Then the client's own costs, the limits of one
writer: the journal commit of one clip (an ``.mrc`` file written and renamed), writing the final archive from the
journal (clips per second into HDF5), and the round trip of one empty task through the Dask scheduler.

Results: ``benchmarks/results/scale.json``, written after every measurement (a later run with ``--skip`` keeps the
figures of the runs it skips); the 1-minute load average is recorded with every measurement.  The
projection for the whole CMU database and a 100,000-clip library is worked out in ``benchmarks/README.md``.

Usage::

    python benchmarks/scale.py [--codec svd] [--repeats 2] [--skip dask-2 ...]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DATA = Path(os.environ.get("MOTIONREP_SHARED_DATA", REPO.parent / "shared" / "data"))
RESULTS = REPO / "benchmarks" / "results"
RUNS = ("local-1", "local-2", "dask-2")


def _load() -> float:
    return round(os.getloadavg()[0], 2)


def _batch(refs, pipeline, out: Path, *, jobs: int = 1, executor=None) -> dict:
    """One run into an archive, as ``motionrep compress`` does it; the seconds it took."""
    from motionrep.batch.engine import compress_clips
    from motionrep.batch.store import open_store

    if out.exists():
        out.unlink()
    store = open_store(out, force=True)
    first: list[float] = []
    start = time.perf_counter()
    load = _load()

    def commit(outcome):
        if not first:
            first.append(time.perf_counter() - start)
        if not outcome.failed:
            store.commit(outcome.name, outcome.data)

    try:
        outcomes = compress_clips(refs, pipeline, jobs=jobs, executor=executor, on_done=commit)
    finally:
        store.close()
    seconds = time.perf_counter() - start
    failed = [o.name for o in outcomes if o.failed]
    return {"seconds": seconds, "first_clip_seconds": first[0], "failed": failed, "load_before": load,
            "load_after": _load(), "clips": len(refs), "when": time.strftime("%Y-%m-%d %H:%M"),
            "frames": sum(o.summary.get("frames", 0) for o in outcomes if not o.failed),
            "cpu_seconds": sum(o.summary.get("cpu_seconds", 0.0) for o in outcomes)}


def _writer_costs(sizes: list[int], count: int, tmp: Path) -> dict:
    """The client's costs per clip, on ``count`` containers of the measured sizes (cycled)."""
    from motionrep.batch.store import ArchiveStore

    import numpy as np

    rng = np.random.default_rng(0)
    blobs = [rng.integers(0, 256, size=s, dtype=np.uint8).tobytes() for s in sizes]
    out = tmp / "writer.h5"
    store = ArchiveStore(out, force=True)
    start = time.perf_counter()
    for i in range(count):
        store.commit(f"clip{i:06d}", blobs[i % len(blobs)])
    commit = time.perf_counter() - start
    start = time.perf_counter()
    store.close()
    assemble = time.perf_counter() - start
    mb = sum(len(blobs[i % len(blobs)]) for i in range(count)) / 1e6
    return {"clips": count, "mean_clip_bytes": round(mb * 1e6 / count), "commit_seconds_per_clip": commit / count,
            "archive_clips_per_second": count / assemble, "archive_mb_per_second": mb / assemble,
            "archive_seconds": assemble, "load": _load()}


def _task_round_trip(client, count: int = 500) -> float:
    """Seconds per empty task submitted and gathered through the scheduler (many in flight)."""
    from distributed import wait

    futures = client.map(int, range(count), pure=False)
    wait(futures)
    start = time.perf_counter()
    futures = client.map(int, range(count), pure=False)
    client.gather(futures)
    return (time.perf_counter() - start) / count


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--codec", default="svd")
    parser.add_argument("--max-error", default="2%")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--writer-clips", type=int, default=5000,
                        help="containers committed and assembled to measure the writer")
    parser.add_argument("--skip", nargs="*", default=[], choices=RUNS + ("writer",))
    args = parser.parse_args()

    from motionrep.batch.engine import dask_executor
    from motionrep.pipeline.compress import Pipeline
    from motionrep.pipeline.sources import collect_clips

    cmu = DATA / "cmu"
    if not cmu.is_dir():
        sys.exit(f"no CMU clips at {cmu}")
    refs = collect_clips([cmu])
    source_mb = sum(r.source_bytes or 0 for r in refs) / 1e6
    pipeline = Pipeline.build(args.codec, max_error=args.max_error)
    results: dict = {"codec": args.codec, "max_error": args.max_error, "clips": len(refs), "source_mb": source_mb,
                     "cpus": os.cpu_count(), "python": sys.version.split()[0], "runs": {}}
    saved = RESULTS / "scale.json"
    if saved.exists():  # keep the figures of what this run skips
        old = json.loads(saved.read_text())
        if (old.get("codec"), old.get("max_error"), old.get("clips")) == (args.codec, args.max_error, len(refs)):
            results = {**old, **{k: v for k, v in results.items() if k != "runs"}, "runs": old.get("runs", {})}

    def save() -> None:
        RESULTS.mkdir(exist_ok=True)
        saved.write_text(json.dumps(results, indent=2) + "\n")

    tmp = Path(tempfile.mkdtemp(prefix="motionrep-scale-"))
    try:
        cluster = None
        for name in RUNS:
            if name in args.skip:
                continue
            best = None
            for _ in range(args.repeats):
                if name == "local-1":
                    r = _batch(refs, pipeline, tmp / "out.h5")
                elif name == "local-2":
                    r = _batch(refs, pipeline, tmp / "out.h5", jobs=2)
                else:
                    from distributed import Client, LocalCluster

                    if cluster is None:
                        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                               dashboard_address=None, silence_logs=50)
                    else:  # fresh worker processes, so that their warm-up is counted every time
                        with Client(cluster) as c:
                            c.restart()
                    with dask_executor(cluster.scheduler_address) as executor:
                        r = _batch(refs, pipeline, tmp / "out.h5", executor=executor)
                    with Client(cluster) as c:
                        results["dask_task_seconds"] = _task_round_trip(c)
                        results["dask_task_load"] = _load()
                r["clips_per_second"] = r["clips"] / r["seconds"]
                r["source_mb_per_second"] = source_mb / r["seconds"]
                print(f"{name}: {r['clips']} clips in {r['seconds']:.1f} s = {r['clips_per_second']:.2f} clips/s "
                      f"(first clip {r['first_clip_seconds']:.1f} s, load {r['load_before']}-{r['load_after']})",
                      flush=True)
                if best is None or r["seconds"] < best["seconds"]:
                    best = r
                results["runs"][name] = best
                save()
        if cluster is not None:
            cluster.close()
        if "writer" not in args.skip:
            from motionrep.io.archive import Archive

            if not (tmp / "out.h5").exists():
                _batch(refs, pipeline, tmp / "out.h5", jobs=2)
            with Archive(tmp / "out.h5") as a:
                sizes = [a.size(n) for n in a.names]
            results["mean_compressed_bytes"] = sum(sizes) / len(sizes)
            w = _writer_costs(sizes, args.writer_clips, tmp)
            results["writer"] = w
            print(f"writer: commit {w['commit_seconds_per_clip'] * 1e3:.2f} ms/clip, archive "
                  f"{w['archive_clips_per_second']:.0f} clips/s ({w['archive_mb_per_second']:.0f} MB/s), "
                  f"load {w['load']}", flush=True)
            save()
        if "dask_task_seconds" in results:
            print(f"dask: {results['dask_task_seconds'] * 1e3:.2f} ms per empty task round trip")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    save()
    print(f"wrote {saved}")


if __name__ == "__main__":
    main()
