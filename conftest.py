"""pytest set-up for every test of the repository (``tests/`` and the shipped plugins' ``plugins/*/tests/``):
isolation from installed third-party plugins, and a fresh plugin registry for each test.  Helpers that tests
import (paths to the real clips in ``../shared/data``) are in ``tests/helpers.py``."""

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
