"""``--cluster local|slurm``, ``--slurm-*`` and ``--tls-*`` (tyre_farm_cli/options.py): on every
command that runs on a cluster, defaults those of :class:`jobs.slurm.SlurmOptions`,
bad combinations one usage line (exit 2) before anything starts."""

from __future__ import annotations

import dataclasses
import sys

import pytest

import jobs.cluster
import jobs.slurm
from jobs.cluster import DaskCluster
from jobs.slurm import FALLBACK, SlurmOptions
from tests.jobs.conftest import study_text
from tyre_farm_cli import main
from tyre_farm_cli.options import CLUSTER_OPTIONS, ClusterKind, cluster_spec

COMMANDS = [["sweep", "submit"], ["sweep", "resume"], ["invert"], ["calibrate"],
            ["reproduce"]]
NO_SLURM = {name: option.default for name, (_, option) in CLUSTER_OPTIONS.items()
            if name.startswith("slurm_")}


def _cli(argv, capsys) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as info:
        main(argv)
        raise SystemExit(0)
    out = capsys.readouterr()
    return info.value.code, out.out, out.err


@pytest.fixture
def study(tmp_path, monkeypatch):
    """A valid study file; any cluster started fails the test."""
    def refuse(*args, **kwargs):
        pytest.fail("a cluster was started")

    monkeypatch.setattr(jobs.cluster, "connect", refuse)
    monkeypatch.setattr(jobs.slurm, "slurm_client", refuse)
    path = tmp_path / "study.toml"
    path.write_text(study_text(tmp_path / "store.zarr"))
    return path


@pytest.mark.parametrize("command", COMMANDS, ids=" ".join)
def test_every_cluster_command_has_the_cluster_options(command, capsys):
    code, out, _ = _cli([*command, "--help"], capsys)
    assert code == 0
    for option in ("--scheduler", "--workers", "--cluster", "--tls-ca-file", "--tls-cert",
                   "--tls-key", "--slurm-partition", "--slurm-jobs", "--slurm-cores",
                   "--slurm-memory", "--slurm-walltime"):
        assert option in out, (command, option)
    assert "jobqueue.slurm.walltime, else 01:00:00]" in " ".join(out.split())


def test_the_slurm_defaults_are_slurm_options_defaults():
    fields = {f.name: f.default for f in dataclasses.fields(SlurmOptions)}
    made = cluster_spec(ClusterKind.slurm, None, None, (None, None, None), dict(NO_SLURM))
    assert isinstance(made, SlurmOptions)
    for cli_name, field in [("slurm_partition", "queue"), ("slurm_account", "account"),
                            ("slurm_jobs", "jobs"), ("slurm_cores", "cores"),
                            ("slurm_memory", "memory"), ("slurm_walltime", "walltime"),
                            ("slurm_interface", "interface"), ("slurm_job_name", "job_name"),
                            ("slurm_dashboard", "dashboard_address")]:
        assert NO_SLURM[cli_name] == fields[field], cli_name
        # cores, memory, walltime: None is "the site's, else the farm's fallback"
        want = FALLBACK.get(field, fields[field]) if fields[field] is None else fields[field]
        assert getattr(made, field) == want, cli_name


def test_slurm_options_reach_the_spec():
    slurm = {**NO_SLURM, "slurm_partition": "debug", "slurm_jobs": 3, "slurm_cores": 2,
             "slurm_memory": "3GiB", "slurm_walltime": "00:20:00", "slurm_interface": "lo"}
    made = cluster_spec(ClusterKind.slurm, None, None, (None, None, None), slurm)
    assert (made.queue, made.jobs, made.cores, made.memory, made.walltime, made.interface) == (
        "debug", 3, 2, "3GiB", "00:20:00", "lo")
    assert made.embedded is False
    kwargs = made.cluster_kwargs()
    assert kwargs["processes"] == 2 and "--lifetime" in kwargs["worker_extra_args"]


def test_local_is_the_dask_cluster_of_scheduler_and_workers(monkeypatch):
    for name in jobs.cluster.SCHEDULER_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    made = cluster_spec(ClusterKind.local, "tcp://127.0.0.1:8786", 3, (None, None, None),
                        dict(NO_SLURM))
    assert made == DaskCluster("tcp://127.0.0.1:8786", 3) and not made.embedded
    assert cluster_spec(ClusterKind.local, None, None, (None, None, None),
                        dict(NO_SLURM)).embedded


@pytest.mark.parametrize("argv, needle", [
    (["--cluster", "slurm", "--scheduler", "tcp://127.0.0.1:8786"],
     "--cluster slurm starts its own scheduler, so --scheduler does not apply"),
    (["--cluster", "slurm", "--workers", "4"], "so --workers does not apply: drop it"),
    (["--slurm-jobs", "2", "--slurm-memory", "1GiB"],
     "--slurm-jobs, --slurm-memory apply to --cluster slurm only"),
    (["--cluster", "slurm", "--slurm-walltime", "1h"], "not a SLURM time"),
    (["--cluster", "slurm", "--slurm-walltime", "00:01:00"], "too short"),
    (["--cluster", "slurm", "--slurm-memory", "lots"], "is not an amount of memory"),
    (["--cluster", "slurm", "--slurm-jobs", "0"], "Invalid value for '--slurm-jobs'"),
    (["--cluster", "pbs"], "Invalid value for '--cluster'"),
])
def test_bad_cluster_combinations_are_one_usage_line(argv, needle, study, capsys):
    code, out, err = _cli(["sweep", "submit", str(study), *argv], capsys)
    assert code == 2 and out == "", err
    assert err.startswith("farm: error: ") and err.count("\n") == 1 and needle in err, err


def test_slurm_without_dask_jobqueue_says_what_to_install(study, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "dask_jobqueue", None)  # as if not installed
    code, out, err = _cli(["sweep", "submit", str(study), "--cluster", "slurm"], capsys)
    assert code != 0 and out == ""
    assert err == ("farm: error: --cluster slurm needs dask-jobqueue: "
                   "pip install 'tyre-farm[slurm]'\n")
