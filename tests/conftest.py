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


@pytest.fixture(scope="module")
def s3_endpoint():
    """moto's S3 server on 127.0.0.1 (it honours If-None-Match like AWS), one per module;
    skips without s3fs or moto[server] (``pip install -e '.[test,s3]'``)."""
    s3fs = pytest.importorskip("s3fs", reason="s3fs is not installed (pip install -e '.[s3]')")
    moto_server = pytest.importorskip(
        "moto.server", reason="moto[server] is not installed (pip install -e '.[test]')")
    server = moto_server.ThreadedMotoServer(ip_address="127.0.0.1", port=0, verbose=False)
    server.start()
    host, port = server.get_host_and_port()
    yield f"http://{host}:{port}"
    server.stop()
    s3fs.S3FileSystem.clear_instance_cache()  # none of them may outlive the server
