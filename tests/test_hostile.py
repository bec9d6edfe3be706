"""Hostile and damaged files (issue 14): every crafted case of ``tests/fuzz/crafted.py`` gets one line naming the
file, exit code 1 and no output (or, for the lossless cases, exactly the source's values); the limits, the HDF5
watchdog, old format versions, and the lossless BVH writer."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from motionrep import Motion, Skeleton, limits
from motionrep.errors import BVHFormatError, FormatError, HDF5FormatError, NPZFormatError, ValidationError
from motionrep.io import format_bvh, parse_bvh, read, write
from motionrep.io._bvh import channel_values
from motionrep.io._h5read import shutdown_worker
from motionrep.model.synthetic import chain_skeleton, synthetic_motion

from fuzz.crafted import build, check_leak, small_motion, write_v1_hdf5
from helpers import run_cli_caught


@pytest.fixture(scope="module")
def crafted(tmp_path_factory):
    directory = tmp_path_factory.mktemp("crafted")
    return {c.name: c for c in build(directory)}


CASE_NAMES = [c for c in [
    "h5-external-storage", "h5-external-link", "h5-soft-link-loop", "h5-soft-link-dataset", "h5-virtual-dataset",
    "h5-declared-1e9-frames", "h5-unknown-filter", "h5-damaged-spin", "h5-flipped-data-byte",
    "npz-header-2^33-frames", "npz-damaged-npy-header", "npz-pickled-member", "npz-short-member",
    "mrc-num-frames-1e6", "mrc-num-frames-1e7", "mrc-metadata-inflation", "mrc-deep-json", "mrc-shape-1e30",
    "mrc-evaluation-list", "mrc-omega-text", "mrc-frames-text", "mrc-skeleton-types", "mrc-unknown-codec",
    "mrc-wrong-representation", "mrc-transform-num-frames-1e6", "mrc-transform-step-text",
    "mrc-transform-payload-4e9-frames",
    "bvh-frames-1e9-no-channels", "bvh-frame-time-1e-320", "bvh-symlink-to-dev-zero", "bvh-fifo", "fifo.npz",
    "fifo.h5", "fifo.mrc", "bvh-exact-values"]]


@pytest.mark.parametrize("name", CASE_NAMES)
def test_crafted_case(crafted, tmp_path, name):
    if name not in crafted:
        pytest.skip("not possible on this platform (FIFOs, symlinks)")
    case = crafted[name]
    out = tmp_path / f"out{case.out_suffix}"
    command = [a.replace("{out}", str(out)) for a in case.command]
    start = time.monotonic()
    with limits.override(read_timeout=5):  # the damaged HDF5 file: the watchdog ends it (the default is 60 s)
        result = run_cli_caught(*command)
    assert time.monotonic() - start < 60
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    assert "Traceback" not in result.output
    assert not check_leak(list(tmp_path.iterdir()))
    if case.kind == "accept":
        assert result.exit_code == 0, result.output
        if case.check is not None:  # (info prints, writes nothing)
            assert case.check(out) is None, case.check(out)
        return
    assert result.exit_code == 1, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"Error: {case.path}"), result.output
    assert case.message in lines[0], result.output
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_the_external_storage_case_leaks_nothing_even_with_the_watchdog_off(crafted, tmp_path):
    with limits.override(read_timeout=0):
        with pytest.raises(HDF5FormatError, match="external file"):
            read(crafted["h5-external-storage"].path)


# ---- limits ------------------------------------------------------------------------------------------------------
def test_limits_from_the_environment_and_overrides(monkeypatch):
    monkeypatch.setenv("MOTIONREP_MAX_FRAMES", "5000")
    monkeypatch.setenv("MOTIONREP_MAX_CLIP_BYTES", "3M")
    monkeypatch.setenv("MOTIONREP_READ_TIMEOUT", "2.5")
    lim = limits.current()
    assert (lim.max_frames, lim.max_clip_bytes, lim.read_timeout) == (5000, 3 << 20, 2.5)
    assert lim.max_metadata_bytes == limits.DEFAULTS.max_metadata_bytes
    with limits.override(max_frames=10) as inner:
        assert limits.current() is inner and inner.max_clip_bytes == 3 << 20
    assert limits.current().max_frames == 5000
    monkeypatch.setenv("MOTIONREP_MAX_FRAMES", "lots")
    with pytest.raises(ValidationError, match="MOTIONREP_MAX_FRAMES='lots'"):
        limits.current()
    monkeypatch.delenv("MOTIONREP_MAX_FRAMES")
    with pytest.raises(ValidationError, match="max_frames must be a positive integer"):
        limits.set_limits(max_frames=0)
    try:
        assert limits.set_limits(max_frames=7).max_frames == 7
        assert limits.current().max_frames == 7
    finally:
        limits.set_limits()
    assert limits.current().max_frames == limits.DEFAULTS.max_frames


@pytest.mark.parametrize("suffix", [".bvh", ".npz", ".h5"])
def test_every_format_refuses_a_clip_beyond_the_limits_before_reading_it(tmp_path, suffix):
    m = synthetic_motion(chain_skeleton(4), frames=50)
    path = tmp_path / f"x{suffix}"
    write(m, path)
    with limits.override(max_frames=49):
        with pytest.raises(FormatError, match="declares 50 frames, more than the limit of 49"):
            read(path)
    with limits.override(max_clip_bytes=50 * 100):
        with pytest.raises(FormatError, match="more than the limit"):
            read(path)
    assert read(path).num_frames == 50


def test_bvh_frames_beyond_the_lines_of_a_channel_less_file():
    text = ("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: 5\n"
            "Frame Time: 0.1\n\n\n\n")
    with pytest.raises(BVHFormatError, match="Frames: 5 but only 3"):
        parse_bvh(text, "x.bvh")
    assert parse_bvh(text + "\n\n", "x.bvh").num_frames == 5  # what the writer gives: one empty line per frame


def test_npz_member_larger_than_the_limit_is_refused_from_its_header(tmp_path):
    m = synthetic_motion(chain_skeleton(3), frames=40)
    write(m, tmp_path / "x.npz", compress=True)
    with limits.override(max_clip_bytes=1000):
        with pytest.raises(NPZFormatError, match="limit"):
            read(tmp_path / "x.npz")


# ---- HDF5: watchdog, versions, checksums -------------------------------------------------------------------------
def test_watchdog_ends_a_read_that_takes_too_long_and_the_next_read_works(tmp_path):
    m = synthetic_motion(chain_skeleton(3), frames=10)
    path = tmp_path / "x.h5"
    write(m, path)
    read(path)  # the worker is up
    with limits.override(read_timeout=1e-4):  # no HDF5 request answers in 100 microseconds
        with pytest.raises(HDF5FormatError, match=r"x\.h5: .*did not finish within 0\.0001 s"):
            read(path)
    assert read(path).num_frames == 10  # a fresh worker
    shutdown_worker()
    assert read(path).num_frames == 10


def test_old_hdf5_files_still_read(tmp_path):
    m = small_motion()
    write_v1_hdf5(m, tmp_path / "old.h5")
    back = read(tmp_path / "old.h5")
    np.testing.assert_array_equal(back.rotations, m.rotations)
    assert back.skeleton == m.skeleton and back.euler_angles is None


def test_hdf5_version_2_layout_has_checksums(tmp_path):
    # the checksums of version 2, kept by version 3 (which stores a BVH clip as its channel values)
    m = parse_bvh(format_bvh(small_motion()))  # with euler_angles
    write(m, tmp_path / "x.h5")
    with h5py.File(tmp_path / "x.h5", "r") as f:
        assert int(f.attrs["format_version"]) == 3
        seen = []

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and obj.size:
                assert obj.fletcher32, name
                seen.append(name)
        f.visititems(visit)
        assert "clips/x/skeleton/names" in seen
        assert "clips/x/channel_deltas" in seen or "clips/x/channel_values" in seen
        assert h5py.check_string_dtype(f["clips/x/skeleton/names"].dtype).length is not None
    np.testing.assert_array_equal(read(tmp_path / "x.h5").euler_angles, m.euler_angles)


def test_a_changed_data_byte_is_detected_by_the_checksum(crafted):
    with pytest.raises(HDF5FormatError, match="fails its checksum"):
        read(crafted["h5-flipped-data-byte"].path)


def test_old_npz_files_still_read(tmp_path, monkeypatch):
    import zipfile

    from motionrep.io import _npz

    m = parse_bvh(format_bvh(small_motion()))
    with monkeypatch.context() as patch:  # the full arrays of versions 1 and 2, not version 3's channel values
        patch.setattr(_npz, "channel_arrays", lambda motion: None)
        write(m, tmp_path / "new.npz")
    with zipfile.ZipFile(tmp_path / "new.npz") as src, zipfile.ZipFile(tmp_path / "old.npz", "w") as out:
        for info in src.infolist():
            if info.filename == "euler_angles.npy":
                continue
            data = src.read(info)
            if info.filename == "format_version.npy":
                import io

                buf = io.BytesIO()
                np.save(buf, np.array(1, dtype=np.int64))
                data = buf.getvalue()
            out.writestr(info, data)
    back = read(tmp_path / "old.npz")
    assert back.euler_angles is None and np.array_equal(back.rotations, m.rotations)


# ---- lossless BVH ------------------------------------------------------------------------------------------------
def test_source_angles_are_kept_through_every_format(tmp_path):
    text = ("HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
            "Yrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: 3\nFrame Time: 0.0333333\n"
            "1 2 3 -192.5 95 720.25\n1 2 3 -1253.0000001 5.1072e-06 1544\n-0 2 3 179.99999999999997 -90 -0.0\n")
    m = parse_bvh(text)
    want = np.array([float(t) for t in text.split("Frame Time: 0.0333333\n")[1].split()]).reshape(3, 6)
    for suffix in (".bvh", ".npz", ".h5"):
        write(m, tmp_path / f"x{suffix}")
        back = read(tmp_path / f"x{suffix}")
        got = channel_values(back)
        assert np.array_equal(got.view(np.uint64), want.view(np.uint64)), suffix
    assert "1.8e" not in format_bvh(m)


def test_angles_that_no_longer_describe_the_rotations_are_not_written():
    m = parse_bvh(format_bvh(small_motion()))
    turned = m.rotations[:, :, [1, 2, 3, 0]] * [1, 1, 1, 1]
    turned /= np.linalg.norm(turned, axis=-1, keepdims=True)
    assert m.replace(rotations=turned).euler_angles is None  # replace() drops them
    stale = Motion(m.skeleton, m.fps, m.root_translation, turned, m.joint_translations, euler_angles=m.euler_angles)
    again = parse_bvh(format_bvh(stale))
    q, q2 = again.rotations, turned
    assert np.minimum(np.abs(q - q2).max(-1), np.abs(q + q2).max(-1)).max() < 1e-9  # the rotations, not the hint


@pytest.mark.parametrize("decimals", [None, 0, 3, 6, 17])
def test_a_finite_value_is_never_written_as_inf(decimals):
    sk = Skeleton(("root",), [-1], [[0, 0, 0]])
    big = [[1.7976931348623157e308, -1.8e302, 4.9e-324]]
    m = Motion(sk, 30.0, big, [[[0, 0, 0, 1.0]]])
    text = format_bvh(m, decimals=decimals)
    assert "inf" not in text
    back = parse_bvh(text)
    if decimals is None:
        np.testing.assert_array_equal(back.root_translation, big)
    else:
        np.testing.assert_allclose(back.root_translation[0, :2], big[0][:2], rtol=1e-15)


def test_shortest_values_read_back_bit_for_bit():
    rng = np.random.default_rng(5)
    values = np.concatenate([rng.normal(size=400) * 10.0 ** rng.integers(-320, 300, 400),
                             [round(v, int(k)) for v, k in zip(rng.normal(size=400) * 100, rng.integers(0, 12, 400))],
                             [0.0, -0.0, 0.1 + 0.2, 2.0 ** 53, 2.0 ** 53 + 2, 1e16, 123456789.123456789, 5e-324]])
    sk = Skeleton(("root",), [-1], [[0, 0, 0]], channels=(("Xposition", "Yposition", "Zposition"),))
    root = values[: values.size // 3 * 3].reshape(-1, 3)
    rot = np.tile([0, 0, 0, 1.0], (root.shape[0], 1, 1))
    text = format_bvh(Motion(sk, 30.0, root, rot))
    back = parse_bvh(text).root_translation
    assert np.array_equal(back.view(np.uint64), root.view(np.uint64))
    tokens = text.split("Frame Time: ")[1].split()[1:]
    assert max(len(t) for t in tokens) <= 24


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_never_blocks_a_reader(tmp_path):
    from motionrep.io.container import read_container
    from motionrep.errors import ContainerError

    for suffix, error in ((".bvh", BVHFormatError), (".npz", NPZFormatError), (".h5", HDF5FormatError)):
        fifo = tmp_path / f"f{suffix}"
        os.mkfifo(fifo)
        with pytest.raises(error, match="FIFO"):
            read(fifo)
    os.mkfifo(tmp_path / "f.mrc")
    with pytest.raises(ContainerError, match="FIFO"):
        read_container(tmp_path / "f.mrc")
    with pytest.raises(BVHFormatError, match="directory"):
        read(Path(tmp_path / "d.bvh").mkdir() or tmp_path / "d.bvh")


def test_archives_carry_checksums_and_old_archives_still_read(tmp_path):
    from motionrep.io.archive import ARCHIVE_VERSION, read_archive, write_archive
    from fuzz.crafted import mrc_parts, pack_meta

    meta, payload = mrc_parts()
    data = pack_meta(meta, payload)
    write_archive({"a": data}, tmp_path / "new.h5")
    with h5py.File(tmp_path / "new.h5", "r") as f:
        assert int(f.attrs["format_version"]) == ARCHIVE_VERSION == 2 and f["clips/a"].fletcher32
    with h5py.File(tmp_path / "old.h5", "w") as f:  # an archive as version 1 wrote them
        f.attrs["format"] = "motionrep-mrc-archive"
        f.attrs["format_version"] = np.int64(1)
        f.create_group("clips").create_dataset("a", data=np.frombuffer(data, np.uint8))
    for name in ("new.h5", "old.h5"):
        assert read_archive(tmp_path / name)["a"].num_frames == meta["num_frames"]
    with h5py.File(tmp_path / "old.h5", "r+") as f:
        f["clips/b"] = h5py.SoftLink("/clips/a")
    with pytest.raises(FormatError, match="not a dataset but a soft link"):
        read_archive(tmp_path / "old.h5")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_AS and /proc/self/statm (Linux)")
def test_an_hdf5_read_may_not_grow_the_reader_by_more_than_its_data():
    from motionrep.io._h5worker import address_space

    with address_space(64 << 20):
        with pytest.raises(MemoryError):
            np.ones(1 << 28)  # 2 GiB
    assert np.ones(1 << 24).sum() == 1 << 24  # the limit is lifted afterwards


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the reader's peak from /proc (Linux)")
@pytest.mark.parametrize("seed", [1934, 5378, 11937, 18000])
def test_damaged_string_data_is_refused_without_gigabytes(tmp_path, seed):
    """Found by tests/fuzz/run.py: damaged bytes in the variable-length strings of a version 1 database made the
    HDF5 library allocate 1.5-3.8 GB before refusing the file (4 of 6,000 HDF5 mutants; seeds 11937 and 18000:
    0.3-1.1 GB in a clip's string attributes, 2 of the next 10,000)."""
    import random

    from fuzz.mutate import h5_mutant
    from fuzz.run import SMALL, _bases, _reset_worker_peak, _worker_peak

    base = _bases("h5", tmp_path)
    path = tmp_path / "mutant.h5"
    h5_mutant(path, base, random.Random(seed), tmp_path)
    with limits.override(**SMALL):
        read(tmp_path / "v2.h5")  # the reader process is running
        before = _worker_peak()
        _reset_worker_peak()
        try:
            read(path)
        except HDF5FormatError as exc:
            assert exc.path == str(path)
        else:  # another HDF5 library wrote other bytes: the damage missed the strings' lengths
            pytest.skip("this mutant is not the damaged file here (the base file's bytes differ)")
    assert _worker_peak() - before < 256 << 20


def test_npz_names_beyond_unicode_are_refused(tmp_path):
    """Found by the NPZ fuzz test: a names array whose UCS-4 code units exceed U+10FFFF made numpy hand out a str
    that CPython cannot use (SystemError far from the reader); it is one FormatError naming the file."""
    import numpy as np

    from motionrep.errors import FormatError
    from motionrep.io import read, write
    from motionrep.model.synthetic import chain_skeleton, synthetic_motion

    write(synthetic_motion(chain_skeleton(3), frames=5, seed=1), tmp_path / "good.npz")
    with np.load(tmp_path / "good.npz") as z:
        arrays = {k: z[k] for k in z.files}
    units = arrays["skeleton_names"].view(np.uint32).copy()
    units[0] = 0x110000
    arrays["skeleton_names"] = units.view(arrays["skeleton_names"].dtype)
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(FormatError, match="U\\+10FFFF") as info:
        read(tmp_path / "bad.npz")
    assert "bad.npz" in str(info.value)
