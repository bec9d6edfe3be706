"""NPZ and HDF5 formats: bit-exact round trips, databases, features files, validation and atomic writes."""

from __future__ import annotations

import zipfile
from pathlib import Path

import h5py
import numpy as np
import pytest

import motionrep.io._hdf5 as hdf5_module
import motionrep.io._npz as npz_module
from motionrep import Motion, Skeleton
from motionrep.plugin.hookspecs import hookimpl
from motionrep.plugin import registry as plugins
from motionrep.errors import (
    FormatError,
    HDF5FormatError,
    NPZFormatError,
    UnknownPluginError,
    ValidationError,
)
from motionrep.io import (
    FeatureClip,
    features_from_motion,
    list_clips,
    read,
    read_bvh,
    read_clips,
    read_features,
    read_stored,
    write,
    write_database,
    write_features,
)
from motionrep.io._bvh import channel_values, format_bvh
from motionrep.io._hdf5 import clip_summaries
from motionrep.plugin.representation import Representation
from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, synthetic_motion

from helpers import real_params

SUFFIXES = (".npz", ".h5")
MOTION_ARRAYS = ("root_translation", "rotations", "joint_translations", "euler_branch")


# ---------------------------------------------------------------------------------------------------------------
# fixtures and helpers
# ---------------------------------------------------------------------------------------------------------------
def odd_skeleton() -> Skeleton:
    """Position channels on a non-root joint, a joint without channels, a two-axis joint, no end sites, units."""
    return Skeleton(
        names=("root", "spine", "fixed", "elbow", "tip"),
        parents=np.array([-1, 0, 1, 2, 3]),
        offsets=np.array([[1.5, 90.0, -2.0], [0, 10, 0], [0, 10, 0], [5, 0, 0], [0.1, 0.2, 0.3]]),
        channels=(("Zrotation", "Xrotation", "Yrotation", "Xposition", "Yposition", "Zposition"),
                  ("Xposition", "Yposition", "Zposition", "Yrotation", "Xrotation", "Zrotation"),
                  (),
                  ("Xrotation", "Zrotation"),
                  ("Yposition", "Zrotation")),
        units="cm",
    )


def odd_motion(frames: int = 37) -> Motion:
    sk = odd_skeleton()
    m = synthetic_motion(sk, frames=frames, fps=1 / 0.0083333, seed=3)
    rng = np.random.default_rng(5)
    jt = np.array(m.joint_translations)
    jt[:, 1, 0] = sk.offsets[4, 0]  # "tip" has only a Yposition channel: X and Z keep the OFFSET
    jt[:, 1, 2] = sk.offsets[4, 2]
    branch = rng.random((frames, sk.num_joints)) < 0.3
    return m.replace(joint_translations=jt, euler_branch=branch)


def motions() -> list:
    return [
        pytest.param(synthetic_motion(humanoid_skeleton(), frames=50), id="humanoid-no-branch"),
        pytest.param(synthetic_motion(chain_skeleton(6), frames=1, seed=2), id="chain-one-frame"),
        pytest.param(odd_motion(), id="odd-skeleton-with-branch"),
    ]


def assert_same_motion(a: Motion, b: Motion) -> None:
    assert a.skeleton == b.skeleton  # names, parents, offsets, channels, end sites, units: exact
    assert a.skeleton.units == b.skeleton.units
    assert a.fps == b.fps
    for name in MOTION_ARRAYS:
        x, y = getattr(a, name), getattr(b, name)
        if x is None:
            assert y is None, name
        else:
            assert y is not None and x.dtype == y.dtype and np.array_equal(x, y), name


class FlatRep(Representation):
    """A lossless toy representation: root translation, raw xyzw quaternions, joint translations."""

    name = "test-flat"
    version = 1
    description = "test only"

    def width(self, skeleton: Skeleton) -> int:
        return 3 + 4 * skeleton.num_joints + 3 * len(skeleton.translated_joints)

    def feature_names(self, skeleton: Skeleton) -> list[str]:
        names = ["root/tx", "root/ty", "root/tz"]
        names += [f"{n}/q{c}" for n in skeleton.names for c in "xyzw"]
        names += [f"{skeleton.names[j]}/t{c}" for j in skeleton.translated_joints for c in "xyz"]
        return names

    def to_features(self, motion: Motion) -> np.ndarray:
        F = motion.num_frames
        return np.concatenate([motion.root_translation, motion.rotations.reshape(F, -1),
                               motion.joint_translations.reshape(F, -1)], axis=1)

    def from_features(self, features, skeleton: Skeleton, fps: float) -> Motion:
        f = np.asarray(features, dtype=np.float64)
        J, P = skeleton.num_joints, len(skeleton.translated_joints)
        if f.ndim != 2 or f.shape[1] != self.width(skeleton):
            raise ValidationError(f"bad features shape {f.shape}")
        rot = f[:, 3:3 + 4 * J].reshape(-1, J, 4)
        return Motion(skeleton, fps, f[:, :3], rot, f[:, 3 + 4 * J:].reshape(f.shape[0], P, 3))

    def weights(self, motion: Motion) -> np.ndarray:
        return np.ones(self.width(motion.skeleton))


def register_representation(rep: Representation) -> None:
    class Plugin:
        @staticmethod
        @hookimpl
        def register_representations(register):
            register(rep)

    plugins.pm.register(Plugin(), name=f"test-plugin-{rep.name}-v{rep.version}")


@pytest.fixture
def flat_rep(monkeypatch) -> FlatRep:
    """Only the toy representation is registered (shipped plugins are not loaded)."""
    monkeypatch.setattr(plugins, "DEFAULT_PLUGINS", ())
    rep = FlatRep()
    register_representation(rep)
    return rep


# ---------------------------------------------------------------------------------------------------------------
# round trips
# ---------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", SUFFIXES)
@pytest.mark.parametrize("motion", motions())
def test_round_trip_is_bit_exact(tmp_path, motion, suffix):
    path = tmp_path / f"clip{suffix}"
    write(motion, path)
    back = read(path)
    assert_same_motion(motion, back)
    assert np.array_equal(channel_values(back), channel_values(motion))
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left beside it


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_extreme_values_round_trip(tmp_path, suffix):
    sk = chain_skeleton(3)
    F = 4
    rng = np.random.default_rng(0)
    q = rng.normal(size=(F, 3, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    root = np.array([[1e-300, -0.0, 5e300], [np.nextafter(1, 2), -1e-310, 3.141592653589793],
                     [0.1, 0.2, 0.30000000000000004], [-7.0, 1e-20, 2.5]])
    m = Motion(sk, 29.97002997002997, root, q, euler_branch=np.ones((F, 3), bool))
    path = tmp_path / f"x{suffix}"
    write(m, path)
    assert_same_motion(m, read(path))
    assert np.signbit(read(path).root_translation[0, 1])  # -0.0 kept


@pytest.mark.realdata
@pytest.mark.parametrize("bvh", real_params())
def test_real_bvh_round_trips_through_npz_and_hdf5(tmp_path, bvh):
    motion = read_bvh(bvh)
    values = channel_values(motion)
    for suffix in SUFFIXES:
        path = tmp_path / f"clip{suffix}"
        write(motion, path)
        back = read(path)
        assert_same_motion(motion, back)
        assert np.array_equal(channel_values(back), values), suffix


@pytest.mark.realdata
@pytest.mark.parametrize("bvh", real_params("edge"))
def test_real_bvh_to_npz_to_bvh_text_is_identical(tmp_path, bvh):
    motion = read_bvh(bvh)
    write(motion, tmp_path / "a.npz")
    write(read(tmp_path / "a.npz"), tmp_path / "b.h5")
    write(read(tmp_path / "b.h5"), tmp_path / "c.bvh")
    assert (tmp_path / "c.bvh").read_text() == format_bvh(motion)


# ---------------------------------------------------------------------------------------------------------------
# NPZ layout
# ---------------------------------------------------------------------------------------------------------------
def test_npz_layout_loads_without_pickle(tmp_path):
    m = odd_motion()
    path = tmp_path / "m.npz"
    write(m, path)
    with np.load(path, allow_pickle=False) as z:
        keys = set(z.files)
        assert str(z["format"]) == "motionrep-npz" and int(z["format_version"]) == 3
        assert str(z["quat_order"]) == "xyzw" and str(z["kind"]) == "motion" and str(z["units"]) == "cm"
        assert z["fps"].dtype == np.float64 and float(z["fps"]) == m.fps
        assert z["skeleton_names"].dtype.kind == "U"
        assert z["skeleton_names"].tolist() == list(m.skeleton.names)
        assert z["skeleton_channels"].tolist()[2] == ""
        assert z["skeleton_channels"].tolist()[0] == "Zrotation Xrotation Yrotation Xposition Yposition Zposition"
        assert z["rotations"].shape == (37, 5, 4) and z["rotations"].dtype == np.float64
        bits = z["euler_branch_bits"]
        assert bits.dtype == np.uint8 and bits.shape == ((37 * 5 + 7) // 8,)
        assert np.array_equal(np.unpackbits(bits, count=37 * 5).reshape(37, 5).astype(bool), m.euler_branch)
    assert {"skeleton_parents", "skeleton_offsets", "skeleton_end_site_parents", "skeleton_end_site_offsets",
            "root_translation", "joint_translations"} <= keys
    # a motion without the Euler hint has no bits key, and reads back None
    write(m.replace(euler_branch=None), path)
    with np.load(path, allow_pickle=False) as z:
        assert "euler_branch_bits" not in z.files and "units" in z.files
    assert read(path).euler_branch is None


def test_npz_uncompressed_reads_the_same(tmp_path):
    m = odd_motion()
    write(m, tmp_path / "c.npz")  # deflated by default (format version 3)
    write(m, tmp_path / "u.npz", compress=False)
    with zipfile.ZipFile(tmp_path / "u.npz") as z:
        assert {i.compress_type for i in z.infolist()} == {zipfile.ZIP_STORED}
    with zipfile.ZipFile(tmp_path / "c.npz") as z:
        assert {i.compress_type for i in z.infolist()} == {zipfile.ZIP_DEFLATED}
    assert_same_motion(read(tmp_path / "u.npz"), read(tmp_path / "c.npz"))


def test_nul_in_names_is_refused(tmp_path):
    # a name no format can write back is refused by the Skeleton itself (issue 27), before any file is written
    with pytest.raises(ValidationError, match="control characters"):
        chain_skeleton(2).replace(names=("a\x00", "b"))
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------------------------------------------
# HDF5 layout and databases
# ---------------------------------------------------------------------------------------------------------------
def test_hdf5_layout_is_readable_with_plain_h5py(tmp_path):
    m = odd_motion(frames=300)
    path = tmp_path / "walk.h5"
    write(m, path)
    with h5py.File(path, "r") as f:
        assert f.attrs["format"] == "motionrep-hdf5" and int(f.attrs["format_version"]) == 3
        assert f.attrs["quat_order"] == "xyzw"
        assert list(f["clips"]) == ["walk"]  # default clip name: the file stem
        g = f["clips/walk"]
        assert isinstance(g.attrs["kind"], str) and g.attrs["kind"] == "motion"
        assert g.attrs["units"] == "cm" and g.attrs["fps"] == m.fps and g.attrs["quat_order"] == "xyzw"
        assert h5py.check_string_dtype(g["skeleton/names"].dtype).encoding == "utf-8"
        assert g["skeleton/names"].asstr()[()].tolist() == list(m.skeleton.names)
        assert g["skeleton/channels"].asstr()[()].tolist()[3] == "Xrotation Zrotation"
        for name in ("root_translation", "rotations", "joint_translations", "euler_branch"):
            ds = g[name]
            assert ds.chunks is not None and ds.compression == "gzip" and ds.shuffle, name
            assert ds.chunks[1:] == ds.shape[1:]
        assert g["rotations"].dtype == np.float64 and g["euler_branch"].dtype == np.uint8
        assert np.array_equal(g["rotations"][()], m.rotations)
        assert np.array_equal(g["euler_branch"][()].astype(bool), m.euler_branch)


def test_hdf5_clip_name_option(tmp_path):
    m = synthetic_motion(chain_skeleton(3), frames=5)
    write(m, tmp_path / "x.h5", clip="take 1")
    assert list_clips(tmp_path / "x.h5") == ["take 1"]
    assert read_stored(tmp_path / "x.h5")[0] == "take 1"


def _three_clips() -> dict[str, Motion]:
    return {"walk": synthetic_motion(humanoid_skeleton(), frames=40, seed=1),
            "arm": odd_motion(frames=12),
            "chain": synthetic_motion(chain_skeleton(5), frames=3, fps=25, seed=4)}


@pytest.mark.parametrize("as_mapping", [True, False])
def test_database_round_trip_keeps_order_and_data(tmp_path, as_mapping):
    clips = _three_clips()
    path = tmp_path / "db.hdf5"
    given = clips if as_mapping else iter(list(clips.items()))
    assert write_database(given, path) == ["walk", "arm", "chain"]
    assert list_clips(path) == ["walk", "arm", "chain"]  # order written, not alphabetical
    seen = []
    for name, motion in read_clips(path):
        assert_same_motion(clips[name], motion)
        seen.append(name)
    assert seen == ["walk", "arm", "chain"]
    assert_same_motion(clips["arm"], read(path, clip="arm"))
    summaries = clip_summaries(path)
    assert [(s["name"], s["frames"], s["joints"], s["fps"]) for s in summaries] == [
        ("walk", 40, 15, 60.0), ("arm", 12, 5, 1 / 0.0083333), ("chain", 3, 5, 25.0)]


def test_read_without_clip_on_a_database_lists_the_clips(tmp_path):
    path = tmp_path / "db.h5"
    write_database(_three_clips(), path)
    with pytest.raises(HDF5FormatError) as info:
        read(path)
    msg = str(info.value)
    assert str(path) in msg and "3 clips" in msg and all(n in msg for n in ("walk", "arm", "chain"))
    with pytest.raises(HDF5FormatError, match="no clip named 'nope'.*walk, arm, chain"):
        read(path, clip="nope")


def test_read_clips_is_lazy(tmp_path, monkeypatch):
    path = tmp_path / "db.h5"
    write_database(_three_clips(), path)
    decoded = []
    real = hdf5_module.decode_clip
    monkeypatch.setattr(hdf5_module, "decode_clip", lambda src: decoded.append(src.clip) or real(src))
    it = read_clips(path)
    assert decoded == []
    name, _ = next(it)
    assert name == "walk" and decoded == ["walk"]
    next(it)
    assert decoded == ["walk", "arm"]
    it.close()


def _corrupt_first_chunk(path: Path, dataset: str) -> None:
    with h5py.File(path, "r") as f:
        chunk = f[dataset].id.get_chunk_info(0)
    with open(path, "r+b") as fh:
        fh.seek(chunk.byte_offset)
        fh.write(b"\xff" * chunk.size)


def test_reading_a_clip_does_not_read_the_others(tmp_path):
    clips = _three_clips()
    path = tmp_path / "db.h5"
    write_database(clips, path)
    _corrupt_first_chunk(path, "clips/arm/rotations")
    # the damaged clip fails with a clean error naming the file, the clip and the dataset ...
    with pytest.raises(HDF5FormatError) as info:
        read(path, clip="arm")
    assert str(path) in str(info.value) and "clip 'arm'" in str(info.value) and "rotations" in str(info.value)
    # ... and the others still read exactly, as do the listing and the summaries (shapes only)
    assert_same_motion(clips["walk"], read(path, clip="walk"))
    assert_same_motion(clips["chain"], read(path, clip="chain"))
    assert list_clips(path) == ["walk", "arm", "chain"]
    assert [s["frames"] for s in clip_summaries(path)] == [40, 12, 3]
    it = read_clips(path)
    assert next(it)[0] == "walk"
    with pytest.raises(HDF5FormatError, match="clip 'arm'"):
        next(it)


@pytest.mark.parametrize("names, message", [
    (["a", "a"], "given twice"),
    (["a", ""], "non-empty"),
    (["a/b"], "may not contain '/'"),
    (["."], "may not contain"),
    ([3], "non-empty strings"),
    ([], "no clips"),
])
def test_database_clip_names_are_validated(tmp_path, names, message):
    path = tmp_path / "db.h5"
    path.write_bytes(b"old content")
    m = synthetic_motion(chain_skeleton(2), frames=2)
    with pytest.raises(HDF5FormatError, match=message) as info:
        write_database([(n, m) for n in names], path)
    assert str(path) in str(info.value)
    assert path.read_bytes() == b"old content"
    assert list(tmp_path.iterdir()) == [path]


def test_database_refuses_values_that_are_not_clips(tmp_path):
    with pytest.raises(ValidationError, match="Motion or a FeatureClip"):
        write_database({"a": np.zeros((3, 4))}, tmp_path / "db.h5")
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------------------------------------------
# atomic writes
# ---------------------------------------------------------------------------------------------------------------
def test_failing_database_write_leaves_nothing_and_keeps_the_old_file(tmp_path):
    path = tmp_path / "db.h5"
    write(synthetic_motion(chain_skeleton(2), frames=2), path)
    before = path.read_bytes()

    def clips():
        yield "first", synthetic_motion(humanoid_skeleton(), frames=20)
        raise RuntimeError("input failed midway")

    with pytest.raises(RuntimeError, match="midway"):
        write_database(clips(), path)
    assert path.read_bytes() == before
    assert list(tmp_path.iterdir()) == [path]


def test_failing_hdf5_writer_leaves_no_file(tmp_path, monkeypatch):
    real = hdf5_module._write_clip

    def write_then_fail(group, name, item):
        real(group, name, item)
        raise OSError("disk full")

    monkeypatch.setattr(hdf5_module, "_write_clip", write_then_fail)
    with pytest.raises(OSError, match="disk full"):
        write(synthetic_motion(chain_skeleton(3), frames=5), tmp_path / "x.h5")
    assert list(tmp_path.iterdir()) == []


def test_failing_npz_writer_leaves_no_file_and_keeps_the_old_one(tmp_path, monkeypatch):
    path = tmp_path / "x.npz"
    path.write_bytes(b"previous")

    def partial(fh, **arrays):
        fh.write(b"PK\x03\x04 partial archive")
        raise OSError("disk full")

    monkeypatch.setattr(npz_module.np, "savez", partial)
    monkeypatch.setattr(npz_module.np, "savez_compressed", partial)
    with pytest.raises(OSError, match="disk full"):
        write(synthetic_motion(chain_skeleton(3), frames=5), path)
    assert path.read_bytes() == b"previous"
    assert list(tmp_path.iterdir()) == [path]


# ---------------------------------------------------------------------------------------------------------------
# validation on read
# ---------------------------------------------------------------------------------------------------------------
def _rewrite_npz(src: Path, dst: Path, drop=(), **replace) -> None:
    with np.load(src, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files if k not in drop}
    arrays.update(replace)
    np.savez(dst, **arrays)


@pytest.fixture
def good_npz(tmp_path) -> Path:
    path = tmp_path / "good.npz"
    write(odd_motion(frames=6), path)
    return path


@pytest.mark.parametrize("drop", ["rotations", "root_translation", "joint_translations", "fps", "kind",
                                  "quat_order", "skeleton_names", "skeleton_parents", "skeleton_offsets",
                                  "skeleton_channels", "skeleton_end_site_parents", "skeleton_end_site_offsets",
                                  "format_version"])
def test_npz_missing_key(tmp_path, good_npz, drop):
    bad = tmp_path / "bad.npz"
    _rewrite_npz(good_npz, bad, drop=[drop])
    with pytest.raises(NPZFormatError) as info:
        read(bad)
    assert str(info.value) == f"{bad}: missing key {drop!r}"


@pytest.mark.parametrize("key, value, message", [
    ("rotations", np.zeros((6, 4, 4)), r"key 'rotations' has shape \(6, 4, 4\), expected \(\?, 5, 4\)"),
    ("root_translation", np.zeros((5, 3)), r"key 'root_translation' has shape \(5, 3\), expected \(6, 3\)"),
    ("joint_translations", np.zeros((6, 1, 3)), r"expected \(6, 2, 3\)"),
    ("skeleton_parents", np.zeros(4, np.int64), r"expected \(5,\)"),
    ("skeleton_parents", np.zeros(5), "must hold integers"),
    ("rotations", np.full((6, 5, 4), "a"), "must hold numbers"),
    ("euler_branch_bits", np.zeros(3, np.uint8), r"expected \(4,\)"),
    ("fps", np.array(-1.0), "fps must be finite and > 0"),
    ("fps", np.array([30.0, 30.0]), "must be a number"),
    ("quat_order", np.array("wxyz"), "xyzw"),
    ("kind", np.array("video"), "'motion' or 'features'"),
    ("rotations", np.ones((6, 5, 4)), "unit quaternions"),
    ("skeleton_parents", np.array([-1, 0, 3, 2, 3]), "invalid skeleton"),
    ("skeleton_channels", np.array(["Xrotation Spin", "", "", "", ""]), "unknown channel 'Spin'"),
    ("format_version", np.array(4), "version 4 is newer than the newest this motionrep reads \\(3\\)"),
    ("format_version", np.array(0), "invalid NPZ format version 0"),
    ("format", np.array("other-format"), "not a motionrep NPZ file"),
])
def test_npz_malformed_content(tmp_path, good_npz, key, value, message):
    bad = tmp_path / "bad.npz"
    _rewrite_npz(good_npz, bad, **{key: value})
    with pytest.raises(NPZFormatError, match=message) as info:
        read(bad)
    assert str(info.value).startswith(f"{bad}: ")


def test_npz_not_motionrep_or_not_npz(tmp_path):
    np.savez(tmp_path / "plain.npz", x=np.arange(3))
    np.save(tmp_path / "array.npy", np.arange(3))
    (tmp_path / "array.npy").rename(tmp_path / "array.npz")
    (tmp_path / "text.npz").write_text("HIERARCHY\nROOT hips\n")
    (tmp_path / "trunc.npz").write_bytes((Path(tmp_path / "plain.npz").read_bytes())[:40])
    np.savez(tmp_path / "pickled.npz", format=np.array(["motionrep-npz", None], dtype=object))
    cases = {"plain.npz": "no 'format' key", "array.npz": "not an NPZ archive", "text.npz": "not an NPZ archive",
             "trunc.npz": "not an NPZ archive", "pickled.npz": "cannot read key 'format'",
             "missing.npz": "cannot read file"}
    for name, message in cases.items():
        with pytest.raises(NPZFormatError, match=message) as info:
            read(tmp_path / name)
        assert str(info.value).startswith(str(tmp_path / name)), name


@pytest.fixture
def good_h5(tmp_path) -> Path:
    path = tmp_path / "good.h5"
    write_database({"a": odd_motion(frames=6), "b": synthetic_motion(chain_skeleton(3), frames=4)}, path)
    return path


def _edit_h5(path: Path, edit) -> None:
    with h5py.File(path, "r+") as f:
        edit(f)


def _replace(f, name, data):
    del f[name]
    f[name] = data


@pytest.mark.parametrize("edit, message", [
    (lambda f: f["clips/a"].pop("rotations"), "clip 'a': missing dataset 'rotations'"),
    (lambda f: f["clips/a/skeleton"].pop("names"), "clip 'a': missing dataset 'skeleton/names'"),
    (lambda f: f["clips/a"].attrs.__delitem__("fps"), "clip 'a': missing attribute 'fps'"),
    (lambda f: _replace(f, "clips/a/rotations", np.zeros((6, 2, 4))),
     r"clip 'a': dataset 'rotations' has shape \(6, 2, 4\), expected \(\?, 5, 4\)"),
    (lambda f: _replace(f, "clips/a/skeleton/names", np.arange(5)), "must hold strings"),
    (lambda f: _replace(f, "clips/a/euler_branch", np.full((6, 5), 2, np.uint8)), "only 0 and 1"),
    (lambda f: f["clips/a"].attrs.__setitem__("fps", "fast"), "attribute 'fps' must be a number"),
    (lambda f: f["clips/a"].attrs.__setitem__("kind", 7), "attribute 'kind' must be a string"),
    (lambda f: f["clips/a"].attrs.__setitem__("quat_order", "wxyz"), "xyzw"),
    (lambda f: f.attrs.__setitem__("format_version", 4), "version 4 is newer than the newest this motionrep"),
    (lambda f: f.attrs.__setitem__("format", "other"), "not a motionrep HDF5 file"),
    (lambda f: f.attrs.__delitem__("format"), "no 'format' attribute"),
    (lambda f: f.pop("clips"), "missing group '/clips'"),
])
def test_hdf5_malformed_content(good_h5, edit, message):
    _edit_h5(good_h5, edit)
    with pytest.raises(HDF5FormatError, match=message) as info:
        read(good_h5, clip="a")
    assert str(info.value).startswith(f"{good_h5}: ")


def test_hdf5_not_motionrep_or_not_hdf5(tmp_path):
    with h5py.File(tmp_path / "plain.h5", "w") as f:
        f["x"] = np.arange(3)
    (tmp_path / "text.h5").write_text("not hdf5 at all")
    cases = {"plain.h5": "not a motionrep HDF5 file", "text.h5": "not an HDF5 file",
             "missing.h5": "No such file"}
    for name, message in cases.items():
        for call in (read, list_clips):
            with pytest.raises(HDF5FormatError, match=message) as info:
                call(tmp_path / name)
            assert str(info.value).startswith(str(tmp_path / name))


def test_hdf5_reads_fixed_length_strings_from_other_writers(good_h5):
    def to_fixed(f):
        names = f["clips/b/skeleton/names"].asstr()[()].tolist()
        _replace(f, "clips/b/skeleton/names", np.array(names, dtype="S"))
        f["clips/b"].attrs["kind"] = np.bytes_(b"motion")

    expected = read(good_h5, clip="b")
    _edit_h5(good_h5, to_fixed)
    assert_same_motion(expected, read(good_h5, clip="b"))


def test_clip_argument_refused_for_single_clip_formats(tmp_path):
    m = synthetic_motion(chain_skeleton(2), frames=2)
    write(m, tmp_path / "a.npz")
    write(m, tmp_path / "a.bvh")
    with pytest.raises(NPZFormatError, match="HDF5 databases"):
        read(tmp_path / "a.npz", clip="x")
    with pytest.raises(FormatError, match="HDF5 databases"):
        read(tmp_path / "a.bvh", clip="x")
    assert list_clips(tmp_path / "a.npz") == ["a"]
    assert [n for n, _ in read_clips(tmp_path / "a.bvh")] == ["a"]


# ---------------------------------------------------------------------------------------------------------------
# features files
# ---------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", SUFFIXES)
def test_features_round_trip_and_decode(tmp_path, flat_rep, suffix):
    motion = odd_motion(frames=9)
    clip = features_from_motion(motion, "test-flat")
    assert clip.representation == "test-flat" and clip.representation_version == 1
    assert clip.features.shape == (9, flat_rep.width(motion.skeleton))
    path = tmp_path / f"f{suffix}"
    write_features(clip, path)
    back = read_features(path)
    assert isinstance(back, FeatureClip)
    assert np.array_equal(back.features, clip.features) and back.features.dtype == np.float64
    assert back.feature_names == clip.feature_names and back.skeleton == motion.skeleton and back.fps == motion.fps
    assert (back.representation, back.representation_version) == ("test-flat", 1)
    decoded = read(path)  # through the registered representation
    assert isinstance(decoded, Motion) and decoded.skeleton == motion.skeleton
    for name in ("root_translation", "rotations", "joint_translations"):
        assert np.array_equal(getattr(decoded, name), getattr(motion, name))


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_features_of_another_representation_version_are_refused(tmp_path, monkeypatch, suffix):
    monkeypatch.setattr(plugins, "DEFAULT_PLUGINS", ())
    clip = FeatureClip(chain_skeleton(2), 30.0, "test-flat", 1, np.zeros((2, 3 + 8)),
                       tuple(f"c{i}" for i in range(11)))
    path = tmp_path / f"f{suffix}"
    write_features(clip, path)

    class FlatRepV2(FlatRep):
        version = 2

    register_representation(FlatRepV2())
    with pytest.raises(FormatError) as info:
        read(path)
    msg = str(info.value)
    assert msg.startswith(str(path)) and "version 1" in msg and "version 2" in msg
    assert read_features(path).representation_version == 1  # still readable as stored


def test_features_of_an_unknown_representation(tmp_path, flat_rep):
    clip = FeatureClip(chain_skeleton(2), 30.0, "no-such-rep", 3, np.zeros((2, 4)), ("a", "b", "c", "d"))
    write_features(clip, tmp_path / "f.npz")
    with pytest.raises(UnknownPluginError, match="unknown representation 'no-such-rep'.*test-flat"):
        read(tmp_path / "f.npz")


def test_features_layout_on_disk(tmp_path, flat_rep):
    clip = features_from_motion(synthetic_motion(chain_skeleton(3), frames=4), "test-flat")
    write_features(clip, tmp_path / "f.npz")
    write_features(clip, tmp_path / "f.h5", clip="feat")
    with np.load(tmp_path / "f.npz", allow_pickle=False) as z:
        assert str(z["kind"]) == "features" and str(z["representation"]) == "test-flat"
        assert int(z["representation_version"]) == 1 and z["feature_names"].dtype.kind == "U"
        assert "rotations" not in z.files
    with h5py.File(tmp_path / "f.h5", "r") as f:
        g = f["clips/feat"]
        assert g.attrs["kind"] == "features" and g.attrs["representation"] == "test-flat"
        assert g["features"].compression == "gzip"
        assert g["feature_names"].asstr()[()].tolist() == list(clip.feature_names)
    assert clip_summaries(tmp_path / "f.h5")[0]["width"] == clip.width


def test_mixed_database_and_read_features_on_a_motion(tmp_path, flat_rep):
    motion = synthetic_motion(chain_skeleton(3), frames=4)
    path = tmp_path / "db.h5"
    write_database([("m", motion), ("f", features_from_motion(motion, "test-flat"))], path)
    assert [s["kind"] for s in clip_summaries(path)] == ["motion", "features"]
    assert isinstance(read_features(path, clip="f"), FeatureClip)
    with pytest.raises(HDF5FormatError, match="clip 'm' holds a motion"):
        read_features(path, clip="m")
    names = [n for n, m in read_clips(path) if isinstance(m, Motion)]
    assert names == ["m", "f"]  # read_clips decodes the features clip


def test_feature_files_are_not_bvh_and_write_needs_a_motion(tmp_path, flat_rep):
    motion = synthetic_motion(chain_skeleton(3), frames=4)
    clip = features_from_motion(motion, "test-flat")
    with pytest.raises(FormatError, match="not features"):
        write_features(clip, tmp_path / "f.bvh")
    with pytest.raises(ValidationError, match="write_features"):
        write(clip, tmp_path / "f.npz")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("kwargs, message", [
    (dict(features=np.zeros((0, 2))), "F >= 1"),
    (dict(features=np.zeros(2)), r"shape \(F, D\)"),
    (dict(features=np.array([[0.0, np.nan]])), "NaN"),
    (dict(feature_names=("a",)), "1 names for 2 feature columns"),
    (dict(representation_version=0), "integer >= 1"),
    (dict(representation=""), "non-empty"),
    (dict(fps=0.0), "fps"),
])
def test_feature_clip_validates(kwargs, message):
    args = dict(skeleton=chain_skeleton(2), fps=30.0, representation="r", representation_version=1,
                features=np.zeros((3, 2)), feature_names=("a", "b"))
    args.update(kwargs)
    with pytest.raises(ValidationError, match=message):
        FeatureClip(**args)


def test_feature_clip_is_read_only():
    clip = FeatureClip(chain_skeleton(2), 30.0, "r", 1, np.zeros((3, 2)), ("a", "b"))
    with pytest.raises(ValueError):
        clip.features[0, 0] = 1.0
    assert (clip.num_frames, clip.width, clip.duration) == (3, 2, 0.1)
