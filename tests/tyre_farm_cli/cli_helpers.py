"""Helpers of the CLI tests: run ``farm`` in-process and collect what it printed."""

from __future__ import annotations

import pytest

from tyre_farm_cli import main

#: --set overrides of the smallest full-model mesh (jobs/reproduce COARSE_MESH)
COARSE_FULL = ["--set", "mesh.tread=4", "--set", "mesh.sidewall=2", "--set", "mesh.bead=1",
               "--set", "mesh.circumferential=16"]


def run_cli(argv, capsys) -> tuple[int | None, str, str]:
    """``farm ARGV`` in this process: (exit code, stdout, stderr)."""
    with pytest.raises(SystemExit) as info:
        main(argv)
        raise SystemExit(0)
    out = capsys.readouterr()
    return info.value.code, out.out, out.err
