"""The decoders give the same bits as the numba decoders they replaced (issue 24): .mrc files of synthetic clips
(every shipped codec and payload version, every shipped representation; tests/data/golden/, made by
make_golden.py with main's decoders at 22eeb6c) decode here to values whose SHA-256 is the one stored.

Compared bit for bit on purpose: decoding is scalar IEEE C compiled without fused multiply-add or fast-math
(setup.py) and numpy element-wise arithmetic, no BLAS, so its values are the same on any x86-64 or aarch64 CPU.
The files are stored rather than encoded again because encoding (the svd codec's LAPACK) may differ between
machines in the last bits.

One intended change since (golden.json's ``remade``): the svd decoder blends the frames it decodes instead of
decoding interpolated coefficients at every time (2026-12-07, issue 24), so the svd files' digests at times between
frames were made again; their frames (``features_frames``) and ``decompress`` kept the numba decoders' digests.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

GOLDEN = Path(__file__).resolve().parent / "data" / "golden"
_spec = importlib.util.spec_from_file_location("make_golden", GOLDEN / "make_golden.py")
make_golden = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(make_golden)
FILES = json.loads((GOLDEN / "golden.json").read_text())["files"]


@pytest.mark.parametrize("name", sorted(FILES))
def test_decodes_are_the_stored_bits(name):
    assert make_golden.decodes((GOLDEN / f"{name}.mrc").read_bytes()) == FILES[name]



def test_decoding_imports_no_numba():
    """Every decoder of the files above (codec decoders, the pose plan, motionrep.open, decompress) runs without
    numba: decoding does not import it (issue 24)."""
    import subprocess
    import sys

    code = ("import sys, importlib.util\n"
            f"spec = importlib.util.spec_from_file_location('g', {str(GOLDEN / 'make_golden.py')!r})\n"
            "g = importlib.util.module_from_spec(spec); spec.loader.exec_module(g)\n"
            f"for name in {sorted(FILES)!r}:\n"
            f"    g.decodes(open({str(GOLDEN)!r} + '/' + name + '.mrc', 'rb').read())\n"
            "print('numba' in sys.modules)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "False"
