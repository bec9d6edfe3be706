"""The shape of the code base: the layout table (CONTRIBUTING.md, linked from the README) names every module
and folder, one home for the file suffixes (``motionrep/formats.py``), no import circle inside ``motionrep``
(imports inside functions counted), modules short enough to read (a longer one is in a reviewed list, with its
reason), no
``assert`` for validation in library code, and the command-line package light to import."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
PACKAGE = REPO / "motionrep"
#: No library module (``motionrep/`` and the shipped plugins, tests aside) is longer than this, unless it is in
#: :data:`LONG_MODULES`.
MAX_LINES = 450
#: The modules reviewed as right at their length, each with the reason one concern needs it (their docstrings'
#: "Size:" paragraphs say more).  A module that grows past :data:`MAX_LINES` is split or added here after review;
#: one that shrinks below it leaves the list.
LONG_MODULES = {
    "motionrep/io/_bvh.py": "the BVH format: reader and writer are each other's specification; most lines name the "
                            "line of a malformed case",
    "motionrep/io/_hdf5.py": "the HDF5 format: reader and writer are each other's specification; most lines name the "
                             "file, clip and field of a malformed case",
    "motionrep/io/container.py": "the .mrc format: writer and reader together, a third of it checking every field of "
                                 "an untrusted file",
    "motionrep/model/rotations.py": "every parameterisation times its conversions, each short and beside its "
                                    "inverse, the compiled column conversions beside their public checks",
    "motionrep/plugin/coding.py": "integer coding: quantiser, model and coder share one definition of the "
                                  "probabilities that must agree bit for bit",
    "motionrep/plugin/codec.py": "the codec interface, with the helpers that are its methods' documented defaults",
    "motionrep/pipeline/sources.py": "every kind of clip-bearing file behind one interface and one naming rule; the "
                                     "kinds are small classes side by side",
    "motionrep/pipeline/pairing.py": "pairing two motions for the shared error: point pairing, frame pairing and the "
                                     "report of what was left out describe one another",
    "motionrep/batch/engine.py": "running many clips' work: the pool supervision and the jobs whose failure outcomes "
                                 "it returns",
}


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


def _is_type_checking(node: ast.AST) -> bool:
    test = node.test if isinstance(node, ast.If) else None
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _import_nodes(tree: ast.Module, inside_functions: bool) -> list[ast.Import | ast.ImportFrom]:
    """The import statements of a module: at module level only, or everywhere (inside functions, methods and
    branches too); imports under ``if TYPE_CHECKING:`` never run and are left out either way (at module level
    every ``if`` is left out, as it always was for the command modules' lightness)."""
    if not inside_functions:
        return [n for n in tree.body if isinstance(n, (ast.Import, ast.ImportFrom))]
    found: list[ast.Import | ast.ImportFrom] = []

    def visit(node: ast.AST) -> None:
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            found.append(node)
        for child in ast.iter_child_nodes(node):
            if _is_type_checking(child):
                for other in child.orelse:
                    visit(other)
            else:
                visit(child)

    visit(tree)
    return found


def _imports(module: Path, inside_functions: bool = False) -> set[str]:
    """Modules of motionrep imported by ``module``: at module level, or anywhere in it (``inside_functions``).

    ``from P import x`` imports the submodule ``P.x`` when there is one (an edge to ``P.x`` only: ``P`` is the
    package ``P.x`` belongs to, initialised first whatever imports it), and otherwise a name of ``P`` itself."""
    rel = module.relative_to(REPO).with_suffix("")
    name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
    package = name if module.name == "__init__.py" else name.rpartition(".")[0]
    out: set[str] = set()
    for node in _import_nodes(ast.parse(module.read_text(encoding="utf-8")), inside_functions):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.startswith("motionrep")}
            continue
        if node.level:
            base = package.split(".")
            base = base[:len(base) - node.level + 1]
            target = ".".join(base + ([node.module] if node.module else []))
        else:
            target = node.module or ""
        if not target.startswith("motionrep"):
            continue
        for a in node.names:
            sub = f"{target}.{a.name}"
            if (REPO / (sub.replace(".", "/") + ".py")).exists() or (REPO / sub.replace(".", "/")).is_dir():
                out.add(sub)
            else:
                out.add(target)
    return out - {name}


def test_no_import_circle():
    """No circle of imports inside ``motionrep``, counting the imports inside functions too (a circle hidden in a
    function still ties the two modules together).  There is no list of allowed circles: a new one is broken
    by moving what both sides need below them (as ``motionrep.pipeline.decode``, ``motionrep.model.ops.detect_up_axis``,
    ``motionrep.pipeline.pairing.skeleton_difference`` and ``motionrep._version`` were)."""
    graph = {}
    for module in _modules():
        rel = module.relative_to(REPO).with_suffix("")
        name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        graph[name] = _imports(module, inside_functions=True)
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


def test_the_import_circle_check_reads_imports_inside_functions(tmp_path, monkeypatch):
    """The circle check sees an import made inside a function (and ignores one under ``if TYPE_CHECKING:``)."""
    pkg = tmp_path / "motionrep"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from . import b\n")
    (pkg / "b.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .c import C\n\n"
                              "def f():\n    from .a import g\n    return g\n")
    (pkg / "c.py").write_text("")
    monkeypatch.setattr(sys.modules[__name__], "REPO", tmp_path)
    monkeypatch.setattr(sys.modules[__name__], "PACKAGE", pkg)
    assert _imports(pkg / "b.py") == set()
    assert _imports(pkg / "b.py", inside_functions=True) == {"motionrep.a"}
    try:
        test_no_import_circle()
    except AssertionError as e:
        assert "motionrep.a -> motionrep.b -> motionrep.a" in str(e)
    else:
        raise AssertionError("the circle a -> b -> a (b's import inside a function) was not found")


def _library_modules() -> list[Path]:
    """Every module of motionrep and of the shipped plugins (their tests and the example plugin aside)."""
    plugins = [p for p in (REPO / "plugins").rglob("*.py")
               if not {"tests", "examples", "__pycache__"} & set(p.relative_to(REPO).parts)]
    return _modules() + sorted(plugins)


def test_long_modules_are_reviewed():
    """No library module over MAX_LINES lines unless LONG_MODULES lists it with its reason; the list names only
    modules that exist and are that long."""
    long = {m.relative_to(REPO).as_posix(): m.read_text(encoding="utf-8").count("\n") for m in _library_modules()}
    long = {name: lines for name, lines in long.items() if lines > MAX_LINES}
    unreviewed = {name: lines for name, lines in long.items() if name not in LONG_MODULES}
    assert not unreviewed, (f"over {MAX_LINES} lines: {unreviewed}; split them (one module, one concern), or add "
                            "them to LONG_MODULES with the reason one concern needs the length")
    stale = sorted(set(LONG_MODULES) - set(long))
    assert not stale, f"LONG_MODULES lists modules no longer over {MAX_LINES} lines (or gone): {stale}"
    assert all(reason.strip() for reason in LONG_MODULES.values())


def test_the_command_modules_are_light():
    """Importing a command module imports click and the standard library only; the library is imported inside
    the command (so that `motionrep --help` never pays for what a command needs)."""
    for module in sorted((PACKAGE / "cli").glob("*.py")):
        if module.name == "__init__.py":
            continue
        imported = _imports(module) - {"motionrep.cli._common", "motionrep.cli._stdin", "motionrep.cli._crosstool",
                                       "motionrep.cli._flags", "motionrep.cli._progress",
                                       "motionrep.cli"}
        assert imported <= {"motionrep.errors", "motionrep.formats", "motionrep.defaults"}, \
            f"{module.name} imports {sorted(imported)} at module level"


def test_the_format_table_is_light():
    """``motionrep.formats`` (which the command modules build their options from) is standard library only."""
    code = "import sys, motionrep.formats; print(sorted(m for m in ('numpy', 'click', 'h5py') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


#: Modules that may spell a clip file's suffix, and why.  Only the table itself: every other module derives its
#: suffixes from ``motionrep.formats``.  (Pictures and pages -- ``.gif``, ``.png``, ``.html`` -- are not clip
#: formats and are not checked.)
SUFFIX_HOMES = {"motionrep/formats.py": "the one table of file formats"}


def test_one_home_for_the_suffixes():
    """No module other than :data:`SUFFIX_HOMES` spells a suffix of the format table (``".bvh"``, ``".h5"``...):
    as a string of its own, in a tuple, a dict or an f-string (text that merely mentions one in a sentence is
    left alone)."""
    from motionrep.formats import BY_SUFFIX

    found = []
    for path in _modules() + sorted((REPO / "plugins").rglob("*.py")):
        rel = path.relative_to(REPO).as_posix()
        if rel in SUFFIX_HOMES or "tests" in path.relative_to(REPO).parts or "__pycache__" in path.parts:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value.lower() in BY_SUFFIX:
                found.append(f"{rel}:{node.lineno} {node.value!r}")
    assert not found, "suffixes spelled outside motionrep/formats.py (derive them from it): " + ", ".join(found)


def test_defaults_have_one_home():
    """``motionrep.defaults`` is the one home of the defaults (no other module assigns one), standard library only,
    and the command line's options show them."""
    from motionrep import defaults
    from motionrep.plugin import hookspecs
    from motionrep.cli import compress as cli_compress
    from motionrep.cli import plugins as cli_plugins

    homes = []
    for path in _modules():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id in defaults.__all__
                                                    for t in node.targets):
                homes.append(path.relative_to(REPO).as_posix())
    assert homes == ["motionrep/defaults.py"] * len(defaults.__all__), homes
    options = {p.name: p.default for p in cli_compress.compress.params}
    assert (options["codec"], options["representation"], options["max_error"]) == (
        defaults.DEFAULT_CODEC, defaults.DEFAULT_REPRESENTATION, defaults.DEFAULT_MAX_ERROR)
    code = "import sys, motionrep.defaults; print(sorted(m for m in ('numpy', 'click') if m in sys.modules))"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip() == "[]"
    assert set(cli_plugins.HOOKS) == {n for n in hookspecs.__all__ if n not in ("hookspec", "hookimpl")}


def test_runtime_never_imports_test_support():
    code = ("import sys, motionrep, motionrep.cli, motionrep.pipeline.compress, motionrep.batch.engine, motionrep.present.bench, "
            "motionrep.present.render, motionrep.io._demo; print('motionrep.testing' in sys.modules)")
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


#: The wings of ``motionrep`` from the bottom up (CONTRIBUTING.md, "Layout"): a module imports only from its own
#: wing and the wings below it.  The base is the top-level modules that hold facts and machinery every wing uses
#: (errors, formats, defaults, limits, the compiler, signals, threads, the version); ``motionrep.testing`` (the
#: conformance suite) and ``torch`` stand above the pipeline, ``cli`` above all.
WINGS = [
    ("base", ("motionrep.errors", "motionrep.formats", "motionrep.defaults", "motionrep.limits", "motionrep.jit",
              "motionrep._signals", "motionrep._threads", "motionrep._version", "motionrep._ccore",
              "motionrep._cpose", "motionrep._cplan", "motionrep._moved")),
    ("model", ("motionrep.model",)),
    ("plugin", ("motionrep.plugin",)),
    ("io", ("motionrep.io",)),
    ("pipeline", ("motionrep.pipeline",)),
    ("batch", ("motionrep.batch",)),
    ("present", ("motionrep.present", "motionrep.torch", "motionrep.testing")),
    ("cli", ("motionrep.cli", "motionrep.__main__", "motionrep")),
]


def _wing(module: str) -> int:
    best, rank = -1, -1
    for i, (_, prefixes) in enumerate(WINGS):
        for prefix in prefixes:
            if (module == prefix or module.startswith(prefix + ".")) and len(prefix) > best:
                best, rank = len(prefix), i
    return rank


def test_every_module_belongs_to_a_wing():
    unplaced = []
    for module in _modules():
        rel = module.relative_to(REPO).with_suffix("")
        name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        if name != "motionrep" and _wing(name) in (-1, len(WINGS) - 1) and not name.startswith("motionrep.cli") \
                and name != "motionrep.__main__":
            unplaced.append(name)
    assert not unplaced, f"modules in no wing (add them to a wing folder or to WINGS' base): {unplaced}"


def test_data_flows_down_the_wings():
    """No import (inside functions too) from a lower wing into a higher one: the model never reaches for a file
    format, a file format never for the pipeline, the pipeline never for the batch engine or the presentation."""
    upward = []
    for module in _modules():
        rel = module.relative_to(REPO).with_suffix("")
        name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        if name == "motionrep":
            continue  # the front door names things from every wing, imported on first use
        for target in sorted(_imports(module, inside_functions=True)):
            if _wing(target) > _wing(name):
                upward.append(f"{name} ({WINGS[_wing(name)][0]}) -> {target} ({WINGS[_wing(target)][0]})")
    assert not upward, "imports up the wings: " + "; ".join(upward)
