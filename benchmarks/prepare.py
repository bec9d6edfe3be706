"""Where preparing a ``transform`` clip goes (issue 24: ``codec.decoder(payload)`` >= 1 M frames/s).

One CMU-31 clip (default ``bvh11/131_01``) compressed with ``transform`` at 2 % in each representation; for each
payload:

* the decisions its integers cost in payload versions 2 and 3, by kind (counted from the integers, as
  ``plugins/motionrep_transform/_c/mrcoder.c`` codes them): the detail coefficients' zero flags, signs, unary bit
  lengths, the two modelled mantissa bits and the raw ones, and the side information (active flags, exponents,
  the approximation);
* times, best of ``--repeat`` (wall clock; the 1-minute load average is recorded), in one process: the whole
  prepare ``codec.decoder(payload)`` of payload versions 1, 2 and 3; the C decoder alone (``_cdecode.decode``,
  the difference is Python); the integers alone, feature-major as the prepare decodes them, by the decoder's own
  loop and by the generic loop it replaced (``_ccoder.decode(..., reference=True)``: the same integers); the
  rest of a prepare (dequantisation, inverse wavelet, allocations) as the difference.

Usage::

    python benchmarks/prepare.py [--clip bvh11/131_01] [--repeat 200] [--out benchmarks/results/prepare.md]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPRESENTATIONS = ("root-quat-axis-angle", "euler", "ortho6d", "dual-quaternion")


def decisions(q) -> dict[str, int]:
    """The binary decisions of payload versions 2 and 3 for the integers of ``q``, by kind."""
    coef = np.concatenate([np.asarray(c, np.int64) for c in q.coefficients])
    rows = len(q.coefficients[0])
    active = np.any(coef != 0, axis=0)

    def sint(values: np.ndarray) -> tuple[int, int]:  # (decisions, of which raw): code_sint
        nz = np.abs(values[values != 0])
        n = np.floor(np.log2(nz)).astype(np.int64) + 1 if nz.size else np.zeros(0, np.int64)
        return int(values.size + nz.size + n.sum() + np.minimum(2, n - 1).sum() + np.maximum(0, n - 3).sum()), \
            int(np.maximum(0, n - 3).sum())

    detail = coef[rows:, active]
    nz = np.abs(detail[detail != 0])
    n = np.floor(np.log2(nz)).astype(np.int64) + 1
    a = coef[:rows, active]
    approx, approx_raw = sint(np.concatenate([a[:1], np.diff(a, axis=0)]).ravel())
    fexp = np.asarray(q.feature_exponents)[active]
    side, side_raw = sint(np.concatenate([fexp[:1], np.diff(fexp)]))
    rexp = np.asarray(q.region_exponents)
    r, r_raw = sint(np.concatenate([rexp[:1], np.diff(rexp)]))
    return {"zero flags": int(detail.size), "signs": int(nz.size), "unary lengths": int(n.sum()),
            "modelled mantissa bits": int(np.minimum(2, n - 1).sum()), "raw mantissa bits": int(np.maximum(0, n - 3).sum()),
            "approximation": approx, "exponents and active flags": side + r + int(q.num_features),
            "(raw bits of the side information)": approx_raw + side_raw + r_raw}


def _best(fn, repeat: int) -> float:
    fn()
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def measure(clip: str, repeat: int) -> tuple[list[dict], float, float]:
    from motionrep.pipeline.compress import compress_motion
    from motionrep.plugin.codec import Payload
    from motionrep.plugin.registry import get_codec
    from motionrep_transform import _ccoder, _cdecode, _stream, _stream2

    sys.path.insert(0, str(HERE))
    from speed import _read

    motion, _ = _read(clip, True)
    codec = get_codec("transform")
    load_start = os.getloadavg()[0]
    out = []
    for rep in REPRESENTATIONS:
        container = compress_motion(motion, "transform", representation=rep, seed=0, max_error="2%").container
        q = _stream2.unpack(np.asarray(container.arrays["data"]).tobytes(), container.codec_version)
        F, D = q.num_frames, q.num_features
        row = {"representation": rep, "frames": F, "features": D,
               "active": int(np.any(np.concatenate(q.coefficients) != 0, axis=0).sum()), "decisions": decisions(q)}
        for version in (1, 2, 3):
            data = _stream.pack(q) if version == 1 else _stream2.pack(q, version)
            arr = np.frombuffer(data, np.uint8)
            payload = Payload(arrays={"data": arr}, info=container.info, version=version)
            row[f"v{version} bytes"] = len(data)
            row[f"v{version} prepare"] = _best(lambda: codec.decoder(payload), repeat)
            row[f"v{version} C decode"] = _best(lambda: _cdecode.decode(arr, version), repeat)
            if version > 1:
                fexp, rexp, coef = np.empty(D, np.int64), np.empty(-(-F // q.region_frames), np.int64), np.empty(F * D, np.int64)
                for name, reference in (("integers", False), ("integers, generic loop", True)):
                    row[f"v{version} {name}"] = _best(
                        lambda: _ccoder.decode(data, fexp, rexp, coef, version, True, reference), repeat)
        out.append(row)
    return out, load_start, os.getloadavg()[0]


def report(rows: list[dict], clip: str, repeat: int, loads: tuple[float, float]) -> str:
    us = lambda s: f"{1e6 * s:.0f}"  # noqa: E731
    md = [f"# Preparing a transform clip (issue 24), {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}", "",
          f"`python benchmarks/prepare.py --clip {clip} --repeat {repeat}`: the clip at 2 % in each representation, "
          f"best of {repeat}, wall clock, one process; load average {loads[0]:.2f} at the start, {loads[1]:.2f} at "
          "the end (2 CPUs, shared). Times in microseconds; M frames/s = frames / prepare.", "",
          "## Decisions of payload versions 2 and 3, by kind", "",
          "| representation | frames x features (active) | " + " | ".join(rows[0]["decisions"]) + " |",
          "|---|---|" + "---:|" * len(rows[0]["decisions"])]
    for r in rows:
        md.append(f"| {r['representation']} | {r['frames']} x {r['features']} ({r['active']}) | "
                  + " | ".join(f"{v:,}" for v in r["decisions"].values()) + " |")
    md += ["", "## Where a prepare goes", "",
           "| representation | version | bytes | prepare | M frames/s | Python | integers | integers, generic loop | "
           "rest (dequantise, inverse wavelet, allocations) |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        for v in (1, 2, 3):
            p, c = r[f"v{v} prepare"], r[f"v{v} C decode"]
            ints = r.get(f"v{v} integers")
            md.append(f"| {r['representation']} | {v} | {r[f'v{v} bytes']} | {us(p)} | {r['frames'] / p / 1e6:.2f} | "
                      f"{us(p - c)} | {us(ints) if ints else '-'} | "
                      f"{us(r[f'v{v} integers, generic loop']) if ints else '-'} | {us(c - ints) if ints else '-'} |")
    return "\n".join(md) + "\n"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--clip", default="bvh11/131_01")
    ap.add_argument("--repeat", type=int, default=200)
    ap.add_argument("--out", type=Path, default=HERE / "results" / "prepare.md")
    args = ap.parse_args(argv)
    rows, start, end = measure(args.clip, args.repeat)
    text = report(rows, args.clip, args.repeat, (start, end))
    args.out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
