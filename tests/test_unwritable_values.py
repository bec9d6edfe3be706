"""Values that no format can write back are refused when a file is read, in every format (issue 27): an fps
whose frame time ``1 / fps`` is infinite (5e-324), joint names that BVH cannot hold or gives back changed (NUL,
ESC and other control characters, ``\\v``, U+2028, runs of spaces)."""

from __future__ import annotations

import dataclasses

import h5py
import numpy as np
import pytest

import motionrep
from motionrep import Motion, Skeleton
from motionrep.errors import FormatError, ValidationError
from motionrep.model.synthetic import synthetic_motion

BAD_NAMES = ["a\x00b", "a\x1bb", "a\vb", "a\u2028b", "a\x85b", "a  b", "a\tb", " a"]


@pytest.fixture(scope="module")
def motion():
    return synthetic_motion(frames=4)


def test_model_refuses_fps_without_a_finite_frame_time(motion):
    with pytest.raises(ValidationError, match="infinite frame time"):
        dataclasses.replace(motion, fps=5e-324)
    # tiny but writable; 1 / 1e-300 is not exactly 1e300 in binary floating point, hence the tolerance
    assert dataclasses.replace(motion, fps=1e-300).frame_time == pytest.approx(1e300, rel=1e-12)


@pytest.mark.parametrize("name", BAD_NAMES)
def test_model_refuses_names_bvh_cannot_round_trip(motion, name):
    names = (name,) + motion.skeleton.names[1:]
    with pytest.raises(ValidationError, match="invalid joint name"):
        dataclasses.replace(motion.skeleton, names=names)


def test_names_bvh_round_trips_are_accepted(motion, tmp_path):
    names = ("Hips é", "spine.01", "a b c") + motion.skeleton.names[3:]
    m = dataclasses.replace(motion, skeleton=dataclasses.replace(motion.skeleton, names=names))
    motionrep.write(m, tmp_path / "ok.bvh")
    assert motionrep.read(tmp_path / "ok.bvh").skeleton.names == names


def _npz(motion, path, **changes):
    motionrep.write(motion, path)
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    arrays.update(changes)
    np.savez(path, **arrays)


def _h5(motion, path, fps=None, name=None):
    motionrep.write(motion, path)
    with h5py.File(path, "r+") as f:
        clip = f["clips"][next(iter(f["clips"]))]
        if fps is not None:
            clip.attrs["fps"] = fps
        if name is not None:
            names = [n.decode() if isinstance(n, bytes) else n for n in clip["skeleton/names"][()]]
            names[0] = name
            old = clip["skeleton/names"]
            data = np.array([n.encode("utf-8") for n in names])  # fixed-length UTF-8 bytes, as written
            kwargs = dict(fletcher32=old.fletcher32, compression=old.compression)
            del clip["skeleton/names"]
            clip["skeleton"].create_dataset("names", data=data, **kwargs)


def _mrc(motion, path, fps=None, name=None):
    from motionrep.pipeline.compress import Pipeline
    from motionrep.io.container import pack, skeleton_to_json

    c = Pipeline.build("transform").compress(motion).container
    if fps is not None:
        c = dataclasses.replace(c, fps=fps)
    data = pack(c)
    if name is not None:  # the skeleton's JSON, written around the validation a Skeleton would do
        import json
        import struct
        import zlib

        from motionrep.io.container import _PREAMBLE, _CRC

        magic, version, flags, total, meta_len = _PREAMBLE.unpack_from(data)
        meta = json.loads(zlib.decompress(data[_PREAMBLE.size:_PREAMBLE.size + meta_len]))
        meta["skeleton"]["names"][0] = name
        blob = zlib.compress(json.dumps(meta, sort_keys=True).encode())
        rest = data[_PREAMBLE.size + meta_len:-_CRC.size]
        total = _PREAMBLE.size + len(blob) + len(rest) + _CRC.size
        body = _PREAMBLE.pack(magic, version, flags, total, len(blob)) + blob + rest
        data = body + struct.pack("<I", zlib.crc32(body))
    path.write_bytes(data)


def _bvh(motion, path, fps=None, name=None):
    motionrep.write(motion, path)
    text = path.read_text()
    if fps is not None:
        text = "\n".join("Frame Time: 1e-320" if line.startswith("Frame Time") else line
                         for line in text.split("\n"))
    if name is not None:
        text = text.replace(f"ROOT {motion.skeleton.names[0]}", f"ROOT {name}", 1)
    path.write_text(text)


def _refused(path, *words):
    with pytest.raises(FormatError) as info:
        motionrep.read(path)
    text = str(info.value)
    assert str(path) in text and "\n" not in text
    for w in words:
        assert w in text, text


def test_npz_fps_5e_324_refused(motion, tmp_path):
    _npz(motion, tmp_path / "a.npz", fps=np.float64(5e-324))
    _refused(tmp_path / "a.npz", "frame time")


@pytest.mark.parametrize("name", ["a\x00b", "a\x1bb", "a\vb", "a\u2028b"])
def test_npz_names_refused(motion, tmp_path, name):
    names = np.array((name,) + motion.skeleton.names[1:])
    _npz(motion, tmp_path / "a.npz", skeleton_names=names)
    _refused(tmp_path / "a.npz", "invalid joint name")


def test_hdf5_fps_5e_324_refused(motion, tmp_path):
    _h5(motion, tmp_path / "a.h5", fps=5e-324)
    _refused(tmp_path / "a.h5", "frame time")


@pytest.mark.parametrize("name", ["a\x1bb", "a\u2028b"])
def test_hdf5_names_refused(motion, tmp_path, name):
    _h5(motion, tmp_path / "a.h5", name=name)
    _refused(tmp_path / "a.h5", "invalid joint name")


def test_mrc_fps_5e_324_refused(motion, tmp_path):
    _mrc(motion, tmp_path / "a.mrc", fps=5e-324)
    from motionrep.io.container import read_container

    with pytest.raises(FormatError, match="finite frame time"):
        read_container(tmp_path / "a.mrc")


@pytest.mark.parametrize("name", ["a\x00b", "a\x1bb", "a\vb", "a\u2028b"])
def test_mrc_names_refused(motion, tmp_path, name):
    _mrc(motion, tmp_path / "a.mrc", name=name)
    from motionrep.io.container import read_container

    with pytest.raises(FormatError, match="invalid joint name") as info:
        read_container(tmp_path / "a.mrc")
    assert str(tmp_path / "a.mrc") in str(info.value)


def test_bvh_tiny_frame_time_refused(motion, tmp_path):
    _bvh(motion, tmp_path / "a.bvh", fps=True)
    with pytest.raises(FormatError) as info:
        motionrep.read(tmp_path / "a.bvh")
    assert str(tmp_path / "a.bvh") in str(info.value)


@pytest.mark.parametrize("name", ["a\x00b", "a\x1bb"])
def test_bvh_names_with_control_characters_refused(motion, tmp_path, name):
    _bvh(motion, tmp_path / "a.bvh", name=name)
    _refused(tmp_path / "a.bvh", "control byte")
