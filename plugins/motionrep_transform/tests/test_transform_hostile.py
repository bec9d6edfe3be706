"""A crafted transform payload whose CRC is valid but whose steps overflow (issue 27): one error, no numpy warning.
The stream is this plugin's own (``_stream``); the checks every codec gets are in ``tests/test_hostile_mrc.py``."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from motionrep.model.synthetic import synthetic_motion
from motionrep.pipeline.compress import Pipeline
from motionrep_transform import _stream2
from motionrep_transform._decoder import STREAMS

from helpers import refused_mrc


@pytest.fixture(scope="module")
def transform():
    return Pipeline.build("transform").compress(synthetic_motion(frames=60)).container


@pytest.mark.parametrize("version", [1, 2, 3])
def test_transform_step_that_overflows_is_one_error_without_warnings(transform, version):
    stream = STREAMS[version]
    q = _stream2.unpack(np.asarray(transform.arrays["data"]).tobytes())
    q = dataclasses.replace(q, region_exponents=np.full_like(q.region_exponents, 32_000))
    bad = dataclasses.replace(transform, arrays={"data": np.frombuffer(stream.pack(q), np.uint8)},
                              codec_version=version)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a numpy overflow warning printed before the error is the bug
        refused_mrc(bad, "not finite")
