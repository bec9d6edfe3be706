"""The batch engine (``motionrep.batch.engine``): results in item order on any executor, errors raised, the same bytes
in this process as on another executor."""

from __future__ import annotations

import concurrent.futures as cf

import pytest

from motionrep.batch.engine import compress_clips, run_batch
from motionrep.pipeline.compress import Pipeline
from motionrep.io import write
from motionrep.pipeline.sources import collect_clips
from motionrep.model.synthetic import chain_skeleton, synthetic_motion


def _square(x: int) -> int:
    return x * x


def _fail_on_three(x: int) -> int:
    if x == 3:
        raise ValueError("three")
    return x


def test_results_in_item_order_in_process_and_on_an_executor():
    done: list[tuple[int, int, int]] = []
    assert run_batch(_square, range(6), on_done=lambda i, item, result: done.append((i, item, result))) == \
        [0, 1, 4, 9, 16, 25]
    assert done == [(i, i, i * i) for i in range(6)]  # in process: in order
    done.clear()
    with cf.ThreadPoolExecutor(3) as pool:
        out = run_batch(_square, range(6), executor=pool, on_done=lambda i, item, result: done.append((i, item,
                                                                                                   result)))
        assert out == [0, 1, 4, 9, 16, 25]
        assert sorted(done) == [(i, i, i * i) for i in range(6)]
        assert run_batch(_square, [7], executor=pool) == [49]  # the executor is the caller's: still open
    assert run_batch(_square, []) == []


def test_errors_are_raised():
    with pytest.raises(ValueError, match="three"):
        run_batch(_fail_on_three, range(6))
    with cf.ThreadPoolExecutor(2) as pool, pytest.raises(ValueError, match="three"):
        run_batch(_fail_on_three, range(6), executor=pool)


def test_compress_clips_gives_the_same_bytes_on_an_executor(tmp_path):
    for i in range(3):
        write(synthetic_motion(chain_skeleton(3 + i), frames=20 + i, seed=i), tmp_path / f"c{i}.bvh")
    refs = collect_clips([tmp_path])
    pipeline = Pipeline.build("svd", max_error="2%")
    here = compress_clips(refs, pipeline)
    with cf.ThreadPoolExecutor(2) as pool:
        there = compress_clips(refs, pipeline, executor=pool)
    assert [o.name for o in here] == ["c0", "c1", "c2"] and not any(o.failed for o in here)
    assert [o.data for o in here] == [o.data for o in there]
    failed = compress_clips(refs[:1], Pipeline.build("svd", params={"rank": 0}, max_error="0.001%"))
    assert failed[0].failed and failed[0].summary["type"] == "BoundNotMetError"
