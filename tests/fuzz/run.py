"""Fuzz benchmark (issue 14): counts of tracebacks, hangs, leaks and over-limit allocations.

    python tests/fuzz/run.py --mutants 100000                 # every format, 100,000 mutants each
    python tests/fuzz/run.py --formats h5 --mutants 20000     # one format
    python tests/fuzz/run.py --formats glb,gltf-json          # glTF: damaged .glb bytes; edited JSON chunks
    python tests/fuzz/run.py --formats mrc --mrc-codecs adaptive-fourier,adaptive-fourier:window=16
                                                              # .mrc mutants of other codecs' payloads
    python tests/fuzz/run.py --crafted                        # the crafted cases, through the command line
    python tests/fuzz/run.py --crafted --pythonpath /old/tree # the same against another checkout (before/after)

Not part of the default test run (it takes from minutes to hours); ``tests/test_format_fuzz.py`` and
``tests/test_hostile.py`` run small versions of it there.

Mutants (``tests/fuzz/mutate.py``) are read by a child process, one after the other, each with
``motionrep.io.read`` (BVH: ``parse_bvh``, the compiled core;
``.mrc``: ``unpack`` then ``decompress``, seed ``s`` mutating the file of codec ``s mod n`` of the ``n`` in
``--mrc-codecs``; ``gltf-json``: even seeds motionrep's own ``.glb``, odd seeds the same file without its
``extras``), under the small limits ``SMALL`` below; the
child reports every outcome on a pipe.  Counted per format:

- ``refused``: motionrep's own error naming the file (the expected answer to a damaged file);
- ``read``: a clip came back (the damage was in bytes the reader does not use, or was harmless);
- ``traceback``: any other exception (``MemoryError`` included), or a motionrep error that does not name the file;
- ``warning``: (glTF) a warning (numpy's overflow, ...) was raised on the way to the clip or the error;
- ``hang``: no answer within ``--timeout`` seconds (the child is killed and restarted after that mutant);
- ``leak``: what was read holds bytes or values of a file the mutant points to (external storage, links);
- ``over-limit``: the read's peak memory (Python-traced allocations; for HDF5 also the reader process's peak
  resident size) exceeded ``64 MiB + 16 x file size + 4 x max_clip_bytes``.

The child runs with an address-space limit (``--memory``, default 4 GiB), so an allocation a check missed ends in
a ``MemoryError`` (counted) rather than in the machine's memory running out.  Mutants with an outcome other
than ``read``/``refused`` are saved under ``--out`` for reproduction.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import resource
import select
import signal
import subprocess
import sys
import tempfile
import time
import traceback
import warnings
from collections import Counter
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

SMALL = dict(max_frames=100_000, max_clip_bytes=32 << 20, max_metadata_bytes=1 << 20, read_timeout=10)
FORMATS = ("bvh", "mrc", "npz", "h5", "glb", "gltf-json")
SUFFIX = {"gltf-json": "glb"}  # JSON-chunk mutants are .glb files too
MRC_CODECS = "svd,transform"


def _codec_specs(text: str) -> list[tuple[str, dict[str, str]]]:
    """``"svd,adaptive-fourier:window=16:dtype=float32"`` -> ``[("svd", {}), ("adaptive-fourier", {...})]``."""
    specs = []
    for item in text.split(","):
        name, *pairs = item.strip().split(":")
        specs.append((name, dict(p.split("=", 1) for p in pairs)))
    return specs


def _budget(size: int) -> int:
    return (64 << 20) + 16 * size + 4 * SMALL["max_clip_bytes"]


# ---------------------------------------------------------------------------------------------------------------
# the child: read mutants, report outcomes
# ---------------------------------------------------------------------------------------------------------------
def _bases(fmt: str, work: Path, mrc_codecs: str = MRC_CODECS):
    from fuzz.crafted import mrc_parts, npz_parts, small_motion, write_v1_hdf5
    from motionrep.io import format_bvh, parse_bvh, write

    m = parse_bvh(format_bvh(small_motion(12)))
    if fmt == "bvh":
        return format_bvh(m).encode()
    if fmt == "mrc":  # by default even seeds mutate an svd file, odd ones a transform file (the default codec)
        return [mrc_parts(codec=name, params=params or None) for name, params in _codec_specs(mrc_codecs)]
    if fmt == "npz":
        write(m, work / "base.npz")
        return npz_parts(work / "base.npz")
    if fmt in ("glb", "gltf-json"):  # a clip of motionrep's own (its extras read too) and a foreign-looking one
        from fuzz.mutate import split_glb
        from motionrep.io import gltf_bytes

        own = gltf_bytes(m, up="y")
        if fmt == "glb":
            return [own]
        doc, blob = split_glb(own)
        foreign = json.loads(json.dumps(doc))
        for node in foreign["nodes"]:
            node.pop("extras", None)
        for anim in foreign["animations"]:
            anim.pop("extras", None)
        return [(doc, blob), (foreign, blob)]
    write(m, work / "v2.h5", clip="clip")
    write_v1_hdf5(m, work / "v1.h5", clip="clip")
    return [(work / "v2.h5").read_bytes(), (work / "v1.h5").read_bytes()]


def _worker_peak() -> int:
    """Peak resident bytes of the HDF5 reader process since the last reset (0 if there is none)."""
    from motionrep.io import _h5read

    proc = _h5read._worker.proc
    if proc is None:
        return 0
    try:
        for line in Path(f"/proc/{proc.pid}/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def _reset_worker_peak() -> None:
    from motionrep.io import _h5read

    proc = _h5read._worker.proc
    if proc is not None:
        try:
            Path(f"/proc/{proc.pid}/clear_refs").write_text("5")
        except OSError:
            pass


def child(fmt: str, start: int, count: int, work: Path, memory: int, mrc_codecs: str = MRC_CODECS) -> None:
    import tracemalloc

    import numpy as np

    from fuzz.crafted import SECRET
    from fuzz.mutate import SECRET_VALUE, bvh_mutant, glb_mutant, gltf_json_mutant, h5_mutant, mrc_mutant, npz_mutant
    from motionrep import Motion, limits
    from motionrep.pipeline.compress import decompress
    from motionrep.io.container import unpack
    from motionrep.errors import FormatError, MotionrepError
    from motionrep.io import parse_bvh, read

    resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    limits.set_limits(**SMALL)
    base = _bases(fmt, work, mrc_codecs)
    path = work / f"mutant.{SUFFIX.get(fmt, fmt)}"
    baseline = 0
    if fmt == "h5":  # start the reader process first: its own footprint (numpy, h5py) is not any read's
        read(work / "v2.h5")
        baseline = _worker_peak()
    out = sys.stdout
    for seed in range(start, start + count):
        rng = random.Random(seed)
        if fmt == "bvh":
            data = bvh_mutant(base, rng)
        elif fmt == "mrc":
            data = mrc_mutant(*base[seed % len(base)], rng)
        elif fmt == "npz":
            data = npz_mutant(base[0], base[1], rng)
        elif fmt == "glb":
            data = glb_mutant(base[0], rng)
        elif fmt == "gltf-json":
            data = gltf_json_mutant(*base[seed % 2], rng)  # even seeds: motionrep's own file; odd: foreign
        else:
            h5_mutant(path, base, rng, work)
            data = None
        if data is not None:
            path.write_bytes(data)
        size = path.stat().st_size
        outcome, detail = "read", ""
        tracemalloc.start()
        _reset_worker_peak()
        caught = warnings.catch_warnings(record=True)
        seen = caught.__enter__()
        warnings.simplefilter("always")
        try:
            if fmt == "bvh":
                item = parse_bvh(data, str(path))
            elif fmt == "mrc":
                item = decompress(unpack(data, str(path)), path=str(path))
            else:
                item = read(path)
            if isinstance(item, Motion):
                for a in (item.rotations, item.root_translation, item.joint_translations):
                    if np.any(a == SECRET_VALUE) or SECRET[:16] in a.tobytes():
                        outcome, detail = "leak", "secret values in the clip"
        except FormatError as exc:
            outcome = "refused" if exc.path == str(path) and "\n" not in str(exc) else "traceback"
            detail = str(exc)[:300]
        except MotionrepError as exc:
            outcome = "refused" if str(path) in str(exc) else "traceback"
            detail = f"{type(exc).__name__}: {exc}"[:300]
        except BaseException as exc:  # noqa: BLE001 - every other exception is what we count
            if isinstance(exc, KeyboardInterrupt):
                raise
            outcome = "traceback"
            detail = "".join(traceback.format_exception_only(type(exc), exc))[:300] + " @ " + \
                traceback.extract_tb(exc.__traceback__)[-1].filename.rsplit("/", 1)[-1] + ":" + \
                str(traceback.extract_tb(exc.__traceback__)[-1].lineno)
        caught.__exit__(None, None, None)
        if seen and outcome in ("read", "refused") and fmt in ("glb", "gltf-json"):
            outcome, detail = "warning", f"{seen[0].category.__name__}: {seen[0].message}"[:300]
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        if fmt == "h5":
            worker = _worker_peak()
            peak = max(peak, worker - baseline)
            if worker < baseline or not baseline:  # a fresh reader process (after a watchdog kill)
                baseline = worker
        if outcome in ("read", "refused") and peak > _budget(size):
            outcome, detail = "over-limit", f"peak {peak} bytes for a {size}-byte file"
        out.write(json.dumps({"seed": seed, "outcome": outcome, "detail": detail, "peak": peak}) + "\n")
        out.flush()


# ---------------------------------------------------------------------------------------------------------------
# the parent: run children, count, restart after a hang
# ---------------------------------------------------------------------------------------------------------------
def run_format(fmt: str, count: int, timeout: float, memory: int, out_dir: Path, seed0: int,
               mrc_codecs: str = MRC_CODECS) -> Counter:
    counts: Counter = Counter()
    details: dict[str, Counter] = {}
    work = Path(tempfile.mkdtemp(prefix=f"fuzz-{fmt}-"))
    next_seed, end = seed0, seed0 + count
    started = time.monotonic()
    peak_max = 0
    while next_seed < end:
        proc = subprocess.Popen([sys.executable, __file__, "--child", fmt, str(next_seed), str(end - next_seed),
                                 str(work), str(memory), mrc_codecs], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                start_new_session=True)
        buf = b""
        last = time.monotonic()
        assert proc.stdout is not None
        fd = proc.stdout.fileno()
        while True:
            ready = select.select([fd], [], [], 1.0)[0]
            if ready:
                chunk = os.read(fd, 1 << 16)
                if not chunk:
                    break
                buf += chunk
                last = time.monotonic()
                *lines, buf = buf.split(b"\n")
                for line in lines:
                    r = json.loads(line)
                    counts[r["outcome"]] += 1
                    peak_max = max(peak_max, r["peak"])
                    if r["outcome"] not in ("read", "refused"):
                        details.setdefault(r["outcome"], Counter())[r["detail"][:160]] += 1
                        _save(fmt, r["seed"], work, out_dir, mrc_codecs)
                    next_seed = r["seed"] + 1
                    done = next_seed - seed0
                    if done % 5000 == 0:
                        rate = done / (time.monotonic() - started)
                        print(f"  {fmt}: {done}/{count} ({rate:.0f}/s) {dict(counts)}", flush=True)
            elif time.monotonic() - last > timeout:
                os.killpg(proc.pid, signal.SIGKILL)
                counts["hang"] += 1
                details.setdefault("hang", Counter())[f"seed {next_seed}"] += 1
                _save(fmt, next_seed, work, out_dir, mrc_codecs)
                next_seed += 1
                break
        proc.wait()
        if proc.returncode not in (0, None, -signal.SIGKILL) and next_seed < end:
            counts["traceback"] += 1  # the child died: count the mutant it was on, go on after it
            details.setdefault("traceback", Counter())[f"child died ({proc.returncode}) at seed {next_seed}"] += 1
            _save(fmt, next_seed, work, out_dir, mrc_codecs)
            next_seed += 1
    counts["seconds"] = round(time.monotonic() - started)
    counts["peak_bytes_max"] = peak_max
    for outcome, c in details.items():
        for text, n in c.most_common(8):
            print(f"    {outcome} x{n}: {text}")
    return counts


def _save(fmt: str, seed: int, work: Path, out_dir: Path, mrc_codecs: str = MRC_CODECS) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    bases = f", --mrc-codecs {mrc_codecs}" if fmt == "mrc" else ""
    (out_dir / f"{fmt}-seed{seed}.txt").write_text(
        f"regenerate with tests/fuzz/mutate.py, format {fmt}, seed {seed}{bases}\n")


_RUSAGE = ("import resource, subprocess, sys; r = subprocess.run(sys.argv[1:]); "
           "print('MAXRSS_KB=%d' % resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, file=sys.stderr); "
           "sys.exit(r.returncode)")


def run_crafted(pythonpath: str | None, timeout: float, memory: int) -> list[dict]:
    from fuzz.crafted import build, check_leak

    work = Path(tempfile.mkdtemp(prefix="crafted-"))
    cases = build(work / "in", bomb=True)
    env = dict(os.environ)
    if pythonpath:
        env["PYTHONPATH"] = os.pathsep.join([pythonpath, str(Path(pythonpath) / "plugins")])
        env["PYTHONDONTWRITEBYTECODE"] = "1"  # leave the other checkout as it is
    rows = []
    for case in cases:
        out_dir = work / "out" / case.name
        out_dir.mkdir(parents=True)
        out = out_dir / f"out{case.out_suffix}"
        # a wrapper runs the command and reports its peak resident size (the child's own rusage)
        cmd = [sys.executable, "-c", _RUSAGE, sys.executable, "-m", "motionrep"] + [
            a.replace("{out}", str(out)) for a in case.command]

        def limit() -> None:
            resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
            os.setsid()

        start = time.monotonic()
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, preexec_fn=limit,
                                cwd=out_dir)  # not this checkout: '' on sys.path would import it first
        try:
            stdout, stderr = proc.communicate(timeout=timeout)
            hung = False
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            stdout, stderr = proc.communicate()
            hung = True
        seconds = time.monotonic() - start
        text = (stdout + stderr).decode("utf-8", "replace")
        peak = None
        if "MAXRSS_KB=" in text:
            text, _, kb = text.rpartition("MAXRSS_KB=")
            peak = int(kb.strip()) * 1024
        leak = check_leak(list(out_dir.iterdir()))
        ok = None
        if case.kind == "accept" and out.exists():
            ok = case.check(out) is None
        rows.append({"case": case.name, "issue": case.issue, "exit": None if hung else proc.returncode,
                     "hang": hung, "seconds": round(seconds, 2), "traceback": "Traceback" in text,
                     "names_file": str(case.path) in text, "output_left": out.exists() and case.kind != "accept",
                     "leak": leak, "exact": ok, "peak_mb": None if peak is None else round(peak / 2 ** 20),
                     "message": text.strip().splitlines()[-1][:200] if text.strip() else ""})
    return rows


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        fmt, start, count, work, memory, mrc_codecs = sys.argv[2:8]
        child(fmt, int(start), int(count), Path(work), int(memory), mrc_codecs)
        return
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mutants", type=int, default=100_000, help="mutants per format (default 100,000)")
    ap.add_argument("--formats", default=",".join(FORMATS), help="comma-separated: " + ", ".join(FORMATS))
    ap.add_argument("--seed", type=int, default=0, help="first seed")
    ap.add_argument("--mrc-codecs", default=MRC_CODECS,
                    help="codecs whose .mrc files are mutated, one after the other, with parameters after colons "
                         f"(default {MRC_CODECS}; e.g. adaptive-fourier,naive-fourier:dtype=float32)")
    ap.add_argument("--timeout", type=float, default=30.0, help="seconds without an answer that make a hang")
    ap.add_argument("--memory", type=int, default=4 << 30, help="address-space limit of the reading process")
    ap.add_argument("--out", type=Path, default=Path("fuzz-findings"), help="where unexpected mutants are listed")
    ap.add_argument("--crafted", action="store_true", help="run the crafted cases through the command line")
    ap.add_argument("--pythonpath", help="with --crafted: run another checkout's motionrep (the 'before')")
    ap.add_argument("--json", type=Path, help="write the results here too")
    args = ap.parse_args()
    load = os.getloadavg()
    print(f"machine load: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} CPUs", flush=True)
    results: dict = {"load": load}
    if args.crafted:
        from motionrep import limits

        # beyond the reader's own watchdog (read_timeout, 60 s by default): the damaged HDF5 case ends there
        rows = run_crafted(args.pythonpath, max(args.timeout, limits.current().read_timeout + 60.0), args.memory)
        results["crafted"] = rows
        for r in rows:
            verdict = ("HANG" if r["hang"] else "TRACEBACK" if r["traceback"] else "LEAK" if r["leak"]
                       else f"exit {r['exit']}")
            print(f"{r['case']:30s} {verdict:10s} {r['seconds']:7.2f}s {r['peak_mb'] or '?':>5} MB names file: "
                  f"{r['names_file']!s:5s} {'exact' if r['exact'] else ''} {r['message'][:100]}")
    else:
        results["mutants"] = {}
        for fmt in args.formats.split(","):
            print(f"{fmt}: {args.mutants} mutants", flush=True)
            counts = run_format(fmt, args.mutants, args.timeout, args.memory, args.out, args.seed, args.mrc_codecs)
            results["mutants"][fmt] = dict(counts)
            print(f"{fmt}: {dict(counts)}", flush=True)
    if args.json:
        args.json.write_text(json.dumps(results, indent=1, default=str))


if __name__ == "__main__":
    main()
