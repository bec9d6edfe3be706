"""The svd codec's compiled decoder (``_csvd``) from Python: an object that was never initialised refuses to sample
(a ValueError, never a call through an empty sampler)."""

from __future__ import annotations

import numpy as np
import pytest

from motionrep_svd import _csvd


def test_an_uninitialised_decoder_refuses_to_sample():
    empty = _csvd.Decoder.__new__(_csvd.Decoder)
    with pytest.raises(ValueError, match="not initialised"):
        empty.sampler
    with pytest.raises(ValueError, match="not initialised"):
        _csvd.sample(np.zeros(2), np.zeros((3, 2)), empty)
