"""Sizes of the binary formats against BVH text (issue 26): each real clip as ``.npz``, all of them in one ``.h5``
database, both read back and checked bit for bit.

    python benchmarks/sizes.py                    # the CMU clips of ../shared/data/cmu
    python benchmarks/sizes.py DIR_OR_FILE ...    # other clips

Writes ``benchmarks/results/sizes.json`` and ``sizes.md``.  Targets: ``.npz`` <= 0.5x the BVH file, the ``.h5``
database <= 0.5x the BVH files together, every array of every clip read back identical.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from motionrep.io import read, write, write_database  # noqa: E402

_FIELDS = ("root_translation", "rotations", "joint_translations", "euler_angles", "euler_branch")


def _same(a, b) -> bool:
    """Every array and the skeleton identical, bit for bit."""
    if a.skeleton != b.skeleton or a.fps != b.fps:
        return False
    for name in _FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        if (x is None) != (y is None) or (x is not None and np.asarray(x).tobytes() != np.asarray(y).tobytes()):
            return False
    return True


def main() -> None:
    args = [Path(a) for a in sys.argv[1:]] or [HERE.parent.parent / "shared" / "data" / "cmu"]
    files = sorted(p for a in args for p in ([a] if a.is_file() else a.rglob("*.bvh")) if "malformed" not in p.parts)
    if not files:
        sys.exit(f"no BVH files under {', '.join(map(str, args))}")
    work = Path(tempfile.mkdtemp(prefix="sizes-"))
    rows, clips = [], {}
    start = time.monotonic()
    for path in files:
        m = read(path)
        out = work / "clip.npz"
        write(m, out)
        with np.load(out, allow_pickle=False) as z:
            compact = "channel_deltas" in z.files
        rows.append({"clip": str(path.relative_to(path.parents[1])), "frames": m.num_frames, "joints": m.num_joints,
                     "bvh_bytes": path.stat().st_size, "npz_bytes": out.stat().st_size,
                     "npz_ratio": round(out.stat().st_size / path.stat().st_size, 3), "compact_integers": compact,
                     "lossless": _same(m, read(out))})
        name = path.stem
        while name in clips:
            name += "_"
        clips[name] = m
    db = work / "clips.h5"
    write_database(clips, db)
    lossless_h5 = all(_same(m, read(db, clip=name)) for name, m in clips.items())
    bvh_total = sum(r["bvh_bytes"] for r in rows)
    result = {
        "clips": len(rows), "bvh_bytes": bvh_total, "npz_bytes": sum(r["npz_bytes"] for r in rows),
        "npz_ratio_max": max(r["npz_ratio"] for r in rows), "npz_ratio_total": round(
            sum(r["npz_bytes"] for r in rows) / bvh_total, 3),
        "h5_bytes": db.stat().st_size, "h5_ratio": round(db.stat().st_size / bvh_total, 3),
        "lossless_npz": all(r["lossless"] for r in rows), "lossless_h5": lossless_h5,
        "seconds": round(time.monotonic() - start, 1), "load": [round(x, 2) for x in os.getloadavg()], "rows": rows,
    }
    for p in work.iterdir():
        p.unlink()
    work.rmdir()
    results = HERE / "results"
    (results / "sizes.json").write_text(json.dumps(result, indent=1) + "\n")
    lines = ["# Sizes of NPZ and HDF5 against BVH (benchmarks/sizes.py)", "",
             f"{result['clips']} clips, {bvh_total:,} bytes of BVH text; NPZ and HDF5 format version 3. "
             f"Targets: each `.npz` <= 0.5x its BVH, the `.h5` database <= 0.5x the BVH files, lossless.", "",
             f"- `.npz`: {result['npz_bytes']:,} bytes in all ({result['npz_ratio_total']}x), largest ratio "
             f"{result['npz_ratio_max']}x; every array read back bit for bit: {result['lossless_npz']}",
             f"- `.h5` database of all clips: {result['h5_bytes']:,} bytes ({result['h5_ratio']}x); every array read "
             f"back bit for bit: {result['lossless_h5']}", "",
             "| clip | frames | joints | BVH bytes | NPZ bytes | ratio | decimal integers |", "|---|---|---|---|---|---|---|"]
    lines += [f"| {r['clip']} | {r['frames']} | {r['joints']} | {r['bvh_bytes']:,} | {r['npz_bytes']:,} | "
              f"{r['npz_ratio']} | {'yes' if r['compact_integers'] else 'no (float64 channel values)'} |" for r in rows]
    (results / "sizes.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines[:7]))


if __name__ == "__main__":
    main()
