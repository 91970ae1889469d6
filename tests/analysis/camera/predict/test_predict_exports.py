"""analysis.camera.predict's lazy public names, and its errors' one-line form."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import analysis.camera.predict as predict
from analysis import errors

ROOT = Path(__file__).resolve().parents[4]


def test_all_mirrors_the_lazy_table_and_the_type_checking_block():
    assert sorted(predict.__all__) == sorted(predict._EXPORTS)
    tree = ast.parse((ROOT / "analysis" / "camera" / "predict" / "__init__.py").read_text())
    block = next(n for n in tree.body if isinstance(n, ast.If))
    names = {a.name: imp.module for imp in block.body if isinstance(imp, ast.ImportFrom)
             for a in imp.names}
    assert names == predict._EXPORTS


def test_every_public_name_resolves():
    for name, module in predict._EXPORTS.items():
        value = getattr(predict, name)
        assert getattr(value, "__module__", module) == module


def test_the_new_errors_are_exported():
    for name in ("CloudError", "RegistrationError", "ModelFileError"):
        assert name in errors.__all__
        assert issubclass(getattr(errors, name), errors.AnalysisError)


def test_importing_intervals_pulls_in_neither_meshio_nor_skops():
    code = ("import sys, analysis.camera.predict.intervals; "
            "print(sorted(m for m in ('meshio', 'skops') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, check=True)
    assert out.stdout.strip() == "[]"
