"""The cluster front door: the dashboard, the scheduler from the environment, a busy port.

Each embedded cluster here has one worker process (the machine is shared; what is tested
is the front door, not throughput).
"""

import socket
import sys
import urllib.request
import warnings
from urllib.parse import urlparse

import dask
import pytest
from dask.utils import parse_timedelta

from jobs.cluster import connect, dashboard_link, resolve_scheduler
from jobs.driver import Announce
from jobs.errors import ClusterError
from jobs.progress import Session

# what Python hides from users by default (distributed leaves a ResourceWarning behind)
HIDDEN = (ResourceWarning, DeprecationWarning, PendingDeprecationWarning, ImportWarning)


@pytest.fixture(scope="module")
def external():
    """A scheduler started apart from the code under test (in-process, one thread)."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=":0") as cluster:
        yield cluster.scheduler_address


def _fetch(url: str) -> tuple[int, str]:
    with urllib.request.urlopen(url, timeout=60) as response:
        return response.status, response.read().decode(errors="replace")


def test_dashboard_serves_its_status_page():
    with connect(workers=1) as client:
        link = dashboard_link(client)
        status, page = _fetch(link)
        # while it runs, the cluster never closes a nanny whose worker died (it restarts
        # it): with the default 15 s, a worker lost twice 15 s apart was gone for good
        lost = dask.config.get("distributed.deploy.lost-worker-timeout")
        assert parse_timedelta(lost) >= 3600
    assert urlparse(link).path == "/status"
    assert status == 200
    assert "needs bokeh" not in page  # what distributed serves when bokeh is missing
    assert "Dask" in page and "<script" in page and "bokeh" in page.lower()


def test_a_busy_dashboard_port_is_silent_and_the_link_is_the_real_one():
    with socket.socket() as busy:
        # as servers bind: a connection of an earlier test in TIME_WAIT does not stop it
        busy.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            busy.bind(("127.0.0.1", 8787))
            busy.listen()
        except OSError:
            pass  # already taken by someone else: busy all the same
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with connect(workers=1) as client:
                link = dashboard_link(client)
                status, _ = _fetch(link)
    shown = [str(w.message) for w in caught if not issubclass(w.category, HIDDEN)]
    assert shown == []
    assert urlparse(link).port != 8787 and status == 200


def test_scheduler_order_argument_then_farm_then_dask(monkeypatch):
    monkeypatch.delenv("FARM_SCHEDULER", raising=False)
    monkeypatch.delenv("DASK_SCHEDULER_ADDRESS", raising=False)
    assert resolve_scheduler(None) is None
    monkeypatch.setenv("DASK_SCHEDULER_ADDRESS", "tcp://dask:8786")
    assert resolve_scheduler(None) == "tcp://dask:8786"
    monkeypatch.setenv("FARM_SCHEDULER", "tcp://farm:8786")
    assert resolve_scheduler(None) == "tcp://farm:8786"
    assert resolve_scheduler("tcp://given:8786") == "tcp://given:8786"
    monkeypatch.setenv("FARM_SCHEDULER", "  ")  # blank is unset
    assert resolve_scheduler(None) == "tcp://dask:8786"


@pytest.mark.parametrize("variable", ["FARM_SCHEDULER", "DASK_SCHEDULER_ADDRESS"])
def test_connect_joins_the_scheduler_named_in_the_environment(external, monkeypatch, variable):
    monkeypatch.delenv("FARM_SCHEDULER", raising=False)
    monkeypatch.delenv("DASK_SCHEDULER_ADDRESS", raising=False)
    monkeypatch.setenv(variable, external)
    with connect() as client:
        assert client.scheduler.address == external  # not a new embedded cluster


def test_farm_scheduler_wins_over_dask_scheduler_address(external, monkeypatch):
    monkeypatch.setenv("DASK_SCHEDULER_ADDRESS", "tcp://127.0.0.1:1")  # nobody there
    monkeypatch.setenv("FARM_SCHEDULER", external)
    with connect() as client:
        assert client.scheduler.address == external


def test_too_few_workers_is_a_cluster_error(external, monkeypatch):
    monkeypatch.setattr("jobs.cluster.WAIT_FOR_WORKERS_SECONDS", 1)
    with pytest.raises(ClusterError, match="has 1 of the 3 workers"), connect(external, 3):
        pass


@pytest.mark.parametrize("address", ["not a url", "foo://bar:1"])
def test_a_malformed_address_is_a_cluster_error(address):
    with pytest.raises(ClusterError, match="scheduler"), connect(address):
        pass


def test_runs_without_a_front_end_print_the_dashboard(capsys):
    # `farm reproduce` drives its sweeps and loops without a progress display
    Announce().started(Session(None, "CalculiX 2.20", "http://127.0.0.1:8790/status", 2), None)
    err = capsys.readouterr().err
    assert "http://127.0.0.1:8790/status" in err and "workers: 2" in err


def test_bokeh_is_a_declared_dependency():
    import tomllib
    from pathlib import Path

    pyproject = tomllib.loads((Path(__file__).parents[2] / "pyproject.toml").read_text())
    assert any(d.replace(" ", "").startswith("bokeh>=3.1")
               for d in pyproject["project"]["dependencies"]), sys.executable
