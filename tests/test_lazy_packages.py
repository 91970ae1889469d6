"""The lazily loaded packages (``analysis``, ``analysis.camera``, ``storage``): every name
their stub promises resolves to the module it names, the stub's ``__all__`` is the
package's, and importing the package (as ``farm --help`` does, through their ``errors``
modules) loads nothing heavy."""

from __future__ import annotations

import ast
import importlib
import subprocess
import sys
from pathlib import Path

import pytest

HEAVY = {
    "analysis": {"sklearn", "scipy", "dask", "xarray", "analysis.data", "analysis.pls"},
    "analysis.camera": {"sklearn", "scipy", "xarray", "meshio", "skops",
                        "analysis.camera.predictor", "analysis.camera.sensor"},
    "storage": {"xarray", "zarr", "pandas", "storage.read", "storage.group"},
}
#: what the CLI imports at start-up of each package (its errors; the camera has none)
FIRST = {"analysis": "analysis.errors", "analysis.camera": "analysis.camera",
         "storage": "storage.errors"}


def _stub(package: str) -> tuple[dict[str, str], list[str]]:
    """name -> submodule of the stub's imports, and the stub's ``__all__``."""
    path = Path(importlib.import_module(package).__file__).with_suffix(".pyi")
    names, all_ = {}, []
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.ImportFrom):
            names |= {a.name: f"{package}.{node.module}" for a in node.names}
        elif isinstance(node, ast.Assign) and node.targets[0].id == "__all__":
            all_ = ast.literal_eval(node.value)
    return names, all_


@pytest.mark.parametrize("package", sorted(HEAVY))
def test_the_stub_lists_each_name_once_and_all_is_the_packages(package):
    names, all_ = _stub(package)
    assert sorted(all_) == sorted(names) == importlib.import_module(package).__all__


@pytest.mark.parametrize("package", sorted(HEAVY))
def test_every_name_resolves_to_the_module_the_stub_names(package):
    module = importlib.import_module(package)
    for name, where in _stub(package)[0].items():
        value = getattr(module, name)
        assert value is getattr(importlib.import_module(where), name), name


@pytest.mark.parametrize("package", sorted(HEAVY))
def test_importing_the_package_or_its_errors_loads_nothing_heavy(package):
    code = (f"import sys, {FIRST[package]}; "
            f"print(sorted(m for m in sys.modules if m in {sorted(HEAVY[package])!r}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize(("submodule", "name"), [("storage.reserve", "reserve"),
                                                 ("storage.verify", "verify")])
def test_a_function_named_like_its_module_is_not_shadowed_by_importing_the_module(
        submodule, name):
    # ``import storage.reserve`` binds the *module* on the package unless the loader guards
    # it; ``storage.reserve(...)`` (jobs/sweep.py) needs the function.
    code = f"import {submodule}, storage; print(callable(storage.{name}))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "True"
