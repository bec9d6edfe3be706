"""Crafted ``.mrc`` files whose CRC is valid but whose counts disagree (issue 27): each is refused with one line
naming both numbers, before anything is decoded; decode work is bounded by the payload's size."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from motionrep import limits
from motionrep.pipeline.compress import Pipeline, decompress
from motionrep.io.container import pack, unpack
from motionrep.errors import ContainerError
from motionrep.model.synthetic import synthetic_motion

from helpers import refused_mrc


@pytest.fixture(scope="module")
def motion():
    return synthetic_motion(frames=60)


@pytest.fixture(scope="module")
def transform(motion):
    return Pipeline.build("transform").compress(motion).container


@pytest.fixture(scope="module")
def windows(motion):
    return Pipeline.build("adaptive-fourier", params={"k": 1, "iters": 25, "window": 20},
                          max_error=None).compress(motion).container


@pytest.mark.parametrize("frames", [120, 2, 59])
def test_metadata_frames_disagree_with_transform_payload(transform, frames):
    bad = dataclasses.replace(transform, num_frames=frames, evaluation=dict(transform.evaluation, num_frames=frames,
                                                                          frame=0))
    refused_mrc(bad, "60 frames", str(frames))


@pytest.mark.parametrize("frames", [120, 2, 59])
def test_metadata_frames_disagree_with_fourier_window_edges(windows, frames):
    bad = dataclasses.replace(windows, num_frames=frames, evaluation=dict(windows.evaluation, num_frames=frames,
                                                                        frame=0))
    refused_mrc(bad, "frame 59", str(frames))


def test_stored_evaluation_disagrees_with_metadata(transform):
    bad = dataclasses.replace(transform, evaluation=dict(transform.evaluation, num_frames=30))
    with pytest.raises(ContainerError, match="num_frames is 60, the stored evaluation was measured on 30"):
        unpack(pack(bad), "crafted.mrc")
    bad = dataclasses.replace(transform, evaluation=dict(transform.evaluation, num_points=3))
    with pytest.raises(ContainerError, match="measured on 3 points"):
        unpack(pack(bad), "crafted.mrc")


@pytest.mark.parametrize("version", [1, 2])
def test_transform_payload_declaring_a_million_frames_is_refused_before_decoding(transform, version):
    from motionrep.plugin.coding import IntegerEncoder

    if version == 1:
        enc = IntegerEncoder()
        enc.encode_raw([999_999], 32)
        enc.encode_raw([50], 20)
        enc.encode_raw([63], 16)
        head = enc.to_bytes()
    else:  # frames - 1, features - 1, region - 1 as LEB128
        head = bytes([0xBF, 0x84, 0x3D, 50, 63])
    data = np.frombuffer(head + bytes(9000), np.uint8)
    bad = dataclasses.replace(transform, arrays={"data": data}, codec_version=version)
    refused_mrc(bad, "1000000 frames", "has 60")


def test_decode_work_beyond_the_limit_is_refused(transform, monkeypatch):
    monkeypatch.setattr(limits, "DECODE_FREE_WORK", 1000)
    with limits.override(max_decode_work=1):
        text = refused_mrc(transform, "MOTIONREP_MAX_DECODE_WORK", "decode work")
    assert "60 frames" in text
    decompress(pack(transform))  # within the default limit


def test_decode_work_limit_from_the_environment(monkeypatch):
    monkeypatch.setenv("MOTIONREP_MAX_DECODE_WORK", "7")
    assert limits.current().max_decode_work == 7


@pytest.mark.parametrize("value", ["abc", [1], True, "-2%"])
def test_stored_max_error_that_is_no_bound_names_the_file(transform, value):
    """A version-1 file's bound is the text ``extra.max_error``."""
    from helpers import mrc_version_1

    with pytest.raises(ContainerError) as info:
        unpack(mrc_version_1(pack(transform), max_error=value), "crafted.mrc")
    assert "crafted.mrc" in str(info.value) and "extra.max_error" in str(info.value)
    assert "--max-error" not in str(info.value)


@pytest.mark.parametrize("bound, words", [
    ({"kind": "abc", "value": 2.0, "distance": 1.0}, "'kind' is 'abc'"),
    ({"kind": "percent", "value": "2%", "distance": 1.0}, "'value' must be a finite number > 0"),
    ({"kind": "percent", "value": 0, "distance": 1.0}, "'value' must be a finite number > 0"),
    ({"kind": "distance", "value": 2.0, "distance": None}, "'distance' must be a finite number >= 0"),
    ({"kind": "none", "value": 2.0, "distance": None}, "'value' must be null"),
    ([1], "must be an object"),
    ({"kind": "distance", "value": 2.0, "distance": 2.5}, "the stored evaluation enforced"),
])
def test_stored_bound_that_is_no_bound_names_the_file(transform, bound, words):
    """A version-2 file's bound is the object ``bound``: a crafted one is the file's fault, named."""
    import json
    import struct
    import zlib

    data = pack(transform)
    meta_len = struct.unpack_from("<I", data, 16)[0]
    meta = json.loads(zlib.decompress(data[20:20 + meta_len]))
    meta["bound"] = bound
    text = zlib.compress(json.dumps(meta, sort_keys=True).encode(), 9)
    body = data[:12] + struct.pack("<II", 20 + len(text) + len(data) - 24 - meta_len + 4, len(text)) + text + \
        data[20 + meta_len:-4]
    with pytest.raises(ContainerError) as info:
        unpack(body + struct.pack("<I", zlib.crc32(body)), "crafted.mrc")
    text = str(info.value)
    assert "crafted.mrc" in text and words in text and "--max-error" not in text, text


def test_cli_info_of_stored_max_error_abc(transform, tmp_path, capsys):
    from helpers import mrc_version_1
    from motionrep.cli import main

    path = tmp_path / "bad.mrc"
    path.write_bytes(mrc_version_1(pack(transform), max_error="abc"))
    with pytest.raises(SystemExit) as info:
        main(["info", str(path)])
    assert info.value.code == 1
    err = capsys.readouterr().err.strip()
    assert "bad.mrc" in err and "extra.max_error" in err and len(err.splitlines()) == 1, err


def test_fourier_decode_work_beyond_the_limit_is_refused(windows, monkeypatch):
    monkeypatch.setattr(limits, "DECODE_FREE_WORK", 1000)
    with limits.override(max_decode_work=1):
        refused_mrc(windows, "MOTIONREP_MAX_DECODE_WORK", "3 window(s) over 60 frames")
    decompress(pack(windows))
