"""Compressed bytes and decoded values never depend on the number of BLAS threads (issue 14): the same clip gives
the same ``.mrc`` bytes in a one-thread batch worker and in a process with two BLAS threads."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from helpers import SHARED_DATA, requires_shared

# svd on this 2,575-frame, 43-joint clip gave different bytes with 1 and 2 OpenBLAS threads before encoding and
# decoding ran with one BLAS thread (synthetic clips did not show it: it takes real data's sizes and values)
CLIP = SHARED_DATA / "cmu" / "beemsoft_salsa" / "60_09_scaled.bvh"

SCRIPT = """
import hashlib, sys
import motionrep
from motionrep.pipeline.compress import compress_motion, decompress
m = motionrep.read(sys.argv[1])
data = compress_motion(m, "svd").data
decoded = decompress(data)
print(hashlib.sha256(data).hexdigest(), hashlib.sha256(decoded.rotations.tobytes()).hexdigest())
"""


def _run(threads: int) -> str:
    env = dict(os.environ, OPENBLAS_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads),
               MKL_NUM_THREADS=str(threads))
    out = subprocess.run([sys.executable, "-c", SCRIPT, str(CLIP)], env=env, capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


@requires_shared
@pytest.mark.realdata
def test_compressed_bytes_and_decoded_values_do_not_depend_on_blas_threads():
    assert _run(1) == _run(2)


def test_one_blas_thread_limits_and_restores():
    from threadpoolctl import threadpool_info

    from motionrep._threads import one_blas_thread

    before = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    with one_blas_thread():
        with one_blas_thread():  # nested: one limit
            assert all(i["num_threads"] == 1 for i in threadpool_info() if i["user_api"] == "blas")
        assert all(i["num_threads"] == 1 for i in threadpool_info() if i["user_api"] == "blas")
    assert [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"] == before
