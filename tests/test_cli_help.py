"""Help texts checked against the code (issue 26): the formats a command's help lists are the formats the code
reads, options say what the code does, and `example --help` agrees with the README's quick start."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

from helpers import run_cli_caught

REPO = Path(__file__).resolve().parent.parent


def _help(*command: str) -> str:
    r = run_cli_caught(*command, "--help", terminal_width=200)
    assert r.exit_code == 0, r.output
    return " ".join(r.output.split())  # one line: click rewraps


def test_info_help_lists_every_suffix_and_format_it_reads():
    from motionrep.present.info import FORMAT_NAMES
    from motionrep.pipeline.sources import SOURCE_SUFFIXES

    text = _help("info")
    listed = set(re.search(r"Suffixes: ([^.]*(?:\.\w+[, ]*)+)", text).group(1).replace(",", " ").split())
    assert listed == set(SOURCE_SUFFIXES), listed
    formats = set(re.search(r"format \(([^)]*)\)", text).group(1).replace('"', "").replace("|", " ").split())
    assert formats == set(FORMAT_NAMES.values()), formats  # gltf included


def test_convert_help_lists_the_suffixes_it_reads_and_the_formats_it_writes():
    from motionrep.cli._common import OUT_FORMATS
    from motionrep.cli.convert import _MOTION_SUFFIXES

    text = _help("convert")
    inputs = re.search(r"IN\.\.\. are files \(([^)]*)\)", text).group(1)
    for suffix in (*_MOTION_SUFFIXES, ".mrc"):
        assert re.search(rf"{re.escape(suffix)}\b", inputs), suffix
    choices = re.search(r"--format \[([^\]]*)\]", text).group(1).split("|")
    assert set(choices) == set(OUT_FORMATS)


def test_help_says_nothing_is_needed_that_is_a_core_dependency():
    core = " ".join(tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["dependencies"])
    for command in ("bench", "render", "view", "compress", "convert", "info"):
        for needed in re.findall(r"needs (\w+)", _help(command)):
            assert needed.lower() not in core.lower(), f"{command} --help says it needs {needed}, a core dependency"


def test_example_help_agrees_with_the_readme_quick_start():
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    quick = readme.split("## Quick start", 1)[1].split("```", 2)[1]
    commands = [c.strip() for line in quick.splitlines() for c in line.split("&&") if c.strip().startswith(
        "motionrep ")]
    text = _help("example")
    for c in commands:
        assert c in text, f"example --help does not show the quick start's {c!r}"
    assert "adaptive-fourier" not in text  # the quick start uses the default codec


@pytest.mark.parametrize("command", ["convert", "compress", "decompress", "merge", "example", "render", "view"])
def test_every_writing_command_offers_quiet(command):
    assert "-q, --quiet" in _help(command)


def test_compress_help_names_the_default_codec_the_code_uses():
    from motionrep.pipeline.compress import DEFAULT_CODEC

    assert f"[default: {DEFAULT_CODEC}]" in _help("compress")
