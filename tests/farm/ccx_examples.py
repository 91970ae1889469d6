"""Shared by the reader tests: fixture decks and CalculiX's published examples, solved
through the farm's own runner (the one choke-point for ccx)."""

from __future__ import annotations

import gzip
import os
from pathlib import Path

import pytest

from farm.ccx.runner import CcxRun, run_ccx

DATA = Path(__file__).parent / "data"
DEBIAN_EXAMPLES = "/usr/share/doc/calculix-ccx-test/examples/test"
EXAMPLES = Path(os.environ.get("FARM_CCX_EXAMPLES", DEBIAN_EXAMPLES))


def solve(deck: Path, workdir: Path) -> CcxRun:
    """Run ccx on ``deck`` (plain or gzipped) in ``workdir`` on one thread; never raises."""
    workdir.mkdir(parents=True, exist_ok=True)
    text = gzip.decompress(deck.read_bytes()).decode() if deck.suffix == ".gz" else deck.read_text()
    return run_ccx(text, workdir, jobname=deck.name.removesuffix(".gz").removesuffix(".inp"),
                   timeout=120, check=False)


def example(name: str, suffix: str) -> Path:
    """A file of the ccx test suite, plain or gzipped; skip (or fail in CI) without it."""
    for path in (EXAMPLES / f"{name}{suffix}", EXAMPLES / f"{name}{suffix}.gz"):
        if path.exists():
            return path
    message = f"CalculiX examples not found in {EXAMPLES} (apt-get install calculix-ccx-test)"
    if os.environ.get("FARM_REQUIRE_CCX") == "1":
        pytest.fail(message)
    pytest.skip(message)
