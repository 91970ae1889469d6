"""SLURM clusters: option checks and the walltime/lifetime rule (no SLURM needed), and the
quick sweep on a real SLURM (``-m slurm``; ``bash scripts/test-slurm.sh`` starts one)."""

from __future__ import annotations

import functools
import shutil
import subprocess
import sys
import time
import uuid

import dask
import pytest

import storage
from jobs.errors import ClusterError
from jobs.slurm import SlurmOptions, lifetime_seconds, slurm_client, walltime_seconds
from tests.jobs.conftest import study_text


@pytest.mark.parametrize("text, seconds", [
    ("90", 90 * 60), ("05:30", 330), ("01:00:00", 3600), ("2-0", 2 * 86400),
    ("1-02:03", 86400 + 2 * 3600 + 180), ("1-00:00:10", 86410), (" 30 ", 1800),
])
def test_walltime_reads_every_slurm_time_format(text, seconds):
    assert walltime_seconds(text) == seconds


@pytest.mark.parametrize("text", ["1h", "", "1:2:3:4", "-5", "01-", None, 60])
def test_walltime_that_is_no_slurm_time_is_refused(text):
    with pytest.raises(ClusterError, match="not a SLURM time"):
        walltime_seconds(text)


def test_an_hour_retires_workers_five_minutes_early():
    assert lifetime_seconds(3600) == (3300, 150)


@pytest.mark.parametrize("walltime", [120, 121, 300, 599, 600, 601, 3600, 86400, 7 * 86400])
def test_every_worker_retires_before_the_walltime_and_lives_a_minute(walltime):
    lifetime, stagger = lifetime_seconds(walltime)
    assert lifetime >= 60
    assert 0 <= stagger < lifetime
    # Dask draws each lifetime in lifetime +/- stagger: even the latest is well before
    # SLURM's kill, by a quarter of the walltime at least or 2.5 min.
    assert walltime - (lifetime + stagger) >= min(150, walltime // 4)


@pytest.mark.parametrize("walltime", [0, 60, 119])
def test_a_walltime_too_short_to_retire_in_is_refused(walltime):
    with pytest.raises(ClusterError, match="too short"):
        lifetime_seconds(walltime)


def test_defaults_are_one_single_threaded_worker_per_job_core_with_lifetime():
    options = SlurmOptions(cores=4, walltime="02:00:00")
    kwargs = options.cluster_kwargs()
    assert kwargs["cores"] == kwargs["processes"] == 4  # nthreads = cores // processes = 1
    assert kwargs["python"] == sys.executable
    args = kwargs["worker_extra_args"]
    assert args[args.index("--lifetime") + 1] == f"{7200 - 300}s"
    assert args[args.index("--lifetime-stagger") + 1] == "150s"
    assert "--lifetime-restart" not in args  # it would restart inside the dying job


@pytest.mark.parametrize("kwargs, match", [
    ({"jobs": 0}, "jobs must be"), ({"jobs": 1.5}, "jobs must be"), ({"jobs": True}, "jobs"),
    ({"cores": -1}, "cores must be"), ({"cores": 4, "processes": 3}, "processes must divide"),
    ({"processes": 0}, "processes must divide"), ({"memory": "lots"}, "memory"),
    ({"memory": "0GB"}, "memory"), ({"walltime": "1h"}, "not a SLURM time"),
    ({"walltime": "1"}, "too short"), ({"job_extra_directives": ["--qos=x"]}, "tuple"),
    ({"start_timeout": 0}, "start_timeout"),
])
def test_invalid_options_are_refused_in_one_line(kwargs, match):
    with pytest.raises(ClusterError, match=match) as info:
        SlurmOptions(**kwargs)
    assert "\n" not in str(info.value)


def test_the_job_script_asks_slurm_for_what_the_options_say():
    jobqueue = pytest.importorskip("dask_jobqueue")
    options = SlurmOptions(queue="debug", account="tyres", cores=2, memory="4GiB",
                           walltime="00:30:00", job_extra_directives=("--qos=short",))
    kwargs = options.cluster_kwargs()
    del kwargs["scheduler_options"]  # the cluster's, not the job's
    script = jobqueue.slurm.SLURMJob(scheduler="tcp://127.0.0.1:8786", name="w",
                                     **kwargs).job_script()
    for line in ("#SBATCH -p debug", "#SBATCH -A tyres", "#SBATCH -t 00:30:00",
                 "#SBATCH --qos=short", "--nthreads 1", "--nworkers 2",
                 "--lifetime 1500s", "--lifetime-stagger 150s"):
        assert line in script, line


def test_without_dask_jobqueue_the_error_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "dask_jobqueue", None)  # import raises ImportError
    with pytest.raises(ClusterError, match=r"pip install 'tyre-farm\[slurm\]'"), \
            slurm_client(SlurmOptions()):
        pass


def test_slurm_options_are_a_cluster_spec_the_driver_takes_alone():
    from jobs.driver import cluster_spec

    options = SlurmOptions()
    assert options.embedded is False  # the driver asks the nodes for their ccx
    assert cluster_spec(options, None, None) is options
    with pytest.raises(TypeError, match="not both"):
        cluster_spec(options, "tcp://127.0.0.1:8786", None)


# ------------------------------------------------------------------ a real SLURM (-m slurm)

@functools.cache  # a `sinfo` without its controller takes ~9 s to give up: ask once
def _slurm_answers() -> bool:
    if shutil.which("sinfo") is None or shutil.which("squeue") is None:
        return False
    try:
        return subprocess.run(["sinfo", "-h"], capture_output=True, timeout=15).returncode == 0
    except subprocess.TimeoutExpired:
        return False


def _require_slurm() -> None:
    if not _slurm_answers():
        pytest.skip("no SLURM answers `sinfo`: `bash scripts/test-slurm.sh` starts one")


def _wait_gone(name: str, seconds: float = 60) -> list[str]:
    """The jobs named ``name`` still queued after up to ``seconds`` (cancelled jobs pass
    through COMPLETING)."""
    deadline = time.monotonic() + seconds
    while (left := _squeue(name)) and time.monotonic() < deadline:
        time.sleep(1)
    return left


def _squeue(name: str) -> list[str]:
    """``<id> <state>`` of the jobs named ``name``."""
    out = subprocess.run(["squeue", "-h", "-n", name, "-o", "%i %T"], capture_output=True,
                         text=True, timeout=30, check=True).stdout
    return out.split("\n")[:-1] if out else []


@pytest.mark.slurm
def test_quick_sweep_runs_on_a_real_slurm(tmp_path, ccx):
    _require_slurm()
    from jobs.study import load_study
    from jobs.sweep import run_sweep

    name = f"tyre-farm-test-{uuid.uuid4().hex[:8]}"
    options = SlurmOptions(queue="debug", jobs=2, memory="1GiB", walltime="00:15:00",
                           interface="lo", job_name=name, dashboard_address="127.0.0.1:0",
                           local_directory=str(tmp_path / "dask"),
                           log_directory=str(tmp_path / "logs"), start_timeout=120)
    seen: list[str] = []
    path = tmp_path / "study.toml"
    path.write_text(study_text(tmp_path / "store.zarr", deflections="[10, 20, 30]"))
    study = load_study(path)

    # the seam: SlurmOptions is a jobs.cluster.ClusterSpec, which drive() connects through
    report = run_sweep(study, cluster=options, on_client=lambda c: seen.extend(_squeue(name)))

    assert report.ok and len(report.done) == 3, report.summary()
    assert report.workers >= 1
    assert list((tmp_path / "logs").glob("*.err")), "no SLURM job wrote its log"
    assert storage.status_counts(study.store, study.group_name) == {
        "pending": 0, "done": 3, "failed": 0}
    assert any(line.endswith(" RUNNING") for line in seen), seen
    assert _wait_gone(name) == [], "SLURM jobs outlived the client"


@pytest.mark.slurm
def test_jobs_that_never_start_are_a_clear_error_and_are_cancelled(tmp_path):
    _require_slurm()
    name = f"tyre-farm-test-{uuid.uuid4().hex[:8]}"
    options = SlurmOptions(queue="debug", interface="lo", job_name=name, start_timeout=5,
                           job_extra_directives=("--begin=now+1hour",),  # held in the queue
                           dashboard_address="127.0.0.1:0", log_directory=str(tmp_path))
    with pytest.raises(ClusterError, match=r"no SLURM job started within 5 s: check `squeue`"), \
            slurm_client(options):
        pytest.fail("a client without workers was handed out")
    assert _wait_gone(name) == [], "the pending jobs were not cancelled"


# Site conventions (issue 48): a cluster's jobqueue.yaml is where its users keep cores,
# memory, walltime, partition and directives; the farm's options fill in, never override.
SITE = {"jobqueue": {"slurm": {"cores": 8, "memory": "16GiB", "walltime": "04:00:00",
                               "job-extra-directives": ["--qos=site"],
                               "worker-extra-args": ["--nanny-port", "0"]}}}


def test_the_sites_jobqueue_settings_fill_what_the_options_leave():
    with dask.config.set(SITE):
        kwargs = SlurmOptions().cluster_kwargs()
    assert (kwargs["cores"], kwargs["memory"], kwargs["walltime"]) == (8, "16GiB", "04:00:00")
    assert kwargs["processes"] == 8  # still one single-threaded worker per core
    assert kwargs["job_extra_directives"] == ["--qos=site"]
    args = kwargs["worker_extra_args"]
    assert args[:2] == ["--nanny-port", "0"] and "--lifetime" in args
    lifetime = int(args[args.index("--lifetime") + 1].rstrip("s"))
    assert lifetime == 4 * 3600 - 300  # retires before the site's walltime, not ours


def test_options_given_win_over_the_site_and_add_to_its_directives():
    with dask.config.set(SITE):
        kwargs = SlurmOptions(cores=2, memory="4GiB", walltime="00:30:00",
                              job_extra_directives=("--exclusive",)).cluster_kwargs()
    assert (kwargs["cores"], kwargs["memory"], kwargs["walltime"]) == (2, "4GiB", "00:30:00")
    assert kwargs["job_extra_directives"] == ["--qos=site", "--exclusive"]


def test_dask_jobqueues_own_defaults_are_not_a_sites_choice():
    """``dask.config.ensure_file`` copies dask-jobqueue's yaml into ~/.config/dask: its
    30 min walltime and null cores are the package's, and the farm's fallback stays."""
    pytest.importorskip("dask_jobqueue")
    packaged = {"jobqueue": {"slurm": {"cores": None, "memory": None,
                                       "walltime": "00:30:00"}}}
    with dask.config.set(packaged):
        options = SlurmOptions()
    assert (options.cores, options.memory, options.walltime) == (1, "2GiB", "01:00:00")


def test_a_bad_site_value_is_named_as_the_sites():
    with dask.config.set({"jobqueue": {"slurm": {"walltime": "1h"}}}), \
            pytest.raises(ClusterError, match=r"not a SLURM time.*walltime from the site's dask "
                          r"config"):
        SlurmOptions()
