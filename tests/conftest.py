"""Shared fixtures: the real CalculiX solver.

Tests that need ``ccx`` use the ``ccx`` fixture (or the ``ccx`` marker). Without the
solver they skip on a developer's machine, but ``FARM_REQUIRE_CCX=1`` (set by
``scripts/test.sh``, hence by CI) turns that skip into a failure.
"""

from __future__ import annotations

import os
import shutil

import pytest

REQUIRE_CCX = os.environ.get("FARM_REQUIRE_CCX") == "1"


def _ccx_or_skip() -> str:
    exe = shutil.which(os.environ.get("FARM_CCX", "ccx"))
    if exe is None:
        if REQUIRE_CCX:
            pytest.fail("ccx is required here (FARM_REQUIRE_CCX=1) but not on PATH")
        pytest.skip("ccx not installed: `bash scripts/test.sh` installs calculix-ccx")
    return exe


@pytest.fixture(scope="session")
def ccx() -> str:
    """Path of the ``ccx`` executable."""
    return _ccx_or_skip()


@pytest.fixture(scope="session")
def docker_compose() -> str:
    """Debian's ``docker-compose`` (validates the compose file; no engine needed)."""
    exe = shutil.which("docker-compose")
    if exe is None:
        if REQUIRE_CCX:
            pytest.fail("docker-compose is required here but not on PATH (scripts/setup.sh "
                        "installs it)")
        pytest.skip("docker-compose not installed: `bash scripts/test.sh` installs it")
    return exe


def pytest_collection_modifyitems(config, items):
    for item in items:
        if "ccx" in item.keywords and "ccx" not in getattr(item, "fixturenames", ()):
            item.fixturenames.append("ccx")
