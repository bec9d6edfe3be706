"""specs/plugins.md and specs/representations.md agree with the code: every hook with its exact signature, the
interfaces' members, the ``motionrep plugins`` options and JSON keys, the shipped plugins and representations."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import pytest

from motionrep.plugin import hookspecs

from motionrep.plugin import registry as plugins
from motionrep.cli.plugins import plugins_command
from motionrep.plugin.codec import Codec
from motionrep.plugin.representation import Representation
from motionrep.model.synthetic import humanoid_skeleton, odd_skeleton

SPECS = Path(__file__).resolve().parent.parent / "specs"
PLUGINS_MD = (SPECS / "plugins.md").read_text()
REPRESENTATIONS_MD = (SPECS / "representations.md").read_text()
SHIPPED_REPRESENTATIONS = {"root-quat-axis-angle": "motionrep_rootquat", "dual-quaternion": "motionrep_dualquat",
                           "ortho6d": "motionrep_ortho6d", "euler": "motionrep_euler"}


def _hookspecs() -> dict[str, object]:
    return {name: func for name, func in vars(hookspecs).items()
            if callable(func) and hasattr(func, "motionrep_spec")}


def _signature(func) -> str:
    return func.__name__ + str(inspect.signature(func)).replace("'", "")


def _section(text: str, heading: str) -> str:
    """The text under ``heading`` (a whole heading line) up to the next heading of the same or a higher level."""
    level = len(heading) - len(heading.lstrip("#"))
    start = text.index(heading + "\n") + len(heading) + 1
    stop = re.search(rf"^#{{1,{level}}} ", text[start:], flags=re.M)
    return text[start:start + stop.start()] if stop else text[start:]


def _table_first_column(section: str) -> list[str]:
    """First cell of every body row of every table in ``section`` (header rows, followed by |---|, skipped)."""
    lines = section.splitlines()
    return [line.split("|")[1].strip() for i, line in enumerate(lines)
            if line.startswith("| ") and not (i + 1 < len(lines) and lines[i + 1].startswith("|---"))]


def test_every_hookspec_is_documented_with_its_exact_signature():
    specs = _hookspecs()
    assert specs, "no hook specifications found"
    for name, func in specs.items():
        heading = f"### `{_signature(func)}`"
        assert heading + "\n" in PLUGINS_MD, f"specs/plugins.md lacks the heading {heading!r}"
        section = _section(PLUGINS_MD, heading)
        documented = {c.strip("`") for c in _table_first_column(section)}
        assert documented == set(inspect.signature(func).parameters), f"{name}: parameter table disagrees"
        assert "When called" in section and "Since" in section


def test_every_documented_hook_exists():
    hooks_section = _section(PLUGINS_MD, "## Hooks")
    documented = re.findall(r"^### `(\w+)\(", hooks_section, flags=re.M)
    assert sorted(documented) == sorted(_hookspecs())
    # and the hookspecs module lists them for `from motionrep.plugin.hookspecs import *`
    assert set(_hookspecs()) <= set(hookspecs.__all__)


def test_loading_rules_are_documented_as_implemented():
    assert f"`{plugins.ENV_VAR}`" in PLUGINS_MD
    assert "[project.entry-points.motionrep]" in PLUGINS_MD
    assert 'HookspecMarker("motionrep")' in inspect.getsource(hookspecs) and '`"motionrep"`' in PLUGINS_MD
    shipped = _section(PLUGINS_MD, "## Shipped plugins")
    assert [c.strip("`") for c in _table_first_column(shipped)] == list(plugins.DEFAULT_PLUGINS)


def test_shipped_plugins_register_what_the_document_says():
    rows = [line.split("|")[1:3] for line in _section(PLUGINS_MD, "## Shipped plugins").splitlines()
            if line.startswith("| `")]
    documented = {module.strip().strip("`"): set(re.findall(r"`([^`]+)`", registers)) for module, registers in rows}
    actual = {i.name: set(i.representations) | set(i.codecs) for i in plugins.plugin_infos() if i.shipped}
    assert documented == actual


def test_interfaces_are_documented_member_by_member():
    for cls, heading in ((Representation, "## The Representation interface"), (Codec, "## The Codec interface")):
        section = _section(PLUGINS_MD, heading)
        documented = {re.match(r"`(\w+)", c).group(1) for c in _table_first_column(section)}
        abstract = set(cls.__abstractmethods__)
        attributes = {n for n in getattr(cls, "__annotations__", {}) if not n.startswith("_")}
        assert abstract <= documented, f"{cls.__name__}: undocumented methods {abstract - documented}"
        assert attributes <= documented, f"{cls.__name__}: undocumented attributes {attributes - documented}"
        for member in documented:
            assert hasattr(cls, member) or member in attributes, f"{cls.__name__} has no member {member!r}"


def test_plugins_command_options_and_json_keys():
    section = _section(PLUGINS_MD, "## `motionrep plugins`")
    rows = _table_first_column(section)
    options = {re.match(r"`(--[\w-]+)", r).group(1) for r in rows if r.startswith("`--")}
    actual = {opt for p in plugins_command.params for opt in p.opts if opt.startswith("--")} - {"--help"}
    assert options == actual
    keys = {r.strip("`") for r in rows if not r.startswith("`--")}
    assert keys == set(plugins.PluginInfo("x", None, False).as_dict())


@pytest.fixture
def shipped(monkeypatch):
    monkeypatch.setattr(plugins, "DEFAULT_PLUGINS", tuple(SHIPPED_REPRESENTATIONS.values()))
    return {name: plugins.get_representation(name) for name in SHIPPED_REPRESENTATIONS}


def test_representations_document_lists_every_shipped_representation(shipped):
    table = _section(REPRESENTATIONS_MD, "# motionrep pose representations reference")
    rows = [line.split("|")[1:5] for line in table.splitlines() if line.startswith("| `")]
    listed = {cells[0].strip().strip("`"): (int(cells[1]), cells[2].strip().strip("`")) for cells in rows}
    assert listed == {name: (rep.version, SHIPPED_REPRESENTATIONS[name]) for name, rep in shipped.items()}
    for name, rep in shipped.items():
        assert f"## `{name}` (version {rep.version})\n" in REPRESENTATIONS_MD


def test_documented_components_are_the_feature_names(shipped):
    for name, rep in shipped.items():
        section = _section(REPRESENTATIONS_MD, f"## `{name}` (version {rep.version})")
        table = [line for line in section.splitlines() if line.startswith("| ")]
        documented = {token for row in table[2:] for cell in row.split("|")[3:4]
                      for token in re.findall(r"`([^`]*)`", cell) for token in token.split()}
        for sk in (humanoid_skeleton(), odd_skeleton()):
            suffixes = {n.rsplit("/", 1)[1] for n in rep.feature_names(sk)}
            assert suffixes <= documented, f"{name}: columns {suffixes - documented} are not documented"
