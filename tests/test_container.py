"""The .mrc container: round trip, determinism, every truncation and byte flip detected, the spec's layout."""

from __future__ import annotations

import dataclasses
import json
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

from motionrep.pipeline.compress import compress_motion, decompress, decompress_file
from motionrep.io.container import CONTAINER_VERSION, MAGIC, pack, read_container, unpack, write_container
from motionrep.errors import ContainerError, FormatError, PluginVersionError, UnknownPluginError, ValidationError
from motionrep.pipeline.evaluate import max_joint_error
from motionrep.model.synthetic import chain_skeleton, synthetic_motion

SPEC = Path(__file__).resolve().parent.parent / "specs" / "container.md"


@pytest.fixture(scope="module")
def small():
    """A small real container: 12 frames of a 3-joint chain, svd rank 1, no bound."""
    from motionrep.plugin.registry import reset_plugins

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
    with pytest.raises(ContainerError, match=f"unsupported .mrc container version {CONTAINER_VERSION + 1} "
                                             r"\(this motionrep reads 1, 2\)"):
        unpack(edited)


@pytest.mark.parametrize("max_error", ["2%", "1.5", None])
def test_a_version_1_file_still_reads_with_its_bound_structured(max_error):
    """Version 1 stated the bound as text (``extra.max_error``); it reads as the same structured bound a version-2
    file stores, and decodes to the same motion."""
    from helpers import mrc_version_1
    from motionrep.model.bound import MaxError

    motion = synthetic_motion(chain_skeleton(3), frames=12, seed=2)
    result = compress_motion(motion, "svd", params={"rank": 2} if max_error is None else {}, max_error=max_error)
    old = mrc_version_1(result.data)
    assert struct.unpack_from("<H", old, 8) == (1,) and struct.unpack_from("<H", result.data, 8) == (2,)
    assert b"max_error" in zlib.decompress(old[20:20 + struct.unpack_from("<I", old, 16)[0]])
    c_old, c_new = unpack(old), unpack(result.data)
    assert c_old.bound == c_new.bound and "max_error" not in c_old.extra  # one home: the structured bound
    if max_error is None:
        assert c_new.bound.kind == "none" and c_new.bound.distance is None
    else:
        assert c_new.bound.asked == MaxError(float(max_error.rstrip("%")), max_error.endswith("%"))
        assert c_new.bound.distance == result.bound == c_new.evaluation["bound"]
    assert np.array_equal(decompress(old).rotations, decompress(result.data).rotations)


def test_a_version_1_file_without_a_bound_says_none():
    """A version-1 file whose writer stated no bound at all (another tool): the bound is unknown, not 'none'."""
    from helpers import mrc_version_1

    motion = synthetic_motion(chain_skeleton(3), frames=12, seed=2)
    data = compress_motion(motion, "svd", params={"rank": 2}, max_error=None).data
    meta_len = struct.unpack_from("<I", data, 16)[0]
    meta = json.loads(zlib.decompress(data[20:20 + meta_len]))
    meta.pop("bound")
    text = zlib.compress(json.dumps(meta, sort_keys=True, separators=(",", ":")).encode(), 9)
    v2 = _reseal(data[:16] + struct.pack("<I", len(text)) + text + data[20 + meta_len:-4])
    assert unpack(v2).bound is None  # version 2 without the key
    assert unpack(mrc_version_1(v2)).bound is None  # version 1 without extra.max_error


def test_the_bound_is_stored_structured():
    motion = synthetic_motion(chain_skeleton(3), frames=12, seed=2)
    result = compress_motion(motion, "svd", max_error="2%")
    meta = json.loads(zlib.decompress(result.data[20:20 + struct.unpack_from("<I", result.data, 16)[0]]))
    assert meta["bound"] == {"kind": "percent", "value": 2.0, "distance": result.bound}
    assert "max_error" not in meta["extra"]


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
    with pytest.raises(ValidationError, match="unsupported dtype"):
        pack(c)


def test_spec_describes_the_bytes(small):
    """Parse a file with struct, zlib and json only, following specs/container.md."""
    spec = SPEC.read_text()
    for needle in ("<8sHHII", "zlib", "CRC-32", "little-endian", "sort_keys"):
        assert needle in spec
    data = small[1].data
    magic, version, flags, total, meta_len = struct.unpack_from("<8sHHII", data, 0)
    assert magic == b"\x89MRC\r\n\x1a\n" == MAGIC and version == 2 and flags == 0 and total == len(data)
    (crc,) = struct.unpack_from("<I", data, total - 4)
    assert crc == zlib.crc32(data[:-4])
    meta = json.loads(zlib.decompress(data[20:20 + meta_len]))
    assert set(meta) == {"codec", "representation", "skeleton", "fps", "num_frames", "evaluation", "arrays", "extra",
                         "bound"}
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
    from motionrep.model.synthetic import humanoid_skeleton

    motion = synthetic_motion(humanoid_skeleton(), frames=900, seed=1)
    data = compress_motion(motion, "svd", params={"rank": 8}, max_error=None).data
    meta_len = struct.unpack_from("<I", data, 16)[0]
    assert meta_len < 0.1 * len(data)


# ---- a codec checks its own outcome (Codec.check_info); the core checks only that it is plain JSON --------------
@pytest.mark.parametrize("codec, info, message", [
    ("svd", {"rank": "9"}, "'rank' must be an integer"),
    ("svd", {"rank": True}, "'rank' must be an integer"),
    ("adaptive-fourier", {"K": 2, "omega": "abc"}, "'omega' must be an array of numbers or an array of arrays"),
    ("adaptive-fourier", {"K": [[1]], "omega": [[1.0]]}, "'K' must be an integer or an array of integers"),
    ("naive-fourier", {"K": 1, "omega": [1.0], "steps": [1.5, 2, 3]}, "'steps' must be an array of integers or"),
    ("naive-fourier", {"K": 1, "omega": [1.0], "iterations": [3]}, "'iterations' must be an integer"),
])
def test_a_shipped_codec_refuses_an_outcome_it_never_writes(small, tmp_path, codec, info, message):
    path = tmp_path / "edited.mrc"
    write_container(dataclasses.replace(unpack(small[1].data), codec=codec, info=info), path)
    with pytest.raises(ContainerError) as caught:
        read_container(path)
    line = str(caught.value)
    assert "\n" not in line and "edited.mrc" in line and f"codec {codec!r} refuses its outcome" in line
    assert message in line


@pytest.mark.parametrize("codec, info", [
    ("svd", {"rank": 1, "K": "x", "omega": "abc"}),  # another codec's words: not svd's concern
    ("adaptive-fourier", {"K": 5, "omega": [1.0, 2.5], "hidden": 22, "iterations": 300, "steps": [3, -4, 7],
                          "parameters": 500}),
    ("adaptive-fourier", {"windows": 2, "K": [1, 2], "omega": [[1.0], [2.0, 3]], "hidden": [6, 10],
                          "iterations": 90, "steps": [[1, 2, 3], [4, 5, 6]], "parameters": 77}),
])
def test_a_shipped_codec_reads_every_outcome_it_writes(small, codec, info):
    assert unpack(pack(dataclasses.replace(unpack(small[1].data), codec=codec, info=info))).info == info


def _third_party(check_info=None):
    """A codec of a third party, registered through the public hook: stores the features, decodes the nearest
    frame; with ``check_info`` given, that is its check of its outcome (otherwise it has none of its own)."""
    from dataclasses import dataclass, field

    from motionrep.plugin import registry as plugins
    from motionrep.plugin.codec import Codec, Payload
    from motionrep.plugin.hookspecs import hookimpl

    @dataclass(frozen=True)
    class Params:
        unused: int = field(default=0, metadata={"help": "unused"})

    members = {"name": "stored", "format_version": 1, "Params": Params,
               "encode": lambda self, features, weights, context: Payload({"f": np.array(features)},
                                                                         {"K": "its own", "frames": len(features)}),
               "decode": lambda self, payload, times: np.asarray(payload.arrays["f"], np.float64)[
                   np.rint(np.asarray(times) * (payload.arrays["f"].shape[0] - 1)).astype(int)]}
    if check_info is not None:
        members["check_info"] = lambda self, info: check_info(info)
    codec = type("Stored", (Codec,), members)()

    class Plugin:
        @staticmethod
        @hookimpl
        def register_codecs(register):
            register(codec)

    plugins.pm.register(Plugin(), name="test-stored-codec")
    return codec


def test_a_codec_without_its_own_check_reads_any_plain_outcome(small, tmp_path):
    """The words of the shipped codecs mean nothing to a third party's codec: its ``"K": "its own"`` (which
    the core once refused as not an integer) is read, described and decoded."""
    from motionrep.pipeline.compress import describe_outcome

    codec = _third_party()
    motion = small[0]
    data = compress_motion(motion, codec, max_error=None).data
    c = unpack(data)
    assert c.info == {"K": "its own", "frames": 12}
    assert describe_outcome(c) == "K=its own, frames=12"
    crafted = pack(dataclasses.replace(c, info={"omega": "abc", "rank": [True], "K": {"deep": [[[]]]}}))
    assert max_joint_error(motion, decompress(crafted)).max_error == c.evaluation["max_error"]


def test_a_third_party_check_names_the_file_in_one_line(small, tmp_path):
    from motionrep.errors import PayloadError

    def strict(info):
        if info.get("frames") != 12:
            raise PayloadError("'frames' must be 12")
        info["K"].upper()  # a bug that a crafted value finds: an AttributeError, not a traceback

    codec = _third_party(strict)
    c = unpack(compress_motion(small[0], codec, max_error=None).data)
    path = tmp_path / "third.mrc"
    for info, message in (({"frames": 11, "K": "x"}, "refuses its outcome 'codec.info': 'frames' must be 12"),
                          ({"frames": 12, "K": 3}, "refuses its outcome 'codec.info': AttributeError")):
        write_container(dataclasses.replace(c, info=info), path)
        with pytest.raises(ContainerError, match=f"third.mrc.*{message}"):
            read_container(path)


def test_the_conformance_suite_checks_the_outcome_against_check_info():
    from motionrep.errors import PayloadError
    from motionrep.testing import check_codec

    def refuse_text(info):
        if isinstance(info.get("K"), str):
            raise PayloadError("'K' must be an integer")

    with pytest.raises(AssertionError, match="check_info refuses the codec's own outcome .*'K' must be an integer"):
        check_codec(_third_party(refuse_text), bound_fraction=None)


def test_check_info_numbers_says_what_a_key_must_be():
    from motionrep.plugin.codec import check_info_numbers
    from motionrep.errors import PayloadError

    check_info_numbers({}, "K", integers=True)  # absent: nothing to check
    check_info_numbers({"K": [4, 6]}, "K", integers=True, arrays=(0, 1))
    check_info_numbers({"omega": [[1.5], [2, 3]]}, "omega", arrays=(1, 2))
    for info, key, kwargs, message in (
            ({"K": 1.0}, "K", {"integers": True}, "'K' must be an integer"),
            ({"x": float("nan")}, "x", {}, "'x' must be a number"),
            ({"x": [1, [2]]}, "x", {"arrays": (1, 2)}, "'x' must be an array of numbers or an array of arrays of "
                                                       "numbers"),
            ({"x": 1}, "x", {"arrays": (1, 1)}, "'x' must be an array of numbers")):
        with pytest.raises(PayloadError, match=f"^{message}$".replace("[", r"\[")):
            check_info_numbers(info, key, **kwargs)
