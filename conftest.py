"""pytest set-up for every test of the repository (``tests/`` and the shipped plugins' ``plugins/*/tests/``):
isolation from installed third-party plugins, a fresh plugin registry for each test, and the fixtures tests of
both share.  Helpers that tests import (the CLI runner, paths to the real clips in ``../shared/data``) are in
``tests/helpers.py``."""

from __future__ import annotations

import os

import pytest

# Third-party plugins installed in the environment must not change what the tests see; tests that need one
# load it explicitly (see tests/test_plugins.py).
os.environ["MOTIONREP_LOAD_PLUGINS"] = ""


@pytest.fixture(autouse=True)
def _fresh_plugins():
    """Each test starts with the plugin registry unloaded, so environment changes take effect."""
    from motionrep.plugin.registry import reset_plugins

    reset_plugins()
    yield
    reset_plugins()


@pytest.fixture(scope="session")
def chain_motion():
    """A three-joint chain, 48 frames at 30 fps swinging twice by 20 degrees: small enough for any codec's tests
    (a Motion is immutable, so one for the session)."""
    from motionrep.model.synthetic import chain_skeleton, synthetic_motion

    return synthetic_motion(chain_skeleton(3), frames=48, fps=30, seed=1, cycles=2, amplitude_deg=20)
