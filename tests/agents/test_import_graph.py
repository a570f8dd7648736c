"""The agents and the learned modules import without a cycle: every ``import`` of a fallgen
module, at module level or inside a function, is an edge (``from fallgen.agents import X``:
the package's ``__init__``, unless X is a submodule), and no path leads back to where it
started."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2] / "src"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path, modules: set[str]) -> set[str]:
    """The fallgen modules ``path`` imports anywhere in it (``from a import b``: ``a.b``
    when that is a module, else ``a``)."""
    me = module_name(path)
    package = me if path.name == "__init__.py" else me.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join(up + ([base] if base else []))
            names = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base
                     for a in node.names]
        out |= {n for n in names if n in modules}
    out.discard(me)
    return out


def cycle(graph: dict[str, set[str]], within: tuple[str, ...]) -> list[str] | None:
    """A cycle through a module whose name starts with one of ``within``, or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        stack.append(m)
        for n in sorted(graph.get(m, ())):
            if state.get(n) == 1:
                loop = stack[stack.index(n):] + [n]
                if any(x.startswith(within) for x in loop):
                    return loop
            elif n not in state:
                found = visit(n)
                if found:
                    return found
        stack.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state:
            found = visit(m)
            if found:
                return found
    return None


def test_no_import_cycle_through_the_agents_or_the_learned_modules():
    files = sorted((SRC / "fallgen").rglob("*.py"))
    modules = {module_name(p) for p in files}
    graph = {module_name(p): imports(p, modules) for p in files}
    assert "fallgen.agents.base" in graph["fallgen.agents.modular"]
    assert cycle(graph, ("fallgen.agents", "fallgen.learn")) is None, \
        cycle(graph, ("fallgen.agents", "fallgen.learn"))


@pytest.mark.parametrize("graph, loop", [
    ({"a.x": {"a.y"}, "a.y": {"a.x"}}, True),
    ({"a.x": {"a.y"}, "a.y": {"b"}, "b": set()}, False),
])
def test_the_cycle_finder_finds_cycles(graph, loop):
    assert (cycle(graph, ("a",)) is not None) == loop
