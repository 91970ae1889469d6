"""The import graph of the project's packages (docs/architecture.md, "Layering").

Dependencies point one way: ``jobs -> farm, storage``; ``analysis -> storage``; the CLI
(``tyre_farm_cli``) on top of all of them. Every import counts, also the ones inside functions: a
lazy import that reaches upward is still an arrow the wrong way. And no module imports
itself back through others (the CLI once registered its commands through such a loop).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("farm", "storage", "jobs", "analysis", "tyre_farm_cli")
ALLOWED = {
    "farm": {"farm"},
    "storage": {"storage"},
    "jobs": {"jobs", "farm", "storage"},
    "analysis": {"analysis", "storage"},
    "tyre_farm_cli": set(PACKAGES),
}
# ``python -m farm`` runs the CLI: a program's entry point, imported by nothing.
ENTRY_POINTS = {"farm.__main__": {"tyre_farm_cli"}}


def _module(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> set[str]:
    """First-party modules ``path`` imports (anywhere in it), resolved to module names."""
    out = set()
    package = _module(path).rsplit(".", 0 if path.name == "__init__.py" else 1)[0]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1]
                                + ([base] if base else []))
            names = [f"{base}.{a.name}" for a in node.names] + [base]
        else:
            continue
        out |= {n for n in names if n.split(".")[0] in PACKAGES}
    return out


def _graph() -> dict[str, set[str]]:
    files = {_module(p): p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py")}
    graph = {}
    for name, path in files.items():
        targets = set()
        for imp in _imports(path):
            while imp and imp not in files:  # `from pkg.mod import name` -> pkg.mod
                imp = imp.rpartition(".")[0]
            if imp and imp != name:
                targets.add(imp)
        graph[name] = targets
    return graph


GRAPH = _graph()


@pytest.mark.parametrize("package", PACKAGES)
def test_no_arrow_points_the_wrong_way(package):
    wrong = sorted(f"{m} -> {t}" for m, targets in GRAPH.items() if m.split(".")[0] == package
                   for t in targets if t.split(".")[0] not in ALLOWED[package]
                   | ENTRY_POINTS.get(m, set()))
    assert not wrong, f"{package} imports what it must not: {wrong}"


def test_no_module_imports_itself_back():
    """No import cycle between modules."""
    seen, stack, cycles = set(), [], []

    def visit(m):
        if m in stack:
            cycles.append(" -> ".join([*stack[stack.index(m):], m]))
            return
        if m in seen:
            return
        seen.add(m)
        stack.append(m)
        for t in sorted(GRAPH.get(m, ())):
            visit(t)
        stack.pop()

    for m in sorted(GRAPH):
        visit(m)
    assert not cycles, cycles


def test_entry_points_are_imported_by_nothing():
    """The exemption above holds only while no module imports the entry point."""
    assert not [m for m, targets in GRAPH.items() if targets & ENTRY_POINTS.keys()]


def test_the_graph_is_not_empty():
    """The check above would pass vacuously if the parser found nothing."""
    assert "jobs.sweep" in GRAPH and "farm.experiment" in GRAPH["jobs.tasks"]
    top = GRAPH["tyre_farm_cli"] | GRAPH["tyre_farm_cli.analyse"]
    assert any(t.startswith("analysis") for t in top)
