"""Helpers the tests import (``from helpers import ...``; ``tests/`` is on pytest's ``pythonpath``): where the
real clips are, and pytest parameters over them.  The real-data tests skip cleanly when ``../shared/data`` is
absent."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
SHARED_DATA = Path(os.environ.get("MOTIONREP_SHARED_DATA", REPO.parent / "shared" / "data"))
HAVE_SHARED = SHARED_DATA.is_dir()

requires_shared = pytest.mark.skipif(not HAVE_SHARED, reason=f"real clips not found at {SHARED_DATA}")


def real_bvh_files(*subdirs: str) -> list[Path]:
    """Every valid real BVH file under ../shared/data (malformed ones excluded); [] when absent."""
    if not HAVE_SHARED:
        return []
    roots = [SHARED_DATA / s for s in subdirs] if subdirs else [SHARED_DATA]
    return sorted(p for r in roots for p in r.rglob("*.bvh") if "malformed" not in p.parts)


def real_params(*subdirs: str):
    """pytest parameters over real BVH files, ids relative to ../shared/data, marked realdata."""
    files = real_bvh_files(*subdirs)
    if not files:
        return [pytest.param(None, marks=[requires_shared, pytest.mark.realdata], id="no-shared-data")]
    return [pytest.param(p, marks=pytest.mark.realdata, id=str(p.relative_to(SHARED_DATA))) for p in files]


def mutant_outcomes(path: Path, mutants, error: type[Exception], warnings_are_errors: bool = False) -> dict[str, int]:
    """Write each of ``mutants`` (bytes, one per seed) to ``path`` and read it under small limits: a clip, or one
    ``error`` naming ``path`` on one line (anything else fails the test).  Returns the counts of both outcomes."""
    import warnings

    from motionrep import limits
    from motionrep.io import read

    outcomes = {"read": 0, "refused": 0}
    with limits.override(max_frames=100_000, max_clip_bytes=32 << 20):
        for seed, data in enumerate(mutants):
            path.write_bytes(data)
            with warnings.catch_warnings():
                if warnings_are_errors:
                    warnings.simplefilter("error")
                try:
                    read(path)
                    outcomes["read"] += 1
                except error as exc:
                    assert exc.path == str(path) and "\n" not in str(exc), (seed, str(exc))
                    outcomes["refused"] += 1
    return outcomes


def convert_fails_naming(args: list, named: Path, out: Path) -> None:
    """``motionrep convert ARGS...`` fails as bad input must: exit 1, one ``Error:`` line naming ``named``, no
    traceback, no ``out`` written."""
    line = one_line_error(run_cli_caught("convert", *args))
    assert line.startswith(f"Error: {named}: "), line
    assert not out.exists()


def run_cli(*args, input: bytes | str | None = None, env: dict | None = None, catch: bool = False, **invoke):
    """``motionrep ARGS...`` in this process through click's test runner (arguments turned into strings). With
    ``catch=False`` an exception the CLI's error funnel did not turn into an exit code fails the test with its
    traceback; ``catch=True`` keeps it on the result (``result.exception``).  ``invoke``: more of
    ``CliRunner.invoke``'s options (``terminal_width``)."""
    from click.testing import CliRunner

    from motionrep.cli import cli

    return CliRunner().invoke(cli, [str(a) for a in args], input=input, env=env, catch_exceptions=catch, **invoke)


def run_cli_caught(*args, input: bytes | str | None = None, env: dict | None = None, **invoke):
    """:func:`run_cli` keeping any exception on the result."""
    return run_cli(*args, input=input, env=env, catch=True, **invoke)


def one_line_error(result, *needles: str, code: int = 1, in_line: bool = True) -> str:
    """The result of a command that failed as bad input must: exit ``code``, exactly one ``Error`` line, no
    traceback, and each of ``needles`` in that line (``Error: ...``) (``in_line``) or anywhere on stderr. Returns the line."""
    assert result.exit_code == code, result.output
    assert "Traceback" not in result.output, result.output
    lines = [line for line in result.output.splitlines() if line.startswith("Error: ")]
    assert len(lines) == 1, result.output
    for needle in needles:
        if in_line:
            assert needle in lines[0], lines[0]
        else:
            assert needle in result.stderr, result.stderr
    return lines[0]


def mrc_version_1(data: bytes, **extra) -> bytes:
    """A version-1 ``.mrc`` file made from the bytes of a current one, as motionrep 0.1 wrote it: the bound as the
    text ``extra.max_error`` (from ``bound``), no ``bound`` object, the setting digest not stored; ``extra`` keys
    given here replace the file's (``max_error="abc"`` crafts a bad one).  The preamble, CRC and payload layout
    are those of both versions (``specs/container.md``)."""
    import json
    import struct
    import zlib

    from motionrep.model.bound import MaxError

    _, _, flags, _, meta_len = struct.unpack_from("<8sHHII", data, 0)
    meta = json.loads(zlib.decompress(data[20:20 + meta_len]))
    bound = meta.pop("bound", None)
    old = dict(meta.get("extra") or {})
    old.pop("setting_sha256", None)
    if bound is not None:
        old["max_error"] = None if bound["kind"] == "none" else str(MaxError(bound["value"], bound["kind"] == "percent"))
    old.update(extra)
    meta["extra"] = old
    text = zlib.compress(json.dumps(meta, sort_keys=True, separators=(",", ":")).encode(), 9)
    payload = data[20 + meta_len:-4]
    body = data[:8] + struct.pack("<HHII", 1, flags, 20 + len(text) + len(payload) + 4, len(text)) + text + payload
    return body + struct.pack("<I", zlib.crc32(body))


def refused_mrc(container, *words: str) -> str:
    """A crafted container (:class:`motionrep.io.container.Container`) is refused when decoded, with one line
    naming the file (``crafted.mrc``) and each of ``words``; returns the line."""
    from motionrep.errors import ContainerError
    from motionrep.io.container import pack
    from motionrep.pipeline.decode import decompress

    with pytest.raises(ContainerError) as info:
        decompress(pack(container), path="crafted.mrc")
    text = str(info.value)
    assert "crafted.mrc" in text and "\n" not in text
    for w in words:
        assert w in text, text
    return text


def representation_alone(monkeypatch, plugin: str, name: str):
    """The representation ``name``, looked up through the plugin registry with only ``plugin`` loaded."""
    from motionrep.plugin import registry

    monkeypatch.setattr(registry, "DEFAULT_PLUGINS", (plugin,))
    return registry.get_representation(name)


def mutant(obj, **methods):
    """An instance of a subclass of ``obj``'s class with ``methods`` replaced: a broken plugin for a check to catch."""
    return type("Mutant", (type(obj),), methods)()


def without(obj, name: str):
    """A stand-in for ``obj`` that lacks its attribute ``name`` (``hasattr`` is False) and forwards every other
    attribute: e.g. a codec's context without one of its capabilities, as a third party's may be."""

    class Without:
        def __getattr__(self, attribute):
            if attribute == name:
                raise AttributeError(attribute)
            return getattr(obj, attribute)

    return Without()
