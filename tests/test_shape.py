"""The package's shape: no import cycle among fallgen's modules (every import counts, at module
level, inside a function or under ``TYPE_CHECKING``), no module over 600 lines, no private
name imported from another package, ``fallgen`` and its command line import without torch
(the ``learn`` extra), and the code, tests, benchmarks and documentation name behaviour
rather than the tracker's issue numbers."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SRC = REPO / "src"
PKG = SRC / "fallgen"
MAX_LINES = 600


def module_name(path: Path, src: Path = SRC) -> str:
    parts = list(path.relative_to(src).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def package_of(path: Path, src: Path = SRC) -> str:
    name = module_name(path, src)
    return name if path.name == "__init__.py" else name.rpartition(".")[0]


def imported(path: Path, modules: set[str], src: Path = SRC) -> list[tuple[str, str, int]]:
    """(module, name or '', line) of every import of a fallgen module in ``path``: ``from a
    import b`` is module ``a.b`` when that is a module, else module ``a`` and name ``b``;
    relative imports resolved against the file's package."""
    package = package_of(path, src)
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(a.name, "", node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")
                up = up[:len(up) - node.level + 1]
                base = ".".join(up + ([base] if base else []))
            for a in node.names:
                sub = f"{base}.{a.name}"
                out.append((sub, "", node.lineno) if sub in modules
                           else (base, a.name, node.lineno))
    found = []
    for mod, name, line in out:
        while mod and mod not in modules:  # `import fallgen.x.y` of a package's attribute
            mod = mod.rpartition(".")[0]
        if mod.startswith("fallgen"):
            found.append((mod, name, line))
    return found


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of ``graph`` with more than one module (Tarjan),
    each sorted: every import cycle lies inside one."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(found)


FILES = sorted(PKG.rglob("*.py"))
MODULES = {module_name(p) for p in FILES}


def import_graph() -> dict[str, set[str]]:
    return {module_name(p): {m for m, _, _ in imported(p, MODULES)} - {module_name(p)}
            for p in FILES}


def test_no_import_cycle_among_fallgens_modules():
    graph = import_graph()
    # function-level imports are edges too: the audio modules import each other that way
    assert "fallgen.audio.coupling_kernel" in graph["fallgen.audio.coupling"]
    assert "fallgen.physics.drop" in graph["fallgen.audio.fall"]
    assert cycles(graph) == []


@pytest.mark.parametrize("graph, expected", [
    ({"a": {"b"}, "b": {"a"}}, [["a", "b"]]),
    ({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}, [["a", "b", "c"]]),
    ({"a": {"b"}, "b": {"c"}, "c": set()}, []),
    ({"a": {"b"}, "b": {"a"}, "c": {"d"}, "d": {"c"}}, [["a", "b"], ["c", "d"]]),
])
def test_the_cycle_finder_finds_every_cycle(graph, expected):
    assert cycles(graph) == expected


def test_the_import_walk_sees_function_level_and_relative_imports(tmp_path):
    pkg = tmp_path / "fallgen" / "sub"
    pkg.mkdir(parents=True)
    f = pkg / "m.py"
    f.write_text("from . import other\nfrom .other import _hidden\n"
                 "def g():\n    from fallgen.sub.other import thing\n")
    mods = {"fallgen.sub", "fallgen.sub.m", "fallgen.sub.other"}
    assert imported(f, mods, src=tmp_path) == [
        ("fallgen.sub.other", "", 1), ("fallgen.sub.other", "_hidden", 2),
        ("fallgen.sub.other", "thing", 4)]


def test_no_module_over_600_lines():
    long = {str(p.relative_to(REPO)): n for p in FILES
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert long == {}


def test_no_private_name_imported_from_another_package():
    """``from fallgen.physics.drop import _instance`` in fallgen.audio reaches into another
    package's internals; within one package a module may share its private helpers."""
    bad = []
    for p in FILES:
        for mod, name, line in imported(p, MODULES):
            if name.startswith("_") and not name.startswith("__"):
                src_pkg = mod if (PKG.parent / (mod.replace(".", "/") + "/__init__.py")
                                  ).is_file() else mod.rpartition(".")[0]
                if src_pkg != package_of(p):
                    bad.append(f"{p.relative_to(REPO)}:{line}: {mod}.{name}")
    assert bad == []


def test_fallgen_and_its_command_line_import_without_torch():
    """torch comes with the ``learn`` extra only: the package, the environment, the agents,
    the evaluation and ``fallgen --help`` work where importing it fails."""
    code = (
        "import sys\n"
        "sys.modules['torch'] = None  # `import torch` raises ImportError\n"
        "import fallgen, fallgen.cli, fallgen.env, fallgen.dataset, fallgen.agents, "
        "fallgen.evaluation\n"
        "from typer.testing import CliRunner\n"
        "r = CliRunner().invoke(fallgen.cli.app, ['--help'])\n"
        "assert r.exit_code == 0, r.output\n"
        "assert sys.modules['torch'] is None\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]


# --- the tracker's numbers ---------------------------------------------------------------------

#: "issue" followed by a number, or "the issue" / "issue's".
TRACKER = re.compile(r"\bissue(?:[ s]*#?[0-9]|'s)|\bthe issue\b", re.I)
#: Where behaviour is described; CHANGELOG.md is history and may cite where a change came from.
WHERE = ("src", "tests", "bench", "docs", "materials", "configs", "scripts", "README.md",
         "Makefile")
def tracker_mentions() -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for where in WHERE:
        root = REPO / where
        files = [root] if root.is_file() else sorted(
            p for p in root.rglob("*") if p.is_file() and p.suffix in (".py", ".md", ".toml", ".sh"))
        for p in files:
            if p == Path(__file__).resolve():  # the patterns and reasons below
                continue
            for k, line in enumerate(p.read_text(errors="replace").splitlines(), 1):
                if TRACKER.search(line):
                    out.setdefault(str(p.relative_to(REPO)), []).append(f"{k}: {line.strip()}")
    return out


def test_the_tracker_pattern_matches_what_it_should():
    said = ["(issue 30)", "Issue 29's measure", "the issue's bar", "issue #12", "issues 27"]
    assert all(TRACKER.search(s) for s in said)
    assert not any(TRACKER.search(s) for s in ("an issue of the journal", "tissue 3 mm",
                                               "goals stop 10 cm short"))


def test_code_tests_and_docs_name_behaviour_not_the_tracker():
    assert tracker_mentions() == {}
