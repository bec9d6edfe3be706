"""The front door (``motionrep/__init__.py``): the main verbs as library functions, light to import, and typed
for static checkers (a ``TYPE_CHECKING`` block beside the lazy imports)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest

import motionrep
from motionrep.model.synthetic import chain_skeleton, synthetic_motion

REPO = Path(__file__).resolve().parent.parent


def test_the_verbs_compress_decompress_evaluate_and_open(tmp_path):
    motion = synthetic_motion(chain_skeleton(4), frames=30, fps=30, seed=1)
    result = motionrep.compress(motion, "svd", max_error="1%")
    assert result.report.max_error_percent <= 1.0 and isinstance(result.data, bytes)
    back = motionrep.decompress(result.data)
    assert isinstance(back, motionrep.Motion) and back.num_frames == 30
    path = tmp_path / "m.mrc"
    path.write_bytes(result.data)
    again = motionrep.decompress(path)
    np.testing.assert_array_equal(again.rotations, back.rotations)  # the same bytes decoded: equal bit for bit
    report = motionrep.evaluate(motion, back)
    assert report.max_error == result.report.max_error  # the error stored is the error measured again
    assert motionrep.decompress(result.data, fps=15).num_frames == 15
    clip = motionrep.open(path)
    assert clip.positions([0.0]).shape[0] == 1


def test_importing_motionrep_stays_light():
    code = "import sys, motionrep; print(sorted(m for m in ('numpy', 'click', 'typing') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_an_old_module_name_that_is_a_verb_leaves_the_verb_in_place():
    """``motionrep.compress`` and ``motionrep.evaluate`` were modules (now motionrep.pipeline.*): importing the
    old names still gives the modules, and the package's names stay the verbs."""
    import importlib

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        module = importlib.import_module("motionrep.compress")
        from motionrep.evaluate import ErrorReport  # noqa: F401 - the old module still answers
    assert module.__name__ == "motionrep.pipeline.compress"
    assert callable(motionrep.compress) and motionrep.compress.__module__ == "motionrep"
    assert callable(motionrep.evaluate) and motionrep.evaluate.__module__ == "motionrep"


USER_SCRIPT = """
    import motionrep

    m = motionrep.read("walk.bvh")
    r = motionrep.compress(m, "svd", max_error="2%")
    back = motionrep.decompress(r.data)
    report = motionrep.evaluate(m, back)
    clip = motionrep.open(r.data)
    reveal_type(m)
    reveal_type(r)
    reveal_type(back)
    reveal_type(report)
    reveal_type(clip)
    reveal_type(motionrep.compress)
    reveal_type(motionrep.decompress)
    reveal_type(motionrep.evaluate)
    reveal_type(motionrep.open)
    reveal_type(motionrep.read)
"""


def test_type_checkers_see_real_types_through_the_front_door(tmp_path):
    """mypy on a small user script: every revealed type of the public functions and of what they return is a
    real type (no ``Any``), seen through ``import motionrep`` (whose names are imported lazily at run time)."""
    pytest.importorskip("mypy")
    script = tmp_path / "user.py"
    script.write_text(textwrap.dedent(USER_SCRIPT), encoding="utf-8")
    run = subprocess.run([sys.executable, "-m", "mypy", "--follow-imports=silent", "--no-incremental",
                          "--cache-dir", os.devnull, "--no-error-summary", str(script)],
                         capture_output=True, text=True, cwd=tmp_path, env=dict(os.environ, MYPYPATH=str(REPO)))
    revealed = re.findall(r'Revealed type is "(.*)"', run.stdout)
    assert len(revealed) == USER_SCRIPT.count("reveal_type("), run.stdout + run.stderr
    expected = ["motionrep.model._pose.Motion", "motionrep.pipeline.compress.CompressResult",
                "motionrep.model._pose.Motion", "motionrep.pipeline.evaluate.ErrorReport",
                "motionrep.pipeline.runtime.Clip"]
    assert revealed[:5] == expected, revealed
    for text in revealed:
        assert "Any" not in text, text
    assert ": error:" not in run.stdout, run.stdout
