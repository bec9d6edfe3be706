"""Crafted Fourier payloads whose CRC is valid but whose window edges disagree with the clip (issue 27): refused with
one line before decoding.  The layout is this plugin's own (``_packed``); the checks every codec gets are in
``tests/test_hostile_mrc.py``."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from motionrep.model.synthetic import synthetic_motion
from motionrep.pipeline.compress import Pipeline
from motionrep_fourier._packed import pack as pack_data, unpack as unpack_data

from helpers import refused_mrc


@pytest.fixture(scope="module")
def windows():
    return Pipeline.build("adaptive-fourier", params={"k": 1, "iters": 25, "window": 20},
                          max_error=None).compress(synthetic_motion(frames=60)).container


@pytest.mark.parametrize("change", ["doubled", "short"])
def test_fourier_window_edges_doubled_or_short(windows, change):
    edges, scale, networks = unpack_data(windows.arrays["data"])
    edges = edges * 2 if change == "doubled" else np.concatenate([edges[:-1], [edges[-1] - 3]])
    bad = dataclasses.replace(windows, arrays={"data": pack_data(edges, scale, networks)})
    refused_mrc(bad, "window edges end at frame", "60 frames")
