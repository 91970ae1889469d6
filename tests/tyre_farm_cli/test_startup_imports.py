"""``farm --help`` stays fast by what it imports, not by a timed test (timings live in
benchmarks/bench_startup.py): declaring the commands loads none of the heavy libraries,
which the commands import when they run (issue 25: 1.1 s before, 0.3 s after)."""

from __future__ import annotations

import subprocess
import sys

HEAVY = ("xarray", "zarr", "pandas", "dask", "distributed", "scipy", "sklearn",
         "matplotlib", "skops")


def test_building_the_command_tree_imports_no_heavy_library():
    code = ("import sys, tyre_farm_cli; "
            "print(sorted({m.split('.')[0] for m in sys.modules} & set(sys.argv[1:])))")
    out = subprocess.run([sys.executable, "-c", code, *HEAVY], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


def test_farm_help_lists_the_commands_without_loading_them():
    code = ("import sys; from typer.testing import CliRunner; from tyre_farm_cli import app; "
            "r = CliRunner().invoke(app, ['--help']); assert r.exit_code == 0, r.output; "
            "assert 'sweep' in r.output; "
            "print(sorted({m.split('.')[0] for m in sys.modules} & set(sys.argv[1:])))")
    out = subprocess.run([sys.executable, "-c", code, *HEAVY], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"
