"""Every real clip decodes to the same bits here as with another checkout's decoders (issue 24: the numba decoders
of main replaced by C): each clip of ``../shared/data`` is compressed with ``transform`` and ``svd`` at 2 % by the
other checkout's interpreter (so that the files are that checkout's), then both interpreters decode every file
and the SHA-256 of what they give is compared: the features at the frames and at random times, ``decompress``,
``motionrep.open``'s poses (float64 and float32) and single poses (``tests/data/golden/make_golden.py``,
``decodes``), and the bytes of the decoded motion written as BVH (Euler angles and the writer).

    python benchmarks/decode_identity.py [--against /work/main/.venv/bin/python] [--codecs transform svd]

Writes ``benchmarks/results/decode_identity.md`` (and ``.json``). The .mrc files are made in a temporary
directory and not kept (they are derived from the shared clips).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
RESULTS = REPO / "benchmarks" / "results"
DATA = Path(os.environ.get("MOTIONREP_SHARED_DATA", REPO.parent / "shared" / "data"))
AGAINST = REPO.parent.parent / "main" / ".venv" / "bin" / "python"

_CHILD = r"""
import importlib.util, json, sys
from pathlib import Path
spec = importlib.util.spec_from_file_location("g", sys.argv[1])
g = importlib.util.module_from_spec(spec)
spec.loader.exec_module(g)
mode, folder, data = sys.argv[2], Path(sys.argv[3]), Path(sys.argv[4])
codecs = sys.argv[5].split(",")
out = {}
if mode == "make":
    from motionrep.io import read
    from motionrep.pipeline.compress import compress_motion
    for bvh in sorted(p for p in data.rglob("*.bvh") if "malformed" not in p.parts):
        name = str(bvh.relative_to(data)).replace("/", "__")
        try:
            motion = read(bvh)
        except Exception as exc:
            out[name] = f"unreadable: {type(exc).__name__}"
            continue
        for codec in codecs:
            try:
                (folder / f"{name}.{codec}.mrc").write_bytes(compress_motion(motion, codec, max_error="2%").data)
            except Exception as exc:
                out[f"{name}.{codec}.mrc"] = f"not encoded: {type(exc).__name__}: {exc}"
import hashlib, tempfile
from motionrep.io import write
from motionrep.io.container import unpack
from motionrep.pipeline.decode import decompress
bvh = Path(tempfile.mkdtemp()) / "decoded.bvh"
for path in sorted(folder.glob("*.mrc")):
    try:
        out[path.name] = g.decodes(path.read_bytes())
        # the decoded motion written as BVH (Euler angles from the quaternions, then the writer): its bytes
        write(decompress(unpack(path.read_bytes())), bvh)
        out[path.name]["bvh"] = hashlib.sha256(bvh.read_bytes()).hexdigest()
    except Exception as exc:
        out[path.name] = f"error {type(exc).__name__}: {exc}"
out["numba imported"] = "numba" in sys.modules
print(json.dumps(out))
"""


def _run(python: str, mode: str, folder: Path, codecs: list[str]) -> dict:
    done = subprocess.run([python, "-c", _CHILD, str(REPO / "tests" / "data" / "golden" / "make_golden.py"), mode,
                           str(folder), str(DATA), ",".join(codecs)], capture_output=True, text=True,
                          cwd=tempfile.gettempdir())
    if done.returncode:
        raise SystemExit(f"{python} {mode} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--against", default=str(AGAINST))
    parser.add_argument("--codecs", nargs="*", default=["transform", "svd"])
    args = parser.parse_args(argv)
    if not DATA.is_dir():
        raise SystemExit(f"no real clips at {DATA}")
    start, load = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        theirs = _run(args.against, "make", Path(tmp), args.codecs)
        ours = _run(sys.executable, "decode", Path(tmp), args.codecs)
    files = sorted(k for k in theirs if k.endswith(".mrc") and isinstance(theirs[k], dict))
    same = [k for k in files if ours.get(k) == theirs[k]]
    differ = sorted(set(files) - set(same))
    doc = {"date": start, "load": round(load, 2), "against": args.against, "codecs": args.codecs,
           "files": len(files), "identical": len(same), "differ": differ,
           "not_encoded": sorted(k for k, v in theirs.items() if isinstance(v, str) and k != "numba imported"),
           "numba_imported_here": ours["numba imported"], "numba_imported_there": theirs["numba imported"]}
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "decode_identity.json").write_text(json.dumps(doc, indent=1) + "\n")
    md = [f"# Decoding identity on the real clips ({start}, load {doc['load']})", "",
          f"Every real clip of `../shared/data` compressed at 2 % with {', '.join(args.codecs)} by `{args.against}`, "
          "then decoded by it and by this checkout: the SHA-256 of the features at the frames and at 700 random "
          "times, of `decompress`, of `motionrep.open`'s poses (float64, float32), of 40 single poses "
          "(`tests/data/golden/make_golden.py`) and of the decoded motion written as BVH (the Euler angles of "
          "its quaternions and the writer).", "",
          f"- files: {doc['files']}; **identical: {doc['identical']}**; different: {len(differ)}"
          + (f" ({', '.join(differ)})" if differ else ""),
          f"- not encoded (the codec refused the clip there): {len(doc['not_encoded'])}",
          f"- numba imported while decoding: here {'yes' if doc['numba_imported_here'] else 'no'}, "
          f"there {'yes' if doc['numba_imported_there'] else 'no'}", ""]
    (RESULTS / "decode_identity.md").write_text("\n".join(md))
    print("\n".join(md))


if __name__ == "__main__":
    main()
