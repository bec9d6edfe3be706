"""The size vocabulary (motionrep.pipeline.figures): one definition per figure, the same in every report."""

from __future__ import annotations

import pytest

from motionrep.pipeline import figures as fg
from motionrep.errors import ValidationError
from motionrep.pipeline.figures import compression_figures
from motionrep.batch.totals import BatchTotals


def test_each_figure_has_one_definition():
    assert fg.bones(31, 5) == 36
    assert fg.payload_bits_per_bone_frame(960, 450 * 20) == pytest.approx(8 * 960 / 9000)
    assert fg.file_bits_per_bone_frame(1655, 450 * 20) == pytest.approx(8 * 1655 / 9000)
    assert fg.ratio_vs_source(204_000, 1655) == pytest.approx(204_000 / 1655)
    assert fg.ratio_vs_source(None, 1655) is None
    with pytest.raises(ValidationError):
        fg.file_bits_per_bone_frame(10, 0)


def test_compression_figures_and_totals_use_the_same_names_and_definitions():
    f = compression_figures(num_frames=450, feature_width=49, num_parameters=960, num_channels=51, num_joints=15,
                            compressed_bytes=1655, source_bytes=204_000, num_end_sites=5, payload_bytes=960)
    d = f.as_dict()
    assert d[fg.PAYLOAD_BPBF] == pytest.approx(8 * 960 / (450 * 20))
    assert d[fg.FILE_BPBF] == pytest.approx(8 * 1655 / (450 * 20))
    assert d[fg.RATIO_VS_SOURCE] == pytest.approx(204_000 / 1655)
    line = f.summary()  # the first size line: short, the three named figures only
    assert "payload bits/bone/frame" in line and "file bits/bone/frame" in line and "smaller than source" in line
    assert "paper" not in line and "float32" not in line and "paper ratio" in f.details()
    from types import SimpleNamespace as NS

    from motionrep.batch.engine import ClipOutcome

    container = NS(num_frames=450, skeleton=NS(num_joints=15, num_end_sites=5, num_channels=51), payload_bytes=960,
                   evaluation=None)
    outcome = ClipOutcome("walk", "walk.bvh", result=NS(container=container, data=b"\0" * 1655, figures=f))
    t = BatchTotals.of([outcome, outcome]).as_dict()
    assert t[fg.PAYLOAD_BPBF] == pytest.approx(d[fg.PAYLOAD_BPBF])  # two equal clips: the same figures
    assert t[fg.FILE_BPBF] == pytest.approx(d[fg.FILE_BPBF])
    assert t[fg.RATIO_VS_SOURCE] == pytest.approx(d[fg.RATIO_VS_SOURCE])
