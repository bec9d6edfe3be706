"""The example third-party plugin (plugins/examples/motionrep-keyframe) is found through the ``motionrep``
entry-point group exactly as if pip-installed, obeys MOTIONREP_LOAD_PLUGINS, conforms, and stays out of the
motionrep distribution.

"Installed" here means what pip leaves in site-packages: the import package next to a
``<name>-<version>.dist-info`` directory whose ``entry_points.txt`` is generated from the example's own
``pyproject.toml``; that directory is put on ``sys.path`` (or ``PYTHONPATH`` for the command line), so
``importlib.metadata`` discovers it the way it discovers any installed distribution.  When this environment
can build wheels offline, a second test builds the real wheel with pip and checks it the same way.
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from motionrep.plugin import registry as plugins
from motionrep.plugin.codec import frame_times
from motionrep.errors import DuplicateNameError, ParameterError, PluginError
from motionrep.model.synthetic import synthetic_motion
from motionrep.testing import ConformanceContext, check_codec, check_representation
from helpers import run_cli_caught

tomllib = pytest.importorskip("tomllib")  # Python >= 3.11

REPO = Path(__file__).resolve().parent.parent
EXAMPLE = REPO / "plugins" / "examples" / "motionrep-keyframe"
REPRESENTATION_PLUGINS = ("motionrep_rootquat", "motionrep_dualquat", "motionrep_ortho6d", "motionrep_euler")


def _install(site: Path, project: dict, source: Path) -> None:
    """Lay ``project`` out in ``site`` as pip would: its packages and a dist-info with its entry points."""
    site.mkdir(parents=True, exist_ok=True)
    for package in project["tool"]["setuptools"]["packages"]:
        shutil.copytree(source / package, site / package, ignore=shutil.ignore_patterns("__pycache__"))
    meta = project["project"]
    dist = site / f"{meta['name'].replace('-', '_')}-{meta['version']}.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {meta['name']}\nVersion: {meta['version']}\n")
    lines = []
    for group, entries in meta.get("entry-points", {}).items():
        lines.append(f"[{group}]")
        lines.extend(f"{name} = {target}" for name, target in entries.items())
    (dist / "entry_points.txt").write_text("\n".join(lines) + "\n")
    (dist / "INSTALLER").write_text("test\n")


@pytest.fixture(scope="module")
def example_site(tmp_path_factory) -> Path:
    """The example plugin installed into a fresh site directory (nothing in the venv changes)."""
    project = tomllib.loads((EXAMPLE / "pyproject.toml").read_text())
    site = tmp_path_factory.mktemp("site")
    _install(site, project, EXAMPLE)
    return site


@pytest.fixture
def on_path(example_site, monkeypatch):
    """The example plugin importable and discoverable in this process, with MOTIONREP_LOAD_PLUGINS unset."""
    monkeypatch.syspath_prepend(str(example_site))
    monkeypatch.delenv("MOTIONREP_LOAD_PLUGINS", raising=False)
    monkeypatch.setattr(plugins, "DEFAULT_PLUGINS", REPRESENTATION_PLUGINS)  # independent of the codec plugins
    return example_site


def _env(*paths: Path, **variables: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "MOTIONREP_LOAD_PLUGINS"}
    env["PYTHONPATH"] = os.pathsep.join([str(p) for p in paths] + [p for p in [env.get("PYTHONPATH")] if p])
    env.update(variables)
    return env


def _plugins_json(env: dict[str, str]) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "motionrep", "plugins", "--json"], capture_output=True, text=True,
                          env=env)


# ---- discovery -------------------------------------------------------------------------------------------------
def test_found_through_the_entry_point_group(on_path):
    eps = [ep for ep in importlib.metadata.entry_points(group="motionrep") if ep.name == "keyframe"]
    assert len(eps) == 1 and eps[0].value == "motionrep_keyframe"
    assert eps[0].dist.name == "motionrep-keyframe" and eps[0].dist.version == "0.1.0"
    info = {i.name: i for i in plugins.plugin_infos()}["keyframe"]
    assert info.as_dict() == {"name": "keyframe", "version": "0.1.0", "shipped": False,
                              "distribution": "motionrep-keyframe",
                              "hooks": ["register_codecs", "register_representations"],
                              "representations": ["local-quaternion"], "codecs": ["keyframe"]}
    module = sys.modules["motionrep_keyframe"]
    assert Path(module.__file__).is_relative_to(on_path)  # the installed copy, not the source tree
    assert plugins.get_codec("keyframe").name == "keyframe"
    assert plugins.provider_of("keyframe") == "motionrep-keyframe"
    assert plugins.get_representation("local-quaternion").version == 1


@pytest.mark.parametrize("value, loaded", [("", False), ("keyframe", True), ("motionrep-keyframe", True),
                                           ("keyframe,motionrep-keyframe", True)])
def test_load_plugins_variable(on_path, monkeypatch, value, loaded):
    monkeypatch.setenv("MOTIONREP_LOAD_PLUGINS", value)
    assert ("keyframe" in {i.name for i in plugins.plugin_infos()}) is loaded
    assert ("keyframe" in plugins.codecs()) is loaded
    assert ("local-quaternion" in plugins.representations()) is loaded


def test_load_plugins_variable_with_an_unknown_name(on_path, monkeypatch):
    monkeypatch.setenv("MOTIONREP_LOAD_PLUGINS", "keyframes")
    with pytest.raises(PluginError, match="'keyframes', but no installed plugin has that name"):
        plugins.load_plugins()


def test_command_line_lists_the_example_when_installed(example_site):
    out = _plugins_json(_env(example_site))
    assert out.returncode == 0, out.stderr
    listed = {p["name"]: p for p in json.loads(out.stdout)}
    assert listed["keyframe"] == {"name": "keyframe", "version": "0.1.0", "shipped": False,
                                  "distribution": "motionrep-keyframe",
                                  "hooks": ["register_codecs", "register_representations"],
                                  "representations": ["local-quaternion"], "codecs": ["keyframe"]}
    assert set(plugins.DEFAULT_PLUGINS) <= {name for name, p in listed.items() if p["shipped"]}
    assert next(iter(listed)) == "keyframe"  # third-party plugins come first

    for value in ("keyframe", "motionrep-keyframe"):
        out = _plugins_json(_env(example_site, MOTIONREP_LOAD_PLUGINS=value))
        assert out.returncode == 0 and "keyframe" in {p["name"] for p in json.loads(out.stdout)}
    out = _plugins_json(_env(example_site, MOTIONREP_LOAD_PLUGINS=""))
    assert out.returncode == 0, out.stderr
    names = [p["name"] for p in json.loads(out.stdout)]
    assert "keyframe" not in names and names == sorted(plugins.DEFAULT_PLUGINS)


@pytest.fixture
def duplicate_site(tmp_path):
    """A second installed distribution, motionrep-dupe, that registers the example's representation name."""
    source = tmp_path / "src"
    (source / "motionrep_dupe").mkdir(parents=True)
    (source / "motionrep_dupe" / "__init__.py").write_text(
        "from motionrep.plugin.hookspecs import hookimpl\n"
        "from motionrep_ortho6d import Ortho6D\n\n\n"
        "class Same(Ortho6D):\n    name = 'local-quaternion'\n\n\n"
        "@hookimpl\ndef register_representations(register):\n    register(Same())\n")
    project = {"project": {"name": "motionrep-dupe", "version": "1.0",
                           "entry-points": {"motionrep": {"dupe": "motionrep_dupe"}}},
               "tool": {"setuptools": {"packages": ["motionrep_dupe"]}}}
    site = tmp_path / "site"
    _install(site, project, source)
    return site


def test_duplicate_name_names_both_plugins(on_path, duplicate_site, monkeypatch):
    monkeypatch.syspath_prepend(str(duplicate_site))
    with pytest.raises(DuplicateNameError) as info:
        plugins.load_plugins()
    assert "representation name 'local-quaternion' is registered twice" in str(info.value)
    assert "'keyframe'" in str(info.value) and "'dupe'" in str(info.value)
    result = run_cli_caught("plugins")
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "'keyframe'" in lines[0] and "'dupe'" in lines[0]
    # leaving one of them out resolves it
    monkeypatch.setenv("MOTIONREP_LOAD_PLUGINS", "keyframe")
    assert plugins.provider_of("local-quaternion", kind="representation") == "motionrep-keyframe"


def test_duplicate_name_from_the_command_line(example_site, duplicate_site):
    out = _plugins_json(_env(example_site, duplicate_site))
    assert out.returncode == 1
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "'keyframe'" in lines[0] and "'dupe'" in lines[0], out.stderr


# ---- the example's representation and codec ------------------------------------------------------------------
def test_example_conforms(on_path):
    from motionrep_keyframe import KeyframeCodec, LocalQuaternion

    check_representation(LocalQuaternion())
    results = check_codec(KeyframeCodec(), representation=LocalQuaternion(), params={"step": "6"})
    assert results[0]["bounded_error"] is not None


def test_keyframe_codec_stores_keyframes_and_interpolates(on_path):
    from motionrep_keyframe import KeyframeCodec, LocalQuaternion

    codec, rep = KeyframeCodec(), LocalQuaternion()
    m = synthetic_motion(frames=23)
    f, w = rep.to_features(m), rep.weights(m)
    ctx = ConformanceContext(m, rep, codec, codec.parse_params({"step": "5"}))
    payload = codec.encode(f, w, ctx)
    keys = [0, 5, 10, 15, 20, 22]
    np.testing.assert_array_equal(payload.arrays["keys"], f[keys].astype(np.float32))
    np.testing.assert_array_equal(payload.arrays["times"], frame_times(23)[keys])
    assert payload.info == {"step": 5, "keyframes": 6}
    assert codec.describe(payload.info) == "6 keyframes, step 5"  # as every command shows the outcome
    out = codec.decode(payload, frame_times(23))
    np.testing.assert_allclose(out[keys], f[keys], rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(out[7], 0.6 * out[5] + 0.4 * out[10], atol=1e-12)  # linear in between
    # with a bound, step is halved until the bound is met
    bounded = ConformanceContext(m, rep, codec, codec.parse_params({"step": "16"}), bound=0.2)
    payload = codec.encode(f, w, bounded)
    assert bounded.evaluate_payload(payload).max_error <= 0.2
    steps = [fields["step"] for stage, fields in bounded.progress_log]
    assert steps[0] == 16 and all(b == a // 2 for a, b in zip(steps, steps[1:])) and payload.info["step"] == steps[-1]
    with pytest.raises(ParameterError, match="step must be >= 1"):
        codec.parse_params({"step": "0"})


def test_example_is_usable_from_every_command(on_path, tmp_path, monkeypatch):
    """compress with the example codec and representation, decompress, and a clear error once it is gone."""
    from motionrep.io import read, write
    from motionrep.model.kinematics import character_height, global_positions

    motion = synthetic_motion(frames=40)
    src, mrc, back = tmp_path / "walk.bvh", tmp_path / "walk.mrc", tmp_path / "back.bvh"
    write(motion, src)
    result = run_cli_caught("compress", str(src), "-o", str(mrc), "--codec", "keyframe", "-r",
                                 "local-quaternion", "--max-error", "2%", "-p", "step=4")
    assert result.exit_code == 0, result.output
    assert re.search(r"codec keyframe: \d+ keyframes, step \d", result.output)  # the outcome in its own words
    result = run_cli_caught("decompress", str(mrc), "-o", str(back))
    assert result.exit_code == 0, result.output
    original = read(src)
    error = np.linalg.norm(global_positions(read(back)) - global_positions(original), axis=-1).max()
    assert error <= 0.02 * character_height(original.skeleton)
    monkeypatch.setenv("MOTIONREP_LOAD_PLUGINS", "")
    plugins.reset_plugins()
    result = run_cli_caught("decompress", str(mrc), "-o", str(tmp_path / "again.bvh"))
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "'keyframe'" in lines[0] and "motionrep-keyframe" in lines[0]


# ---- packaging --------------------------------------------------------------------------------------------------
def test_example_is_not_part_of_the_motionrep_distribution():
    from setuptools import find_packages

    config = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]["find"]
    found = {pkg for where in config["where"]
             for pkg in find_packages(str(REPO / where), include=config["include"])}
    assert {"motionrep", *REPRESENTATION_PLUGINS} <= found
    assert not any(p.startswith("motionrep_keyframe") for p in found)
    assert not any("examples" in p for p in found)


def _can_build_wheels_offline() -> bool:
    if importlib.util.find_spec("wheel") is not None:
        return True
    import setuptools

    major, minor = (int(x) for x in setuptools.__version__.split(".")[:2])
    return (major, minor) >= (70, 1)  # setuptools builds wheels itself from 70.1 on


@pytest.mark.skipif(not _can_build_wheels_offline(), reason="this environment cannot build wheels offline")
def test_example_builds_into_a_wheel_that_is_found(tmp_path):
    source = tmp_path / "src"
    shutil.copytree(EXAMPLE, source, ignore=shutil.ignore_patterns("__pycache__", "build", "*.egg-info"))
    dist = tmp_path / "dist"
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--no-index",
                            "--quiet", "--wheel-dir", str(dist), str(source)], capture_output=True, text=True,
                           env={**os.environ, "PIP_DISABLE_PIP_VERSION_CHECK": "1"})
    assert build.returncode == 0, build.stderr
    (wheel,) = dist.glob("motionrep_keyframe-0.1.0-*.whl")
    site = tmp_path / "site"
    with zipfile.ZipFile(wheel) as zf:
        names = zf.namelist()
        assert {n.split("/")[0] for n in names} == {"motionrep_keyframe", "motionrep_keyframe-0.1.0.dist-info"}
        entry_points = zf.read("motionrep_keyframe-0.1.0.dist-info/entry_points.txt").decode()
        assert "[motionrep]" in entry_points and "keyframe = motionrep_keyframe" in entry_points
        zf.extractall(site)
    out = _plugins_json(_env(site))
    assert out.returncode == 0, out.stderr
    listed = {p["name"]: p for p in json.loads(out.stdout)}
    assert listed["keyframe"]["distribution"] == "motionrep-keyframe"
    assert listed["keyframe"]["codecs"] == ["keyframe"]
