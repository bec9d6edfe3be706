"""The .mrc container: round trip, determinism, every truncation and byte flip detected, the spec's layout."""

from __future__ import annotations

import dataclasses
import json
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

from motionrep.compress import compress_motion, decompress, decompress_file
from motionrep.container import CONTAINER_VERSION, MAGIC, pack, read_container, unpack, write_container
from motionrep.errors import ContainerError, FormatError, PluginVersionError, UnknownPluginError
from motionrep.evaluate import max_joint_error
from motionrep.synthetic import chain_skeleton, synthetic_motion

SPEC = Path(__file__).resolve().parent.parent / "specs" / "container.md"


@pytest.fixture(scope="module")
def small():
    """A small real container: 12 frames of a 3-joint chain, svd rank 1, no bound."""
    from motionrep.plugins import reset_plugins

    reset_plugins()
    motion = synthetic_motion(chain_skeleton(3), frames=12, seed=2)
    result = compress_motion(motion, "svd", params={"rank": 1}, max_error=None)
    reset_plugins()
    return motion, result


def test_round_trip_keeps_every_field(small):
    motion, result = small
    c = unpack(result.data)
    assert c.codec == "svd" and c.codec_version == 2 and c.codec_plugin == "motionrep_svd"
    assert c.representation == "root-quat-axis-angle" and c.representation_plugin == "motionrep_rootquat"
    assert c.skeleton == motion.skeleton and c.fps == motion.fps and c.num_frames == motion.num_frames
    assert c.params == {"rank": 1, "dtype": "float32"} and c.info == {"rank": 1}
    assert set(c.arrays) == {"mean", "coefficients", "basis"}
    for name, a in result.container.arrays.items():
        assert c.arrays[name].dtype == a.dtype and np.array_equal(c.arrays[name], a)
    assert c.evaluation["max_error"] == result.report.max_error and c.evaluation["bound"] is None
    assert pack(c) == result.data  # packing is deterministic and lossless


def test_decoded_motion_matches_stored_evaluation(small, tmp_path):
    motion, result = small
    path = tmp_path / "a.mrc"
    assert write_container(result.data, path) == len(result.data)
    decoded = decompress_file(path)
    assert max_joint_error(motion, decoded).max_error == result.report.max_error
    assert read_container(path).num_parameters == result.container.num_parameters


def test_every_truncation_is_detected(small):
    data = small[1].data
    for n in range(len(data)):
        with pytest.raises(ContainerError):
            unpack(data[:n])
    with pytest.raises(ContainerError, match="extra bytes"):
        unpack(data + b"\0")


@pytest.mark.parametrize("mask", [0x01, 0x80, 0xFF])
def test_every_single_byte_change_is_detected(small, mask):
    data = small[1].data
    for i in range(len(data)):
        altered = bytearray(data)
        altered[i] ^= mask
        with pytest.raises(ContainerError):
            unpack(bytes(altered))


def test_errors_name_the_file(small, tmp_path):
    path = tmp_path / "bad.mrc"
    path.write_bytes(small[1].data[:-3])
    with pytest.raises(ContainerError, match="bad.mrc.*truncated"):
        read_container(path)
    path.write_bytes(b"BVH HIERARCHY\n" * 3)
    with pytest.raises(ContainerError, match="not a motionrep .mrc file"):
        read_container(path)


def _reseal(body: bytes) -> bytes:
    """Fix the length field and the CRC of an edited container (to test checks behind the checksum)."""
    body = body[:12] + struct.pack("<I", len(body) + 4) + body[16:]
    return body + struct.pack("<I", zlib.crc32(body))


def test_unknown_container_version_is_refused(small):
    data = small[1].data
    edited = _reseal(data[:8] + struct.pack("<H", CONTAINER_VERSION + 1) + data[10:-4])
    with pytest.raises(ContainerError, match="unsupported .mrc container version 2"):
        unpack(edited)


def test_unknown_codec_names_codec_and_plugin(small):
    c = dataclasses.replace(unpack(small[1].data), codec="haar", codec_plugin="motionrep-haar")
    with pytest.raises(UnknownPluginError, match="unknown codec 'haar'.*motionrep-haar"):
        decompress(pack(c))


def test_unknown_representation_names_it_and_plugin(small):
    c = dataclasses.replace(unpack(small[1].data), representation="bones", representation_plugin="motionrep-bones")
    with pytest.raises(UnknownPluginError, match="unknown representation 'bones'.*motionrep-bones"):
        decompress(pack(c))


def test_newer_codec_payload_version_is_refused(small, tmp_path):
    c = dataclasses.replace(unpack(small[1].data), codec_version=99)
    with pytest.raises(PluginVersionError, match="payload version 99"):
        decompress(pack(c))
    path = tmp_path / "new.mrc"
    write_container(c, path)
    with pytest.raises(FormatError) as info:  # a file problem, naming the file and its plugin
        decompress_file(path)
    assert str(info.value).startswith(f"{path}: codec 'svd' payload version 99") and "motionrep_svd" in str(info.value)


def test_newer_representation_version_is_refused(small):
    c = dataclasses.replace(unpack(small[1].data), representation_version=7)
    with pytest.raises(PluginVersionError, match="representation 'root-quat-axis-angle' version 7"):
        decompress(pack(c))


def test_unsupported_dtype_is_refused_when_packing(small):
    c = dataclasses.replace(unpack(small[1].data), arrays={"x": np.array(["a"])})
    with pytest.raises(Exception, match="unsupported dtype"):
        pack(c)


def test_spec_describes_the_bytes(small):
    """Parse a file with struct, zlib and json only, following specs/container.md."""
    spec = SPEC.read_text()
    for needle in ("<8sHHII", "zlib", "CRC-32", "little-endian", "sort_keys"):
        assert needle in spec
    data = small[1].data
    magic, version, flags, total, meta_len = struct.unpack_from("<8sHHII", data, 0)
    assert magic == b"\x89MRC\r\n\x1a\n" == MAGIC and version == 1 and flags == 0 and total == len(data)
    (crc,) = struct.unpack_from("<I", data, total - 4)
    assert crc == zlib.crc32(data[:-4])
    meta = json.loads(zlib.decompress(data[20:20 + meta_len]))
    assert set(meta) == {"codec", "representation", "skeleton", "fps", "num_frames", "evaluation", "arrays", "extra"}
    assert meta["codec"]["name"] == "svd" and meta["num_frames"] == 12
    offset = 20 + meta_len
    sizes = {"f2": 2, "f4": 4, "f8": 8}
    for entry in meta["arrays"]:
        count = int(np.prod(entry["shape"]))
        raw = data[offset:offset + count * sizes[entry["dtype"]]]
        values = np.frombuffer(raw, dtype="<" + entry["dtype"]).reshape(entry["shape"])
        assert np.array_equal(values, small[1].container.arrays[entry["name"]])
        offset += len(raw)
    assert offset == total - 4


def test_metadata_is_small_next_to_the_payload_of_a_long_clip():
    """A 900-frame clip's file is dominated by its payload (here a 15-joint humanoid, svd rank 8)."""
    from motionrep.synthetic import humanoid_skeleton

    motion = synthetic_motion(humanoid_skeleton(), frames=900, seed=1)
    data = compress_motion(motion, "svd", params={"rank": 8}, max_error=None).data
    meta_len = struct.unpack_from("<I", data, 16)[0]
    assert meta_len < 0.1 * len(data)
