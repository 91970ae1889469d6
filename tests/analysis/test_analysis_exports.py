"""``analysis``'s public names: the lazy table and its ``TYPE_CHECKING`` mirror agree, every
name resolves, and ``import analysis`` stays cheap (it is on ``farm --help``'s path)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import analysis

INIT = Path(analysis.__file__)


def _type_checking_imports() -> dict[str, str]:
    """name -> module of the imports under ``if TYPE_CHECKING:`` in analysis/__init__.py."""
    out = {}
    for node in ast.parse(INIT.read_text()).body:
        if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
            for imp in node.body:
                out |= {a.name: imp.module for a in imp.names}
    return out


def test_the_type_checking_block_and_all_mirror_the_lazy_table():
    assert _type_checking_imports() == analysis._EXPORTS
    assert analysis.__all__ == sorted(analysis._EXPORTS)


def test_every_public_name_resolves_to_its_module():
    for name, module in analysis._EXPORTS.items():
        assert getattr(analysis, name).__module__.startswith(module.rsplit(".", 1)[0]), name


def test_importing_the_package_imports_none_of_its_heavy_modules():
    code = ("import sys, analysis; print(sorted(m for m in sys.modules if m in "
            "{'sklearn', 'scipy', 'dask', 'analysis.data', 'analysis.pls'}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
