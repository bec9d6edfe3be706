"""Plugin loading and registration: entry points, MOTIONREP_LOAD_PLUGINS, lazy single loading, duplicate and
invalid registrations, and the ``motionrep plugins`` command."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import types
from dataclasses import dataclass, field

import numpy as np
import pytest

import motionrep
from motionrep.plugin import registry as plugins
from motionrep.plugin.codec import Codec, Payload
from motionrep.errors import DuplicateNameError, PluginError, UnknownPluginError
from motionrep.plugin.representation import Representation
from motionrep.plugin.hookspecs import hookimpl

from motionrep_ortho6d import Ortho6D
from helpers import run_cli_caught

REPRESENTATION_PLUGINS = ("motionrep_rootquat", "motionrep_dualquat", "motionrep_ortho6d", "motionrep_euler")


def _representation(name: str):
    """A working representation called ``name`` (the ortho6d encoding under another name)."""
    return type("Renamed", (Ortho6D,), {"name": name})()


@dataclass(frozen=True)
class _RawParams:
    scale: float = field(default=1.0, metadata={"help": "unused"})


class _RawCodec(Codec):
    """Stores the features as they are; decodes the nearest frame."""

    name = "raw"
    format_version = 1
    Params = _RawParams

    def encode(self, features, weights, context):
        return Payload({"features": np.array(features)})

    def decode(self, payload, times):
        f = payload.arrays["features"]
        idx = np.rint(np.asarray(times) * (f.shape[0] - 1)).astype(int)
        return np.asarray(f[idx], np.float64)


def _codec(name: str):
    return type("Renamed", (_RawCodec,), {"name": name})()


def _module(name: str, reps=(), codecs=(), version="9.9.9"):
    """A plugin module registering the given objects through the public hooks."""
    module = types.ModuleType(name)
    module.__version__ = version
    if reps:
        @hookimpl
        def register_representations(register):
            for rep in reps:
                register(rep)

        module.register_representations = register_representations
    if codecs:
        @hookimpl
        def register_codecs(register):
            for codec in codecs:
                register(codec)

        module.register_codecs = register_codecs
    return module


class _EntryPoint:
    """What importlib.metadata gives for one entry point of an installed distribution."""

    def __init__(self, name: str, module, dist: str, version: str = "1.2.3", fail: Exception | None = None):
        self.name, self.value, self._module, self._fail = name, module.__name__, module, fail
        self.dist = types.SimpleNamespace(name=dist, version=version)

    def load(self):
        if self._fail is not None:
            raise self._fail
        return self._module


@pytest.fixture
def installed(monkeypatch):
    """Install fake distributions (entry points in the ``motionrep`` group) and load them all
    (``MOTIONREP_LOAD_PLUGINS`` unset); shipped plugins: the representations only, so these tests do not depend
    on the codec plugins."""
    monkeypatch.setattr(plugins, "DEFAULT_PLUGINS", REPRESENTATION_PLUGINS)
    monkeypatch.delenv("MOTIONREP_LOAD_PLUGINS", raising=False)
    eps: list[_EntryPoint] = []

    def entry_points(group=None, **kw):
        assert group == "motionrep"
        return list(eps)

    monkeypatch.setattr(plugins.metadata, "entry_points", entry_points)
    return eps


@pytest.fixture
def lab(installed):
    installed.append(_EntryPoint("alpha", _module("lab_alpha", reps=[_representation("alpha-rep")]), "lab-alpha",
                                 "2.0"))
    installed.append(_EntryPoint("beta", _module("studio_beta", codecs=[_codec("beta-codec")]), "studio-beta",
                                 "0.3"))
    return installed


# ---- discovery and MOTIONREP_LOAD_PLUGINS --------------------------------------------------------------------
def test_entry_points_load_with_the_variable_unset(lab):
    assert "alpha-rep" in plugins.representations()
    assert "beta-codec" in plugins.codecs()
    infos = {i.name: i for i in plugins.plugin_infos()}
    assert infos["alpha"].as_dict() == {"name": "alpha", "version": "2.0", "shipped": False,
                                        "distribution": "lab-alpha", "hooks": ["register_representations"],
                                        "representations": ["alpha-rep"], "codecs": []}
    assert infos["beta"].codecs == ["beta-codec"] and infos["beta"].hooks == ["register_codecs"]
    assert plugins.provider_of("beta-codec") == "studio-beta"
    assert plugins.provider_of("alpha-rep", kind="representation") == "lab-alpha"
    # third-party first, then shipped, each sorted by name
    assert [i.name for i in plugins.plugin_infos()] == ["alpha", "beta"] + sorted(REPRESENTATION_PLUGINS)


@pytest.mark.parametrize("value, expected", [
    ("", set()),
    ("alpha", {"alpha"}),
    ("studio-beta", {"beta"}),  # a distribution name works too
    (" alpha , beta ", {"alpha", "beta"}),
    ("alpha,lab-alpha", {"alpha"}),
])
def test_load_plugins_variable_limits_third_party_plugins(lab, monkeypatch, value, expected):
    monkeypatch.setenv("MOTIONREP_LOAD_PLUGINS", value)
    infos = plugins.plugin_infos()
    assert {i.name for i in infos if not i.shipped} == expected
    assert {i.name for i in infos if i.shipped} == set(REPRESENTATION_PLUGINS)  # shipped plugins always load
    assert ("alpha-rep" in plugins.representations()) == ("alpha" in expected)
    assert ("beta-codec" in plugins.codecs()) == ("beta" in expected)


def test_load_plugins_variable_naming_a_missing_plugin(lab, monkeypatch):
    monkeypatch.setenv("MOTIONREP_LOAD_PLUGINS", "alpha,gamma")
    with pytest.raises(PluginError, match="MOTIONREP_LOAD_PLUGINS names 'gamma'"):
        plugins.load_plugins()


def test_plugins_load_lazily_and_once(installed):
    calls = []

    @hookimpl
    def register_representations(register):
        calls.append(1)
        register(_representation("counted"))

    module = types.ModuleType("counting")
    module.register_representations = register_representations
    plugins.pm.register(module, name="counting")
    assert calls == []  # registering a plugin does not call hooks
    plugins.get_representation("counted")
    plugins.representations()
    plugins.plugin_infos()
    plugins.load_plugins()
    assert calls == [1]
    info = {i.name: i for i in plugins.plugin_infos()}["counting"]
    assert not info.shipped and info.distribution is None and info.representations == ["counted"]


def test_importing_motionrep_loads_no_plugin():
    code = ("import sys, motionrep, motionrep.cli, motionrep.plugin.registry as p; "
            "print(p._State.loaded, sorted(m for m in sys.modules if m.startswith('motionrep_')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={**os.environ, "MOTIONREP_LOAD_PLUGINS": ""}).stdout
    assert out.strip() == "False []"


def test_shipped_plugins_use_the_same_hooks(installed):
    names = plugins.representations()
    assert sorted(names) == ["dual-quaternion", "euler", "ortho6d", "root-quat-axis-angle"]
    for module_name in REPRESENTATION_PLUGINS:
        module = sys.modules[module_name]
        assert module.__version__ == motionrep.__version__
        assert getattr(module.register_representations, "motionrep_impl", None) is not None  # an @hookimpl
        assert plugins.pm.get_plugin(module_name) is module


# ---- errors -------------------------------------------------------------------------------------------------
def test_duplicate_representation_names_both_plugins(installed):
    installed.append(_EntryPoint("mylab", _module("mylab", reps=[_representation("euler")]), "mylab-reps"))
    with pytest.raises(DuplicateNameError) as info:
        plugins.load_plugins()
    message = str(info.value)
    assert "'euler'" in message and "'motionrep_euler'" in message and "'mylab'" in message
    assert "\n" not in message
    assert not plugins._State.loaded  # nothing half-loaded: the next lookup starts again


def test_duplicate_codec_names_both_plugins(installed):
    installed.append(_EntryPoint("one", _module("one", codecs=[_codec("twin")]), "dist-one"))
    installed.append(_EntryPoint("two", _module("two", codecs=[_codec("twin")]), "dist-two"))
    with pytest.raises(DuplicateNameError, match=r"codec name 'twin' is registered twice: by plugin '(one|two)' "
                                                 r"and by plugin '(one|two)'") as info:
        plugins.codecs()
    assert "'one'" in str(info.value) and "'two'" in str(info.value)


def test_duplicate_name_from_the_command_line(installed):
    installed.append(_EntryPoint("mylab", _module("mylab", reps=[_representation("ortho6d")]), "mylab-reps"))
    result = run_cli_caught("plugins", env={"MOTIONREP_LOAD_PLUGINS": "mylab"})
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "'motionrep_ortho6d'" in lines[0] and "'mylab'" in lines[0]


def test_plugin_reusing_a_shipped_plugin_name(installed):
    installed.append(_EntryPoint("motionrep_euler", _module("impostor", reps=[_representation("x")]), "impostor"))
    with pytest.raises(DuplicateNameError, match="'motionrep_euler' is used twice.*'impostor'"):
        plugins.load_plugins()


class _NoLayout(Ortho6D):
    name = "no-layout"
    layout = Representation.layout
    width = Representation.width


@pytest.mark.parametrize("obj, message", [
    (object(), "which is invalid: is not a motionrep.plugin.representation.Representation"),
    (type("NoVersion", (Ortho6D,), {"name": "v0", "version": 0})(), "version must be an integer >= 1, got 0"),
    (type("NoName", (Ortho6D,), {"name": ""})(), "name must be a non-empty string"),
    (_NoLayout(), "must define layout\\(skeleton\\), or width\\(skeleton\\) and feature_names"),
])
def test_invalid_representation_is_refused_naming_the_plugin(installed, obj, message):
    installed.append(_EntryPoint("broken", _module("broken", reps=[obj]), "broken-dist"))
    with pytest.raises(PluginError, match=message) as info:
        plugins.load_plugins()
    assert "'broken'" in str(info.value)


def test_invalid_codec_is_refused_naming_the_plugin(installed):
    bad = type("NoParams", (_RawCodec,), {"name": "np", "Params": dict})()
    installed.append(_EntryPoint("broken", _module("broken", codecs=[bad]), "broken-dist"))
    with pytest.raises(PluginError, match="plugin 'broken' registered codec 'np', which is invalid: Params must be a "
                                          "dataclass"):
        plugins.load_plugins()


def test_misspelt_hook_fails_loudly(installed):
    module = types.ModuleType("typo")

    @hookimpl
    def register_representation(register):  # missing "s"
        register(_representation("never"))

    module.register_representation = register_representation
    installed.append(_EntryPoint("typo", module, "typo-dist"))
    result = run_cli_caught("plugins", env={"MOTIONREP_LOAD_PLUGINS": "typo"})
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1
    assert "unknown hook 'register_representation'" in lines[0]
    assert "register_representations" in lines[0]  # the known hooks are listed


def test_hook_with_an_unknown_argument_is_refused(installed):
    module = types.ModuleType("extra")

    @hookimpl
    def register_codecs(register, options):
        pass

    module.register_codecs = register_codecs
    installed.append(_EntryPoint("extra", module, "extra-dist"))
    with pytest.raises(PluginError, match="plugin 'extra' is invalid: .*'options'"):
        plugins.load_plugins()


def test_entry_point_that_fails_to_import(installed):
    installed.append(_EntryPoint("crash", types.ModuleType("crash"), "crash-dist", fail=ImportError("no numpy 3")))
    with pytest.raises(PluginError, match=r"plugin 'crash' \(crash\) failed to load: ImportError: no numpy 3"):
        plugins.load_plugins()


def test_unknown_names_list_what_is_available(installed):
    with pytest.raises(UnknownPluginError, match="unknown representation 'quat'; available: dual-quaternion, "
                                                 "euler, ortho6d, root-quat-axis-angle"):
        plugins.get_representation("quat")
    with pytest.raises(UnknownPluginError, match="unknown codec 'x' \\(provided by plugin 'motionrep-x'"):
        plugins.get_codec("x", provided_by="motionrep-x")


# ---- motionrep plugins ----------------------------------------------------------------------------------------
def test_plugins_command_json(lab):
    result = run_cli_caught("plugins", "--json")
    assert result.exit_code == 0, result.output
    listed = json.loads(result.output)
    assert [p["name"] for p in listed] == ["alpha", "beta"] + sorted(REPRESENTATION_PLUGINS)
    for entry in listed:
        assert set(entry) == {"name", "version", "shipped", "distribution", "hooks", "representations", "codecs"}
    by_name = {p["name"]: p for p in listed}
    assert by_name["beta"] == {"name": "beta", "version": "0.3", "shipped": False, "distribution": "studio-beta",
                               "hooks": ["register_codecs"], "representations": [], "codecs": ["beta-codec"]}
    assert by_name["motionrep_dualquat"] == {
        "name": "motionrep_dualquat", "version": motionrep.__version__, "shipped": True,
        "distribution": "motionrep", "hooks": ["register_representations"],
        "representations": ["dual-quaternion"], "codecs": []}


def test_plugins_command_filters_and_table(lab):
    codecs_only = json.loads(run_cli_caught("plugins", "--json", "--hook", "register_codecs").output)
    assert [p["name"] for p in codecs_only] == ["beta"]
    third = json.loads(run_cli_caught("plugins", "--json", "--third-party").output)
    assert [p["name"] for p in third] == ["alpha", "beta"]
    table = run_cli_caught("plugins")
    assert table.exit_code == 0
    lines = table.output.splitlines()
    assert lines[0].split() == ["NAME", "VERSION", "SOURCE", "REGISTERS"]
    assert lines[1].split() == ["alpha", "2.0", "lab-alpha", "representations:", "alpha-rep"]
    assert lines[2].split() == ["beta", "0.3", "studio-beta", "codecs:", "beta-codec"]
    assert lines[3].split() == ["motionrep_dualquat", motionrep.__version__, "shipped", "representations:",
                                "dual-quaternion"]
    assert len(lines) == 1 + 2 + len(REPRESENTATION_PLUGINS)
    bad = run_cli_caught("plugins", "--hook", "register_formats")
    assert bad.exit_code == 2  # a usage error


def test_plugins_command_with_no_third_party_plugins(lab, monkeypatch):
    monkeypatch.setenv("MOTIONREP_LOAD_PLUGINS", "")  # installed, but none loads
    result = run_cli_caught("plugins", "--third-party")
    assert result.exit_code == 0 and result.output.strip() == "No loaded plugin matches."


def test_every_shipped_plugin_is_listed():
    """The real installation: every plugin in DEFAULT_PLUGINS loads and is listed as shipped."""
    env = {**os.environ, "MOTIONREP_LOAD_PLUGINS": ""}
    out = subprocess.run([sys.executable, "-m", "motionrep", "plugins", "--json"], capture_output=True, text=True,
                         env=env)
    assert out.returncode == 0, out.stderr
    listed = json.loads(out.stdout)
    assert [p["name"] for p in listed] == sorted(plugins.DEFAULT_PLUGINS)
    assert all(p["shipped"] and p["distribution"] == "motionrep" for p in listed)
    registered = {name for p in listed for name in p["representations"]}
    assert {"root-quat-axis-angle", "dual-quaternion", "ortho6d", "euler"} <= registered
    assert all(p["representations"] or p["codecs"] for p in listed)


# ---- the conformance suite over every shipped codec ----------------------------------------------------------
#: Small settings per shipped codec: (params without a bound, params with a bound, bound as a fraction of height).
_CODEC_SETTINGS = {
    "svd": ({"rank": 4}, {}, 0.05),
    "naive-fourier": ({"k": 1, "iters": 50}, {"max_k": 4, "iters": 100}, 0.25),
    "adaptive-fourier": ({"k": 1, "iters": 50}, {"max_k": 4, "iters": 100}, 0.25),
    "transform": ({"step": 0.5}, {}, 0.05),
}


def test_every_shipped_codec_has_conformance_settings():
    shipped = {name for name in plugins.codecs() if plugins.provider_of(name) in plugins.DEFAULT_PLUGINS}
    assert shipped == set(_CODEC_SETTINGS)


@pytest.mark.parametrize("name", [pytest.param(n, marks=[pytest.mark.slow] if "fourier" in n else [])
                                  for n in sorted(_CODEC_SETTINGS)])
def test_shipped_codecs_conform(name):
    from motionrep.model.synthetic import synthetic_motion
    from motionrep.testing import check_codec

    params, bound_params, bound = _CODEC_SETTINGS.get(name, ({}, None, 0.05))
    results = check_codec(plugins.get_codec(name), [synthetic_motion(frames=32, seed=7)], params=params,
                          bound_params=bound_params, bound_fraction=bound)
    assert results[0]["num_parameters"] > 0


def test_plugins_describe_lists_a_codecs_parameters():

    r = run_cli_caught("plugins", "--describe", "adaptive-fourier")
    assert r.exit_code == 0, r.output
    assert "codec adaptive-fourier (plugin motionrep_fourier), format version 4, reads 1, 2, 3, 4" in r.output
    for line in ("  window  int | None, default None:", "  dtype   quantised | float32 | float16, default quantised:",
                 "  k       int | None, default None:"):
        assert line in r.output, r.output
    d = json.loads(run_cli_caught("plugins", "--describe", "svd", "--json").output)
    assert (d["kind"], d["plugin"], d["version"]) == ("codec", "motionrep_svd", 2)
    assert [p["name"] for p in d["params"]] == ["rank", "dtype"]
    d = json.loads(run_cli_caught("plugins", "--describe", "dual-quaternion", "--json").output)
    assert (d["kind"], d["plugin"], d["params"]) == ("representation", "motionrep_dualquat", [])
    r = run_cli_caught("plugins", "--describe", "nope")
    assert r.exit_code == 1 and r.output.count("\n") == 1 and "'nope'" in r.output and "svd" in r.output


@pytest.mark.slow
def test_windowed_fourier_codec_conforms():
    from motionrep.model.synthetic import synthetic_motion
    from motionrep.testing import check_codec

    results = check_codec(plugins.get_codec("adaptive-fourier"), [synthetic_motion(frames=32, seed=7)],
                          params={"k": 1, "iters": 50, "window": 10},
                          bound_params={"max_k": 4, "iters": 100, "window": 10}, bound_fraction=0.25)
    assert results[0]["num_parameters"] > 0
