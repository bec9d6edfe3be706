"""The shape of the code base: the layout table (CONTRIBUTING.md, linked from the README) names every module
and folder, no module-level import
circle inside ``motionrep``, modules short enough to read (a longer one says why in its docstring), no
``assert`` for validation in library code, and the command-line package light to import."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
PACKAGE = REPO / "motionrep"
#: A module longer than this says why in a docstring paragraph starting "Size:".
MAX_LINES = 450


def _modules() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def _layout_rows() -> list[tuple[str, str]]:
    text = (REPO / "CONTRIBUTING.md").read_text(encoding="utf-8")
    section = text.split("\n## Layout", 1)[1].split("\n## ", 1)[0]
    rows = []
    for line in section.splitlines():
        m = re.match(r"^\| `([^`]+)` \| (.*) \|$", line)
        if m:
            rows.append((m.group(1), m.group(2)))
    return rows


def test_readme_layout_names_every_module_and_folder():
    rows = _layout_rows()
    paths = {p for p, _ in rows}
    for p in paths:  # every row names something that exists
        target = REPO / p.replace("<name>", "*")
        assert list(REPO.glob(p.replace("<name>", "*").rstrip("/"))) or target.exists(), f"CONTRIBUTING.md names {p}"
    folders = {f"{d.relative_to(REPO).as_posix()}/" for d in PACKAGE.rglob("*")
               if d.is_dir() and "__pycache__" not in d.parts}
    folders |= {f"{d}/" for d in ("tests", "specs", "benchmarks", ".ci", "plugins/examples")}
    missing = sorted(folders - paths)
    assert not missing, f"folders the layout table (CONTRIBUTING.md) does not name: {missing}"
    for module in _modules():
        rel = module.relative_to(REPO).as_posix()
        if rel in paths:
            continue
        folder = f"{module.parent.relative_to(REPO).as_posix()}/"
        described = dict(rows).get(folder, "")
        assert f"`{module.name}`" in described, f"the layout table (CONTRIBUTING.md) does not name {rel}"
    shipped = {f"plugins/{d.name}" for d in (REPO / "plugins").glob("motionrep_*")}
    assert "(CONTRIBUTING.md)" in (REPO / "README.md").read_text(encoding="utf-8")  # linked from the README
    assert shipped and "plugins/motionrep_<name>/" in paths


def _imports(module: Path) -> set[str]:
    """Modules of motionrep imported at module level (not inside functions) by ``module``."""
    rel = module.relative_to(REPO).with_suffix("")
    name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
    package = name if module.name == "__init__.py" else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.parse(module.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.If):  # `if TYPE_CHECKING:` imports do not run
            continue
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.startswith("motionrep")}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.startswith("motionrep"):
                out.add(target)
                for a in node.names:  # `from . import x` imports the submodule x
                    sub = f"{target}.{a.name}"
                    if (REPO / (sub.replace(".", "/") + ".py")).exists() or (REPO / sub.replace(".", "/")).is_dir():
                        out.add(sub)
    return out - {name}


def test_no_import_circle():
    graph = {}
    for module in _modules():
        rel = module.relative_to(REPO).with_suffix("")
        name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        graph[name] = {m for m in _imports(module)}
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                cycle = stack[stack.index(nxt):] + [nxt]
                raise AssertionError("import circle: " + " -> ".join(cycle))
            if nxt in graph and not state.get(nxt):
                visit(nxt)
        stack.pop()
        state[node] = 2

    for node in sorted(graph):
        if not state.get(node):
            visit(node)


def test_long_modules_say_why():
    for module in _modules():
        lines = module.read_text(encoding="utf-8").count("\n")
        if lines > MAX_LINES:
            doc = ast.get_docstring(ast.parse(module.read_text(encoding="utf-8"))) or ""
            assert "\nSize:" in "\n" + doc, (f"{module.relative_to(REPO)} has {lines} lines: split it, or say in its "
                                              "docstring (a paragraph starting 'Size:') why one concern needs them")


def test_the_command_modules_are_light():
    """Importing a command module imports click and the standard library only; the library is imported inside
    the command (so that `motionrep --help` never pays for what a command needs)."""
    for module in sorted((PACKAGE / "cli").glob("*.py")):
        if module.name == "__init__.py":
            continue
        imported = _imports(module) - {"motionrep.cli._common", "motionrep.cli._stdin", "motionrep.cli._crosstool",
                                       "motionrep.cli"}
        assert imported <= {"motionrep.errors"}, f"{module.name} imports {sorted(imported)} at module level"


def test_cli_defaults_agree_with_the_library():
    from motionrep import compress, hookspecs
    from motionrep.cli import compress as cli_compress
    from motionrep.cli import plugins as cli_plugins

    assert (cli_compress.DEFAULT_CODEC, cli_compress.DEFAULT_REPRESENTATION, cli_compress.DEFAULT_MAX_ERROR) == (
        compress.DEFAULT_CODEC, compress.DEFAULT_REPRESENTATION, compress.DEFAULT_MAX_ERROR)
    assert set(cli_plugins.HOOKS) == {n for n in hookspecs.__all__ if n not in ("hookspec", "hookimpl")}


def test_runtime_never_imports_test_support():
    code = ("import sys, motionrep, motionrep.cli, motionrep.compress, motionrep.batch, motionrep.bench, "
            "motionrep.render, motionrep._demo; print('motionrep.testing' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_library_code_validates_without_assert():
    """Validation raises motionrep's own errors: ``assert`` vanishes under ``python -O`` and would show a user a
    traceback.  Library code (the core and the shipped plugins, not their tests) has none."""
    found = []
    for path in _modules() + sorted((REPO / "plugins").rglob("*.py")):
        if "tests" in path.relative_to(REPO).parts or "__pycache__" in path.parts:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Assert):
                found.append(f"{path.relative_to(REPO)}:{node.lineno}")
    assert not found, "assert in library code: " + ", ".join(found)
