"""Dask TLS (jobs/tls.py, ``--tls-*``): the files checked at the boundary, the address and
TLS settings checked against each other, and real TLS clusters - a sweep through the CLI
on a ``tls://`` scheduler, the embedded cluster encrypted, clients without the right
certificates refused. No dask mocks: certificates from ``cryptography``, real schedulers."""

from __future__ import annotations

import json
import os

import dask
import pytest

import jobs.cluster
import storage
from jobs.cluster import DaskCluster, connect
from jobs.errors import ClusterError
from jobs.tls import TlsFiles, check_file
from tests.jobs.conftest import study_text
from tests.jobs.tls_certs import make_certificates
from tyre_farm_cli import main


@pytest.fixture(scope="module")
def certs(tmp_path_factory):
    return make_certificates(tmp_path_factory.mktemp("tls"))


@pytest.fixture(scope="module")
def strangers(tmp_path_factory):
    """Certificates of another CA: well-formed, not trusted by the cluster."""
    return make_certificates(tmp_path_factory.mktemp("other-tls"), prefix="other-")


@pytest.fixture(scope="module")
def tls_scheduler(certs):
    """A real TLS scheduler with one worker process (ccx runs there)."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=":0", security=TlsFiles(*certs).cluster_security(),
                      silence_logs=40) as cluster:
        yield cluster.scheduler_address


def _cli(argv, capsys) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as info:
        main(argv)
        raise SystemExit(0)
    out = capsys.readouterr()
    return info.value.code, out.out, out.err


def _tls_args(files) -> list[str]:
    return [a for option, path in zip(("--tls-ca-file", "--tls-cert", "--tls-key"), files,
                                      strict=True) for a in (option, str(path))]


# ------------------------------------------------------------------------ checks at the boundary

def test_the_three_files_are_checked_and_resolved(certs, tmp_path, monkeypatch):
    monkeypatch.chdir(certs[0].parent)
    files = TlsFiles.from_options(*(p.name for p in certs))
    assert (files.ca_file, files.cert, files.key) == certs


@pytest.mark.parametrize("given, missing", [((0,), "--tls-cert, --tls-key"),
                                            ((1, 2), "--tls-ca-file"), ((0, 2), "--tls-cert")])
def test_all_three_files_or_none(certs, given, missing):
    args = [certs[k] if k in given else None for k in range(3)]
    with pytest.raises(ClusterError, match=f"{missing} missing; give all three or none"):
        TlsFiles.from_options(*args)
    assert TlsFiles.from_options(None, None, None) is None


def test_a_missing_file_or_a_folder_is_one_clear_line(tmp_path):
    with pytest.raises(ClusterError, match=r"--tls-key: '.*nope.pem' does not exist"):
        check_file(tmp_path / "nope.pem", "--tls-key")
    with pytest.raises(ClusterError, match="is not a regular file"):
        check_file(tmp_path, "--tls-ca-file")


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads every file")
def test_an_unreadable_file_is_refused(certs, tmp_path):
    locked = tmp_path / "locked.pem"
    locked.write_bytes(certs[2].read_bytes())
    locked.chmod(0)
    with pytest.raises(ClusterError, match="not readable"):
        check_file(locked, "--tls-key")


def test_a_tls_address_needs_certificates(monkeypatch):
    monkeypatch.delenv("FARM_SCHEDULER", raising=False)
    with pytest.raises(ClusterError, match=r"speaks TLS but no certificates .* --tls-ca-file"):
        DaskCluster("tls://127.0.0.1:8786")
    monkeypatch.setenv("FARM_SCHEDULER", "tls://127.0.0.1:8786")  # the env route too
    with pytest.raises(ClusterError, match="speaks TLS but no certificates"):
        DaskCluster()


def test_dask_config_certificates_count(certs):
    # DASK_DISTRIBUTED__COMM__TLS__* end up here; a Client reads them itself
    with dask.config.set({"distributed.comm.tls.ca-file": str(certs[0]),
                          "distributed.comm.tls.client.cert": str(certs[1]),
                          "distributed.comm.tls.client.key": str(certs[2])}):
        assert DaskCluster("tls://127.0.0.1:8786").tls is None


def test_certificates_with_a_plain_tcp_address_are_refused(certs):
    with pytest.raises(ClusterError, match="is not tls://: give it as tls://host:port"):
        DaskCluster("tcp://127.0.0.1:8786", tls=TlsFiles(*certs))


def test_tls_usage_errors_exit_2_before_anything_starts(certs, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(jobs.cluster, "connect", lambda *a, **k: pytest.fail("connected"))
    study = tmp_path / "study.toml"
    study.write_text(study_text(tmp_path / "store.zarr"))
    for argv, needle in [
        (["--scheduler", "tls://127.0.0.1:1"], "speaks TLS but no certificates"),
        (["--tls-ca-file", str(certs[0])], "--tls-cert, --tls-key missing"),
        ([*_tls_args(certs), "--scheduler", "tcp://127.0.0.1:1"], "is not tls://"),
        (_tls_args((tmp_path / "ca.pem", *certs[1:])), "--tls-ca-file: '"),
    ]:
        code, out, err = _cli(["sweep", "submit", str(study), *argv], capsys)
        assert code == 2 and out == "", (argv, err)
        assert err.startswith("farm: error: ") and err.count("\n") == 1 and needle in err, err
    assert not (tmp_path / "store.zarr").exists()


# --------------------------------------------------------------------------- real TLS clusters

@pytest.mark.ccx
def test_a_sweep_runs_through_the_cli_on_a_tls_scheduler(tls_scheduler, certs, tmp_path,
                                                         capsys):
    assert tls_scheduler.startswith("tls://")
    study = tmp_path / "study.toml"
    study.write_text(study_text(tmp_path / "store.zarr", deflections="[10, 20]"))
    code, out, err = _cli(["sweep", "submit", str(study), "--scheduler", tls_scheduler,
                           *_tls_args(certs), "--json"], capsys)
    assert code == 0, err
    summary = json.loads(out)
    assert summary["ok"] and summary["done_now"] == 2 and summary["failed"] == []
    assert storage.status_counts(str(tmp_path / "store.zarr"), summary["group"]) == {
        "pending": 0, "done": 2, "failed": 0}


@pytest.mark.parametrize("who", ["other CA", "plain tcp"])
def test_clients_without_the_clusters_certificates_are_refused(who, tls_scheduler, strangers,
                                                               capsys, monkeypatch, tmp_path):
    monkeypatch.setattr(jobs.cluster, "CONNECT_TIMEOUT", "5s")
    study = tmp_path / "study.toml"
    study.write_text(study_text(tmp_path / "store.zarr"))
    argv = (["--scheduler", tls_scheduler, *_tls_args(strangers)] if who == "other CA" else
            ["--scheduler", tls_scheduler.replace("tls://", "tcp://")])
    code, out, err = _cli(["sweep", "submit", str(study), *argv], capsys)
    assert code == 1 and out == ""
    assert err.startswith("farm: error: cannot reach the Dask scheduler at ")
    assert err.count("\n") == 1
    assert ("over TLS: TLS certificate does not match" in err if who == "other CA"
            else "one run with TLS as tls://host:port with --tls-*" in err), err


def test_the_embedded_cluster_runs_encrypted_with_the_files(certs):
    with DaskCluster(None, 1, TlsFiles(*certs)).client() as client:
        address = client.scheduler.address
        assert address.startswith("tls://127.0.0.1:")
        assert client.submit(pow, 2, 10, pure=False).result() == 1024
        # no certificate, no entry
        with pytest.raises(ClusterError, match="cannot reach"), \
                connect(address.replace("tls://", "tcp://")):
            pass


def test_analyse_refuses_a_tls_scheduler_without_certificates(tmp_path, capsys):
    code, out, err = _cli(["analyse", "pca", str(tmp_path / "s.zarr"), "--scheduler",
                           "tls://127.0.0.1:1"], capsys)
    assert code == 2 and out == ""
    assert err.startswith("farm: error: the scheduler 'tls://127.0.0.1:1' speaks TLS")
    assert err.count("\n") == 1


def test_analyse_runs_on_a_tls_scheduler(tls_scheduler, certs, tmp_path, capsys):
    from tests.synthetic import make_store

    store = tmp_path / "s.zarr"
    make_store(store, n_experiments=6, rows=4, cols=8, tread_rows=3, tread_cols=6)
    code, _, err = _cli(["analyse", "pca", str(store), "--scheduler", tls_scheduler,
                         *_tls_args(certs), "--out", str(tmp_path / "pca")], capsys)
    assert code == 0, err
    assert any((tmp_path / "pca").iterdir())
