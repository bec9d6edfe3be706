"""Mutated .mrc, NPZ and HDF5 files (``tests/fuzz/mutate.py``; hypothesis picks the mutations) give a clip or
motionrep's own error naming the file -- never another exception, a hang, bytes from outside the file, or an
allocation beyond the limits.  Bounded to a few seconds per format; ``tests/fuzz/run.py`` runs 100,000 of each.
"""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motionrep import Motion, limits
from motionrep.pipeline.compress import decompress, describe_outcome
from motionrep.io.container import unpack
from motionrep.errors import ContainerError, FormatError, MotionrepError
from motionrep.io import format_bvh, parse_bvh, read, write

from fuzz.crafted import SECRET, mrc_parts, npz_parts, small_motion, write_v1_hdf5
from fuzz.mutate import SECRET_VALUE, h5_mutant, mrc_mutant, npz_mutant

SEEDS = st.integers(0, 2 ** 32 - 1)
FUZZ = settings(deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow,
                                                                       HealthCheck.function_scoped_fixture])
# Small limits while fuzzing: a mutant that slipped past a check would show as an allocation far beyond them.
SMALL = dict(max_frames=100_000, max_clip_bytes=32 << 20, max_metadata_bytes=1 << 20, read_timeout=10)


def _no_leak(motion) -> None:
    if isinstance(motion, Motion):
        for a in (motion.rotations, motion.root_translation, motion.joint_translations):
            assert not np.any(a == SECRET_VALUE), "a value from outside the file was read"
            assert SECRET[:16] not in a.tobytes()


def _check(read_it, path: str) -> None:
    try:
        item = read_it()
    except FormatError as exc:
        assert exc.path == path, exc
        assert "\n" not in str(exc)
        return
    except MotionrepError as exc:  # a plugin-level error (unknown codec...) must still name the file
        assert path in str(exc), exc
        return
    _no_leak(item)


@pytest.fixture(scope="module", params=["svd", "transform", "adaptive-fourier"])
def mrc_base(request):
    return mrc_parts(codec=request.param)


@settings(FUZZ, max_examples=100)
@given(seed=SEEDS)
def test_mutated_mrc_gives_a_container_or_a_container_error(mrc_base, seed):
    meta, payload = mrc_base
    data = mrc_mutant(meta, payload, random.Random(seed))
    with limits.override(**SMALL):
        try:
            c = unpack(data, "fuzz.mrc")
        except ContainerError as exc:
            assert exc.path == "fuzz.mrc" and "\n" not in str(exc)
            return
        # what readers of a container rely on holds
        assert isinstance(c.codec, str) and isinstance(c.num_frames, int) and c.num_frames >= 1 and c.fps > 0
        assert c.evaluation is None or isinstance(c.evaluation["max_error"], float | int)
        # its outcome can be described (motionrep info) and it decodes, or the error names the file
        describe_outcome(c, detail=True)
        _check(lambda: decompress(c, path="fuzz.mrc"), "fuzz.mrc")


@pytest.mark.parametrize("seed", [1056, 6360, 8616, 10548, 11916])
def test_payloads_that_decode_to_no_motion_name_the_file(seed):
    """Found by tests/fuzz/run.py: svd payloads whose features are NaN or give quaternions of norm 1e22 were a
    ValidationError without the file (in version-1 files, the version they were found in)."""
    data = mrc_mutant(*mrc_parts(version=1), random.Random(seed))
    with limits.override(**SMALL), pytest.raises(ContainerError, match="cannot decode this payload") as info:
        decompress(unpack(data, "fuzz.mrc"), path="fuzz.mrc")
    assert info.value.path == "fuzz.mrc"


@pytest.fixture(scope="module")
def npz_base(tmp_path_factory):
    d = tmp_path_factory.mktemp("npz")
    m = parse_bvh(format_bvh(small_motion(12)))
    write(m, d / "base.npz")
    return npz_parts(d / "base.npz")


@settings(FUZZ, max_examples=150)
@given(seed=SEEDS)
def test_mutated_npz_gives_a_motion_or_an_npz_error(npz_base, tmp_path_factory, seed):
    members, arrays = npz_base
    path = tmp_path_factory.mktemp("n", numbered=True) / "fuzz.npz"
    path.write_bytes(npz_mutant(members, arrays, random.Random(seed)))
    with limits.override(**SMALL):
        _check(lambda: read(path), str(path))


@pytest.fixture(scope="module")
def h5_base(tmp_path_factory):
    d = tmp_path_factory.mktemp("h5")
    m = parse_bvh(format_bvh(small_motion(12)))
    write(m, d / "v2.h5", clip="clip")
    write_v1_hdf5(m, d / "v1.h5", clip="clip")
    return [(d / "v2.h5").read_bytes(), (d / "v1.h5").read_bytes()], d


@settings(FUZZ, max_examples=60)
@given(seed=SEEDS)
def test_mutated_hdf5_gives_a_motion_or_an_hdf5_error(h5_base, tmp_path_factory, seed):
    bases, secret_dir = h5_base
    path = Path(tmp_path_factory.mktemp("h", numbered=True)) / "fuzz.h5"
    h5_mutant(path, bases, random.Random(seed), secret_dir)
    with limits.override(**SMALL):
        _check(lambda: read(path), str(path))
