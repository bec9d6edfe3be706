"""NPZ and HDF5 format version 3 (issue 26): compact by default, lossless, older versions still read."""

from __future__ import annotations

import zipfile

import h5py
import numpy as np
import pytest

from motionrep.errors import NPZFormatError
from motionrep.io import _hdf5 as hdf5_module
from motionrep.io import _npz as npz_module
from motionrep.io import format_bvh, parse_bvh, read, write, write_database
from motionrep.io._compact import channel_arrays
from motionrep.model.synthetic import humanoid_skeleton, synthetic_motion

from helpers import SHARED_DATA, mutant_outcomes, real_bvh_files, real_params

FIELDS = ("root_translation", "rotations", "joint_translations", "euler_angles", "euler_branch")


def assert_identical(a, b) -> None:
    """Every array bit for bit (lossless storage: no tolerance), the skeleton and the frame rate equal."""
    assert a.skeleton == b.skeleton and a.fps == b.fps
    for name in FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        assert (x is None) == (y is None), name
        if x is not None:
            assert np.asarray(x).dtype == np.asarray(y).dtype and np.asarray(x).tobytes() == np.asarray(y).tobytes(), name


def bvh_clip(frames: int = 40, edit=None):
    """A clip as the BVH reader gives it (its channel values are decimals), optionally with edited values."""
    text = format_bvh(synthetic_motion(humanoid_skeleton(), frames=frames, fps=30.0, seed=5))
    lines, first = _frame_lines(text)
    lines[first:] = [" ".join(f"{float(v) + 0.0:.4f}" for v in line.split()) for line in lines[first:]]
    text = "\n".join(lines) + "\n"  # 4 decimals, as motion capture software writes them
    if edit is not None:
        text = edit(text)
    return parse_bvh(text)


def _frame_lines(text: str) -> tuple[list[str], int]:
    lines = text.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("Frame Time")) + 1
    return lines, first


def with_negative_zero(text: str) -> str:
    lines, first = _frame_lines(text)
    values = lines[first + 3].split()
    values[4] = "-0.000"
    values[5] = "-0"
    lines[first + 3] = " ".join(values)
    return "\n".join(lines) + "\n"


def with_long_decimals(text: str) -> str:
    lines, first = _frame_lines(text)
    values = lines[first].split()
    values[7] = "0.12345678901234567"  # 17 digits: not a short decimal, kept as a float64 patch
    lines[first] = " ".join(values)
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("suffix", [".npz", ".h5"])
@pytest.mark.parametrize("edit", [None, with_negative_zero, with_long_decimals], ids=["plain", "-0", "17-digits"])
def test_a_bvh_clip_is_stored_as_its_channel_values_and_reads_back_bit_for_bit(tmp_path, suffix, edit):
    m = bvh_clip(edit=edit)
    compact = channel_arrays(m)
    assert compact is not None
    assert "channel_values" not in compact  # an odd value is a patch, not a reason to keep float64
    if edit is with_negative_zero:
        assert compact["channel_patches"].size >= 2 and np.all(compact["channel_patch_values"] == 0)
    if edit is with_long_decimals:
        assert 0.12345678901234567 in compact["channel_patch_values"]
    path = tmp_path / f"clip{suffix}"
    write(m, path)
    back = read(path)
    assert_identical(m, back)
    assert format_bvh(back) == format_bvh(m)  # BVH -> binary -> BVH: the same text


def test_npz_layout_version_3_is_deflated_and_has_no_redundant_arrays(tmp_path):
    m = bvh_clip()
    path = tmp_path / "clip.npz"
    write(m, path)
    with np.load(path, allow_pickle=False) as z:
        assert int(z["format_version"]) == 3
        assert {"channel_digits", "channel_deltas", "channel_patches", "channel_patch_values"} <= set(z.files)
        assert not {"rotations", "root_translation", "joint_translations", "euler_angles",
                    "euler_branch_bits"} & set(z.files)
        assert z["channel_deltas"].dtype == np.int32 and z["channel_deltas"].shape == (40, m.skeleton.num_channels)
    with zipfile.ZipFile(path) as z:
        assert {i.compress_type for i in z.infolist()} == {zipfile.ZIP_DEFLATED}
    with h5py.File(write_h5(m, tmp_path / "clip.h5"), "r") as f:
        assert int(f.attrs["format_version"]) == 3
        g = f["clips/clip"]
        assert "channel_deltas" in g and "rotations" not in g and g["channel_deltas"].compression == "gzip"


def write_h5(m, path):
    write(m, path)
    return path


@pytest.mark.parametrize("suffix", [".npz", ".h5"])
def test_a_motion_not_from_bvh_keeps_the_full_arrays(tmp_path, suffix):
    m = synthetic_motion(humanoid_skeleton(), frames=20, fps=30.0)  # no source angles: nothing to derive from
    assert channel_arrays(m) is None
    moved = bvh_clip().replace(rotations=bvh_clip().rotations[::-1].copy())  # changed since it was read
    assert channel_arrays(moved) is None
    for clip in (m, moved):
        path = tmp_path / f"c{suffix}"
        write(clip, path)
        assert_identical(clip, read(path))


def test_older_npz_versions_are_still_read(tmp_path, monkeypatch):
    m = bvh_clip()
    path = tmp_path / "v2.npz"
    with monkeypatch.context() as patch:  # the version-2 writer: full arrays, stored members
        patch.setattr(npz_module, "channel_arrays", lambda motion: None)
        patch.setattr(npz_module, "NPZ_FORMAT_VERSION", 2)
        write(m, path, compress=False)
    with np.load(path, allow_pickle=False) as z:
        assert int(z["format_version"]) == 2 and "rotations" in z.files and "channel_deltas" not in z.files
    assert_identical(m, read(path))


def test_older_hdf5_versions_are_still_read(tmp_path, monkeypatch):
    m = bvh_clip()
    path = tmp_path / "v2.h5"
    with monkeypatch.context() as patch:  # the version-2 writer
        patch.setattr(hdf5_module, "channel_arrays", lambda motion: None)
        patch.setattr(hdf5_module, "HDF5_FORMAT_VERSION", 2)
        write_database({"a": m, "b": synthetic_motion(humanoid_skeleton(), frames=5)}, path)
    with h5py.File(path, "r") as f:
        assert int(f.attrs["format_version"]) == 2 and "rotations" in f["clips/a"]
    assert_identical(m, read(path, clip="a"))


def _npz_with(tmp_path, **changes) -> str:
    path = tmp_path / "clip.npz"
    write(bvh_clip(), path)
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    for k, v in changes.items():
        if v is None:
            arrays.pop(k)
        else:
            arrays[k] = v
    bad = tmp_path / "bad.npz"
    np.savez(bad, **arrays)
    return str(bad)


C = humanoid_skeleton().num_channels


@pytest.mark.parametrize("changes, needle", [
    (dict(channel_digits=np.full(C, 13, np.int8)), "digit counts"),
    (dict(channel_digits=np.full(C, -1, np.int8)), "digit counts"),
    (dict(channel_digits=np.zeros(C - 1, np.int8)), "shape"),
    (dict(channel_patches=np.array([40 * C]), channel_patch_values=np.zeros(1)), "indices"),
    (dict(channel_patches=np.array([-1]), channel_patch_values=np.zeros(1)), "indices"),
    (dict(channel_patch_values=np.zeros(10 ** 3)), "shape"),
    (dict(channel_deltas=np.zeros((40, C + 1), np.int32)), "shape"),
    (dict(channel_deltas=np.zeros((0, C), np.int32)), "no frames"),
    (dict(channel_deltas=np.zeros((40, C), np.float64)), "integers"),
    (dict(channel_deltas=np.zeros((40, C), np.uint64)), "signed"),
    (dict(channel_digits=None), "missing"),
    (dict(channel_deltas=np.full((40, C), 2 ** 62, np.int64)), "beyond 2\\*\\*53"),
])
def test_damaged_compact_layout_is_refused(tmp_path, changes, needle):
    import re

    path = _npz_with(tmp_path, **changes)
    with pytest.raises(NPZFormatError) as info:
        read(path)
    assert info.value.path == path and "\n" not in str(info.value) and re.search(needle, str(info.value)), \
        str(info.value)


def test_a_compact_clip_beyond_the_frame_limit_is_refused_before_reading(tmp_path):
    from motionrep import limits

    path = _npz_with(tmp_path)
    with limits.override(max_frames=39), pytest.raises(NPZFormatError, match="MOTIONREP_MAX_FRAMES"):
        read(path)


@pytest.mark.parametrize("path", real_params("cmu"))
def test_real_clip_npz_is_at_most_half_its_bvh(tmp_path, path):
    m = read(path)
    out = tmp_path / "clip.npz"
    write(m, out)
    assert out.stat().st_size <= 0.5 * path.stat().st_size
    assert_identical(m, read(out))


@pytest.mark.realdata
@pytest.mark.slow
@pytest.mark.skipif(not real_bvh_files("cmu"), reason=f"real clips not found at {SHARED_DATA}")
def test_real_clips_h5_database_is_at_most_half_their_bvh(tmp_path):
    files = real_bvh_files("cmu")
    clips = {f"{p.parent.name}_{p.stem}": read(p) for p in files}
    write_database(clips, tmp_path / "db.h5")
    assert (tmp_path / "db.h5").stat().st_size <= 0.5 * sum(p.stat().st_size for p in files)
    for name, m in clips.items():
        assert_identical(m, read(tmp_path / "db.h5", clip=name))


def test_mutants_of_a_compact_npz_are_read_or_refused(tmp_path):
    """Mutants of a version-3 file in the integer layout (tests/fuzz/mutate.py): a clip or one clean error."""
    import random

    from fuzz.crafted import npz_parts
    from fuzz.mutate import npz_mutant

    write(bvh_clip(12), tmp_path / "base.npz")
    members, arrays = npz_parts(tmp_path / "base.npz")
    assert "channel_deltas.npy" in members
    outcomes = mutant_outcomes(tmp_path / "mutant.npz",
                               (npz_mutant(members, arrays, random.Random(seed)) for seed in range(300)), NPZFormatError)
    assert outcomes["refused"] > 100 and outcomes["read"] > 5  # both outcomes exercised
