"""Shared fixtures: isolation from installed third-party plugins, paths to the real clips in ../shared/data."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

# Third-party plugins installed in the environment must not change what the tests see; tests that need one
# load it explicitly (see tests/test_plugins.py).
os.environ["MOTIONREP_LOAD_PLUGINS"] = ""

REPO = Path(__file__).resolve().parent.parent
SHARED_DATA = Path(os.environ.get("MOTIONREP_SHARED_DATA", REPO.parent / "shared" / "data"))
HAVE_SHARED = SHARED_DATA.is_dir()

requires_shared = pytest.mark.skipif(not HAVE_SHARED, reason=f"real clips not found at {SHARED_DATA}")


def real_bvh_files(*subdirs: str) -> list[Path]:
    """Every valid real BVH file under ../shared/data (malformed ones excluded); [] when absent."""
    if not HAVE_SHARED:
        return []
    roots = [SHARED_DATA / s for s in subdirs] if subdirs else [SHARED_DATA]
    files = sorted(p for r in roots for p in r.rglob("*.bvh") if "malformed" not in p.parts)
    return files


def real_params(*subdirs: str):
    """pytest parameters over real BVH files, ids relative to ../shared/data, marked realdata."""
    files = real_bvh_files(*subdirs)
    if not files:
        return [pytest.param(None, marks=[requires_shared, pytest.mark.realdata], id="no-shared-data")]
    return [pytest.param(p, marks=pytest.mark.realdata, id=str(p.relative_to(SHARED_DATA))) for p in files]


@pytest.fixture(autouse=True)
def _fresh_plugins():
    """Each test starts with the plugin registry unloaded, so environment changes take effect."""
    from motionrep.plugins import reset_plugins

    reset_plugins()
    yield
    reset_plugins()
