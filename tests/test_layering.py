"""The import graph of the project's packages (docs/architecture.md, "Layering").

Dependencies point one way: ``jobs -> farm, storage``; ``analysis -> storage``; the CLI
(``tyre_farm_cli``) on top of all of them. Every import counts, also the ones inside functions: a
lazy import that reaches upward is still an arrow the wrong way. And no module imports
itself back through others (the CLI once registered its commands through such a loop), nor
does a subpackage: ``analysis.report`` and ``analysis.studies`` once imported each other
through different modules (issue 25).
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
# The virtual sensor (analysis.camera.sensor) computes T2Cam's CST strain with the very function
# that defines the stored ``surface_strain``: a pure-numpy module that imports nothing of
# the farm (checked below), so the arrow costs analysis no gmsh or solver import.
# The road's axes of a tilted road (issue 45: forces as TYDEX reads them) are shared the
# same way: farm.measure.axes, pure numpy, the one definition for `farm roll` and analysis.
SHARED = {"analysis": {"farm.measure.surface", "farm.measure.axes", "farm.measure", "farm"}}
# ``python -m farm`` runs the CLI: a program's entry point, imported by nothing.
ENTRY_POINTS = {"farm.__main__": {"tyre_farm_cli"}}


def _module(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> set[str]:
    """First-party modules ``path`` imports (anywhere in it), resolved to module names."""
    out = set()
    # a package's __init__.py or __init__.pyi (a lazy package's stub) is its own package
    package = _module(path).rsplit(".", 0 if path.stem == "__init__" else 1)[0]
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
        # A lazy package names its exports in __init__.pyi (lazy_loader): arrows too.
        stub = path.with_suffix(".pyi")
        for imp in _imports(path) | (_imports(stub) if stub.exists() else set()):
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
                   | ENTRY_POINTS.get(m, set()) and t not in SHARED.get(package, set()))
    assert not wrong, f"{package} imports what it must not: {wrong}"


def _cycles(graph: dict[str, set[str]]) -> list[str]:
    """Every cycle a depth-first walk of ``graph`` meets, as ``a -> b -> a``."""
    seen, stack, cycles = set(), [], []

    def visit(m):
        if m in stack:
            cycles.append(" -> ".join([*stack[stack.index(m):], m]))
            return
        if m in seen:
            return
        seen.add(m)
        stack.append(m)
        for t in sorted(graph.get(m, ())):
            visit(t)
        stack.pop()

    for m in sorted(graph):
        visit(m)
    return cycles


def test_no_module_imports_itself_back():
    """No import cycle between modules."""
    cycles = _cycles(GRAPH)
    assert not cycles, cycles


def test_entry_points_are_imported_by_nothing():
    """The exemption above holds only while no module imports the entry point."""
    assert not [m for m, targets in GRAPH.items() if targets & ENTRY_POINTS.keys()]


def test_the_graph_is_not_empty():
    """The check above would pass vacuously if the parser found nothing."""
    assert "jobs.sweep" in GRAPH and "farm.experiment" in GRAPH["jobs.tasks"]
    top = GRAPH["tyre_farm_cli"] | GRAPH["tyre_farm_cli.analyse"]
    assert any(t.startswith("analysis") for t in top)


def _unit_graphs(graph: dict[str, set[str]]) -> dict[str, dict[str, set[str]]]:
    """Per package, the graph of its children (subpackages and modules): child ``a`` ->
    child ``b`` if anything in ``a`` imports anything in ``b``.

    ``analysis.report.ch5 -> analysis.studies.noise -> analysis.report.markdown`` is no
    module cycle, yet ``analysis.report`` and ``analysis.studies`` import each other: the
    one cannot be understood, tested or moved without the other. Between the top-level
    packages the arrows above rule (``farm.__main__`` runs the CLI on purpose).
    """
    packages = {m for m in graph if any(o.startswith(m + ".") for o in graph)}
    units: dict[str, dict[str, set[str]]] = {p: {} for p in packages}
    for m, targets in graph.items():
        for package in packages:
            child = _child(package, m)
            if child is None:
                continue
            edges = units[package].setdefault(child, set())
            edges |= {c for t in targets if (c := _child(package, t)) not in (None, child)}
    return units


def _child(package: str, module: str) -> str | None:
    """The child of ``package`` that holds ``module`` (None: outside it, or its __init__)."""
    if not module.startswith(package + "."):
        return None
    return f"{package}.{module[len(package) + 1:].split('.')[0]}"


def test_no_subpackage_imports_itself_back():
    """No import cycle between the subpackages and modules of one package."""
    cycles = [c for units in _unit_graphs(GRAPH).values() for c in _cycles(units)]
    assert not cycles, cycles


def test_the_subpackage_check_finds_a_cycle_that_is_no_module_cycle():
    """The layout this check was written against (issue 25): report.ch5 imports the
    studies, the studies import report.markdown. No module imports itself back."""
    old = {"analysis.report.ch5": {"analysis.studies.noise"},
           "analysis.studies.noise": {"analysis.report.markdown", "analysis.noise"},
           "analysis.report.markdown": set(), "analysis.noise": set(),
           "analysis.report": set(), "analysis.studies": set(), "analysis": set()}
    assert not _cycles(old)
    assert _cycles(_unit_graphs(old)["analysis"]) == [
        "analysis.report -> analysis.studies -> analysis.report"]
    fixed = old | {"analysis.studies.noise": {"analysis.render.markdown", "analysis.noise"},
                   "analysis.render.markdown": set()}
    assert not [c for units in _unit_graphs(fixed).values() for c in _cycles(units)]


def test_shared_geometry_imports_nothing_of_the_farm():
    """What analysis may import of farm stays free of farm imports (no gmsh, no solver)."""
    for name in SHARED["analysis"]:
        assert not {t for t in GRAPH[name] if t.split(".")[0] in PACKAGES}, name


def _private_uses(source: str) -> list[str]:
    """Private names (``_x``, not dunders) a module takes from another of the farm's
    modules: ``from pkg.mod import _x`` or ``mod._x`` on an imported module."""
    tree = ast.parse(source)
    ours = {"farm", "jobs", "storage", "analysis", "tyre_farm_cli"}
    found, modules = [], set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0 \
                and node.module.split(".")[0] in ours:
            for a in node.names:
                if a.name.startswith("_") and not a.name.startswith("__"):
                    found.append(f"{node.module}.{a.name}")
                else:
                    modules.add(a.asname or a.name)  # may be a module: plots
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] in ours:
                    modules.add(a.asname or a.name.split(".")[0])
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) \
                and node.value.id in modules and node.attr.startswith("_") \
                and not node.attr.startswith("__"):
            found.append(f"{node.value.id}.{node.attr}")
    return found


def test_no_module_uses_another_modules_private_names():
    """Issue 49: private helpers shared across modules (14 imports, e.g. the rolling and
    tree solvers taking contact's ``_solve``, ``_state``, ``_road``) made every new load
    path extend another module's private parts. A name another module needs is public.
    (``storage._zarr`` is a private *module*, the one use of zarr internals: its names
    are public to ``storage``.)"""
    bad = {}
    for path in sorted(ROOT.glob("*/**/*.py")):
        if path.parts[len(ROOT.parts)] not in {"farm", "jobs", "storage", "analysis",
                                               "tyre_farm_cli"}:
            continue
        found = [u for u in _private_uses(path.read_text(encoding="utf-8"))
                 if u not in {"_lazy.attach_stub"}]
        if found:
            bad[str(path.relative_to(ROOT))] = found
    assert not bad, bad


def test_the_private_name_check_finds_both_forms():
    assert _private_uses("from farm.solve.contact import _solve, road_of\n") == [
        "farm.solve.contact._solve"]
    assert _private_uses("from analysis.render import plots\nplots._figure(1)\n") == [
        "plots._figure"]
    assert _private_uses("import numpy as np\nnp._x\nfrom os import _exit\n") == []
