"""Bare ccx timing shared by the benchmarks: the decks alone, plain subprocess, one thread.

Deliberately NOT the package's runner: this is the baseline the package is measured
against.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

from farm.ccx.runner import find_ccx


def bare_seconds(decks: list[Path]) -> float:
    """Wall seconds of ``ccx -i job`` on each deck in turn, in fresh directories."""
    exe, total = find_ccx(), 0.0
    env = {**os.environ, "LC_ALL": "C", "OMP_NUM_THREADS": "1", "CCX_NPROC_EQUATION_SOLVER": "1"}
    with tempfile.TemporaryDirectory() as tmp:
        for k, deck in enumerate(decks):
            work = Path(tmp) / str(k)
            work.mkdir()
            shutil.copy(deck, work / "job.inp")
            start = time.perf_counter()
            subprocess.run([exe, "-i", "job"], cwd=work, env=env, check=True,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            total += time.perf_counter() - start
    return total
