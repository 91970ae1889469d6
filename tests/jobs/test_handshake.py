"""A scheduler address must answer as a Dask scheduler, within a deadline (issue 26).

Before: a port that accepted and never answered hung `farm sweep submit` for minutes
(Client's timeout covers the connection, not the handshake); an HTTP server's bytes
were read as a frame length ("Unable to allocate 3.07 EiB"); ucx:// was a TypeError.
"""

import http.server
import socket
import threading
import time

import pytest

from jobs.errors import ClusterError
from jobs.handshake import check_scheduler
from tyre_farm_cli import main


@pytest.fixture
def silent_port():
    """A port that accepts connections and never says a word."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    held = []
    stop = threading.Event()

    def accept():
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                held.append(server.accept()[0])
            except OSError:
                continue

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    yield server.getsockname()[1]
    stop.set()
    thread.join()
    for c in held:
        c.close()
    server.close()


@pytest.fixture
def http_port():
    """An HTTP server (e.g. the dashboard given as the scheduler)."""
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0),
                                             http.server.SimpleHTTPRequestHandler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield server.server_address[1]
    server.shutdown()
    server.server_close()


@pytest.fixture
def banner_port():
    """A service that greets every connection with a banner line (as SSH does)."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    stop = threading.Event()

    def serve():
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                conn = server.accept()[0]
            except OSError:
                continue
            with conn:
                conn.sendall(b"SSH-2.0-OpenSSH_9.2\r\n" + b"\xff" * 64)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield server.getsockname()[1]
    stop.set()
    thread.join()
    server.close()


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_a_silent_port_is_refused_within_the_deadline(silent_port):
    start = time.monotonic()
    with pytest.raises(ClusterError, match="accepted no Dask handshake within 2 s"):
        check_scheduler(f"tcp://127.0.0.1:{silent_port}", 2.0)
    assert time.monotonic() - start < 10.0


def test_an_http_server_is_not_a_scheduler(http_port):
    with pytest.raises(ClusterError, match=f"127.0.0.1:{http_port}") as info:
        check_scheduler(f"tcp://127.0.0.1:{http_port}", 2.0)
    assert "not its dashboard" in str(info.value) and "\n" not in str(info.value)


def test_an_http_server_is_named_not_read_as_a_frame_length(http_port):
    """Issue 50: an HTTP reply read as a frame length was "MemoryError: Unable to
    allocate 3.07 EiB"; the line says what answers instead."""
    with pytest.raises(ClusterError) as info:
        check_scheduler(f"tcp://127.0.0.1:{http_port}", 2.0)
    line = str(info.value)
    assert "an HTTP server answers there, 'HTTP/1" in line, line
    assert "EiB" not in line and "MemoryError" not in line


def test_another_service_is_quoted(banner_port):
    with pytest.raises(ClusterError) as info:
        check_scheduler(f"tcp://127.0.0.1:{banner_port}", 2.0)
    assert "an SSH server answers there, 'SSH-2.0-OpenSSH_9.2'" in str(info.value)


def test_nothing_listening_is_said_at_once():
    start = time.monotonic()
    with pytest.raises(OSError, match="refused"):
        check_scheduler(f"tcp://127.0.0.1:{_free_port()}", 20.0)
    assert time.monotonic() - start < 5.0


def test_a_real_scheduler_answers():
    from distributed import LocalCluster

    with LocalCluster(n_workers=0, processes=False, dashboard_address=":0") as cluster:
        reply = check_scheduler(cluster.scheduler_address, 10.0)
    assert reply["type"] == "Scheduler"


@pytest.mark.parametrize("make", ["silent", "ucx"])
def test_the_cli_says_one_line_and_submits_nothing(make, silent_port, tmp_path, capsys,
                                                   monkeypatch):
    import jobs.cluster

    monkeypatch.setattr(jobs.cluster, "CONNECT_TIMEOUT", "2s")
    study = tmp_path / "s.toml"
    study.write_text(f'[study]\nname = "t"\nstore = "{tmp_path / "s.zarr"}"\n[model]\n'
                     'kind = "reduced"\n[loads]\ndeflection_mm = [10]\n')
    address = (f"tcp://127.0.0.1:{silent_port}" if make == "silent"
               else "ucx://127.0.0.1:13337")
    with pytest.raises(SystemExit) as info:
        main(["sweep", "submit", str(study), "--scheduler", address])
    err = capsys.readouterr().err
    assert info.value.code != 0 and err.count("\n") == 1, err
    assert ("no Dask handshake" if make == "silent" else "not supported") in err
    assert not (tmp_path / "s.zarr").exists()


def test_analyse_with_a_silent_scheduler_is_one_line(silent_port, tmp_path, capsys,
                                                      monkeypatch):
    import analysis.cluster

    monkeypatch.setattr(analysis.cluster, "CONNECT_TIMEOUT", "2s")
    start = time.monotonic()
    with pytest.raises(SystemExit) as info:
        main(["analyse", "pca", str(tmp_path / "none.zarr"), "--scheduler",
              f"tcp://127.0.0.1:{silent_port}"])
    err = capsys.readouterr().err
    assert info.value.code != 0 and err.count("\n") == 1, err
    assert "accepted no Dask handshake within 2 s" in err  # the scheduler, before the store
    assert time.monotonic() - start < 30.0
