"""Nothing silent (issue 24): a process about to compile kernels that numba's cache does not hold says so in one
line on stderr, once, and a run that finds them cached says nothing (no shipped command compiles any: they are C;
``motionrep.jit`` serves third-party plugins); a codec's internal diagnostics (the
transform codec's ``bisect regions=...``) reach stderr only with ``compress --verbose``, through the progress
callback (the plugin never prints)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from motionrep.cli._common import CodecProgress
from motionrep.plugin.codec import describe_progress
from motionrep.io import write
from motionrep.jit import COMPILE_NOTICE
from motionrep.model.synthetic import humanoid_skeleton, synthetic_motion

from helpers import run_cli_caught

REPO = Path(__file__).resolve().parent.parent


def _env(tmp_path: Path, cache: Path, *extra: Path) -> dict[str, str]:
    env = dict(os.environ)
    path = [str(p) for p in extra] + [str(REPO), str(REPO / "plugins")]
    env["PYTHONPATH"] = os.pathsep.join(path + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    env["NUMBA_CACHE_DIR"] = str(cache)
    env.pop("MOTIONREP_COMPILE_NOTICE", None)  # an in-process --quiet of an earlier test sets it
    return env


def test_a_cold_cache_is_announced_once_and_a_warm_one_not(tmp_path):
    """A kernel of its own (a module in tmp_path), so the test compiles one small function, not motionrep's."""
    (tmp_path / "startup_kernels.py").write_text(textwrap.dedent("""
        from motionrep.jit import jit

        @jit
        def add_one(x):
            return x + 1.0

        @jit
        def twice(x):
            return 2.0 * x
    """))
    code = "import startup_kernels as k; assert k.add_one(1.0) == 2.0; assert k.twice(2.0) == 4.0"
    env = _env(tmp_path, tmp_path / "numba-cache", tmp_path)
    first = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    assert first.stderr.splitlines().count(COMPILE_NOTICE) == 1, first.stderr  # two kernels compiled, one line
    second = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert second.returncode == 0, second.stderr
    assert COMPILE_NOTICE not in second.stderr  # loaded from the cache the first run wrote
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "another-cache")  # another machine, or a cleared cache
    third = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert COMPILE_NOTICE in third.stderr
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "a-third-cache")
    env["MOTIONREP_COMPILE_NOTICE"] = "0"  # what --quiet sets
    kept = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert kept.returncode == 0 and COMPILE_NOTICE not in kept.stderr


def test_a_process_that_compiles_nothing_says_nothing(tmp_path):
    env = _env(tmp_path, tmp_path / "empty-cache")
    walk = tmp_path / "walk.bvh"
    write(synthetic_motion(humanoid_skeleton(), frames=20, fps=30.0), walk)
    done = subprocess.run([sys.executable, "-m", "motionrep", "info", str(walk)], capture_output=True, text=True,
                          env=env)
    assert done.returncode == 0, done.stderr
    assert COMPILE_NOTICE not in done.stderr  # info reads BVH with the compiled core (C): no kernel, no notice
    assert not (tmp_path / "empty-cache").exists() or not any((tmp_path / "empty-cache").iterdir())


@pytest.mark.slow
def test_compress_with_every_shipped_codec_compiles_nothing(tmp_path):
    """Every shipped encoder and decoder is C (or numpy, scipy, torch-free Python): compressing with each codec on
    an empty numba cache imports no numba, so it has nothing to announce and ``--quiet`` leaves stderr empty."""
    env = _env(tmp_path, tmp_path / "numba-cache")
    walk = tmp_path / "walk.bvh"
    write(synthetic_motion(humanoid_skeleton(), frames=60, fps=30.0), walk)
    code = ("import sys\nfrom motionrep.cli import main\ntry:\n    main(sys.argv[1:])\nexcept SystemExit as e:\n"
            "    assert not e.code, e.code\nprint('NUMBA', 'numba' in sys.modules)")
    for codec in ("transform", "svd", "naive-fourier", "adaptive-fourier"):
        cmd = [sys.executable, "-c", code, "compress", str(walk), "-o", str(tmp_path / f"{codec}.mrc"), "--codec",
               codec, "--force", "--quiet"]
        done = subprocess.run(cmd, capture_output=True, text=True, env=env)
        assert done.returncode == 0, done.stderr
        assert done.stderr == "" and done.stdout.split("NUMBA", 1)[1].split() == ["False"], (codec, done.stderr)
    assert not (tmp_path / "numba-cache").exists() or not any((tmp_path / "numba-cache").iterdir())


@pytest.fixture
def walk(tmp_path) -> Path:
    path = tmp_path / "walk.bvh"
    write(synthetic_motion(humanoid_skeleton(), frames=60, fps=30.0), path)
    return path


def test_bisect_lines_only_with_verbose(tmp_path, walk):
    plain = run_cli_caught("compress", str(walk), "-o", str(tmp_path / "a.mrc"))
    assert plain.exit_code == 0, plain.output
    assert "bisect regions=" not in plain.output and "settle regions=" not in plain.output
    assert "wrote" in plain.output
    verbose = run_cli_caught("compress", str(walk), "-o", str(tmp_path / "b.mrc"), "--verbose")
    assert verbose.exit_code == 0, verbose.output
    assert "bisect regions=" in verbose.output and "settle regions=" in verbose.output
    assert "diagnostic" not in verbose.output  # the marker is not shown as a field
    assert (tmp_path / "a.mrc").read_bytes() == (tmp_path / "b.mrc").read_bytes()  # --verbose changes no result


def test_the_transform_codec_reports_its_diagnostics_through_the_callback(walk):
    from motionrep.pipeline.compress import compress_motion
    from motionrep.io import read

    seen = []
    compress_motion(read(walk), "transform", max_error="2%",
                    progress=lambda stage, fields: seen.append((stage, dict(fields))))
    stages = {stage: fields for stage, fields in seen}
    assert stages["bisect"]["diagnostic"] is True and stages["settle"]["diagnostic"] is True


def test_codec_progress_hides_diagnostics_unless_verbose(capsys):
    class Codec:
        def describe_progress(self, stage, fields):
            return describe_progress(stage, fields)

    CodecProgress(Codec())("bisect", {"regions": 3, "diagnostic": True})
    CodecProgress(Codec())("train", {"K": 2})
    assert capsys.readouterr().err == "  train K=2\n"
    CodecProgress(Codec(), verbose=True)("bisect", {"regions": 3, "diagnostic": True})
    assert capsys.readouterr().err == "  bisect regions=3\n"


_KERNELS_LOADED = """
import gc, sys
from motionrep.cli import main
from motionrep.jit import LazyKernel
try:
    main(sys.argv[1:])
except SystemExit as exc:
    assert not exc.code, exc.code
names = sorted(k.py_func.__qualname__ for k in gc.get_objects()
               if isinstance(k, LazyKernel) and k._dispatcher is not None and "inline" not in k._options)
print("KERNELS", " ".join(names + ["numba-imported"] * ("numba" in sys.modules)))
"""


def _kernels_loaded(tmp_path: Path, *args) -> list[str]:
    env = _env(tmp_path, tmp_path / "numba-cache")
    env.pop("NUMBA_CACHE_DIR")  # the tree's own cache: warm after the first run
    done = subprocess.run([sys.executable, "-c", _KERNELS_LOADED, *map(str, args)], capture_output=True, text=True,
                          env=env)
    assert done.returncode == 0, done.stderr
    return done.stdout.split("KERNELS", 1)[1].split()


def test_commands_load_only_the_kernels_they_need(tmp_path, walk):
    """``info`` of a BVH file runs no numba kernel (the compiled core, C, reads it); ``decompress`` to BVH none
    either and does not even import numba (the decoders and the pose plan are C, BVH writing is scipy's Euler
    conversion and the C writer): a
    regression here costs numba's start-up (about half a second quiet) or a kernel's cached code."""
    mrc = tmp_path / "walk.mrc"
    assert run_cli_caught("compress", str(walk), "-o", str(mrc)).exit_code == 0
    assert _kernels_loaded(tmp_path, "info", walk) == []
    assert _kernels_loaded(tmp_path, "info", mrc) == []
    assert _kernels_loaded(tmp_path, "decompress", mrc, "-o", tmp_path / "out.bvh") == []
    assert _kernels_loaded(tmp_path, "compress", walk, "-o", tmp_path / "again.mrc") == []


def test_info_of_a_compact_hdf5_clip_imports_no_numba(tmp_path, walk):
    """A compact HDF5 clip (channels stored as integers) is decoded by the BVH reader's compiled conversion (C), so
    ``info`` imports neither numba nor scipy (it did, through the compiled Euler conversion), and it is the very
    clip that was written, bit for bit."""
    from motionrep.io import read

    h5 = tmp_path / "walk.h5"
    write(read(walk), h5)
    code = ("import sys\nfrom motionrep.cli import main\ntry:\n    main(['info', %r])\nexcept SystemExit as e:\n"
            "    assert not e.code\nprint('TOPS', ' '.join(sorted({m.split('.')[0] for m in sys.modules})))" % str(h5))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=_env(tmp_path, tmp_path))
    assert done.returncode == 0, done.stderr
    assert not set(done.stdout.split("TOPS", 1)[1].split()) & {"numba", "scipy", "h5py"}
    a, b = read(walk), read(h5)
    for name in ("root_translation", "rotations", "joint_translations", "euler_angles", "euler_branch"):
        assert getattr(a, name).tobytes() == getattr(b, name).tobytes(), name
