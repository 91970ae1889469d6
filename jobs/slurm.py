"""Dask workers as SLURM jobs (dask-jobqueue): :class:`SlurmOptions` and :func:`slurm_client`.

The scheduler runs in this (the submitting) process; each SLURM job runs ``processes``
single-threaded Dask workers, by default one per job core, as the embedded cluster does:
ccx is a subprocess, one ccx per core is the throughput optimum (docs/architecture.md,
"Jobs on Dask").

Walltime. SLURM kills a job at its walltime; a worker killed while running a task is a
lost worker, and ``allowed-failures`` such losses give the task up (``KilledWorker``).
So every worker retires itself *before* the walltime (:func:`lifetime_seconds`): Dask's
``--lifetime`` closes it gracefully - the scheduler moves its task elsewhere without
counting a failure (the farm's tasks are idempotent) - and the job ends. The cluster is
kept at ``jobs`` jobs by ``adapt(minimum_jobs=jobs, maximum_jobs=jobs)``, which submits
a new job for each one that ended (``scale`` alone would not). ``--lifetime-stagger``
spreads the retirements so that the workers of one wave do not all leave at once.
``--lifetime-restart`` is *not* set: it would restart the worker inside the same job,
minutes before SLURM kills that job - exactly the loss we retire to avoid.

Site conventions (issue 48). A cluster keeps its SLURM settings in dask's
``jobqueue.yaml`` (``jobqueue.slurm.*``). What the user does not give here comes from
there: partition, account, interface and directories as dask-jobqueue reads them, and
cores, memory and walltime by :func:`site_settings` (a value equal to dask-jobqueue's own
packaged default is not the site's: ``dask.config.ensure_file`` copies that file into
``~/.config/dask`` unchanged), else :data:`FALLBACK`. The site's job directives and
worker arguments are kept and ours added after them. Processes stay one per core, the
farm's rule, and ``python`` this interpreter (the package must be importable).
"""

from __future__ import annotations

import contextlib
import re
import sys
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import dask
from dask.utils import parse_bytes

from jobs.cluster import SCHEDULER_CONFIG, with_farm_page
from jobs.errors import ClusterError

INSTALL_HINT = "pip install 'tyre-farm[slurm]'"
RETIRE_MARGIN_SECONDS = 300  # workers retire about 5 min before the walltime ...
MIN_LIFETIME_SECONDS = 60  # ... but live at least 1 min
START_TIMEOUT_SECONDS = 300  # for the first worker to join (queue wait included)
FALLBACK: dict[str, Any] = {"cores": 1, "memory": "2GiB", "walltime": "01:00:00"}
"""Cores, memory and walltime per job where neither the options nor the site say."""

# SLURM's --time formats: M, M:S, H:M:S, D-H, D-H:M, D-H:M:S
_WALLTIME = re.compile(r"^(?:(?P<d>\d+)-(?P<dh>\d+)(?::(?P<dm>\d+)(?::(?P<ds>\d+))?)?"
                       r"|(?P<a>\d+)(?::(?P<b>\d+)(?::(?P<c>\d+))?)?)$")


def walltime_seconds(walltime: str) -> int:
    """Seconds in a SLURM time limit (``"01:30:00"``, ``"90"`` minutes, ``"1-12"``...)."""
    m = _WALLTIME.match(walltime.strip()) if isinstance(walltime, str) else None
    if m is None:
        raise ClusterError(f"SLURM walltime {walltime!r} is not a SLURM time: give "
                           "MM, MM:SS, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS, e.g. '01:00:00'")
    g = {k: int(v) for k, v in m.groupdict().items() if v is not None}
    if "d" in g:
        return ((g["d"] * 24 + g["dh"]) * 60 + g.get("dm", 0)) * 60 + g.get("ds", 0)
    if "c" in g:  # H:M:S
        return (g["a"] * 60 + g["b"]) * 60 + g["c"]
    return g["a"] * 60 + g.get("b", 0)  # M or M:S


def lifetime_seconds(walltime: int) -> tuple[int, int]:
    """``(lifetime, stagger)`` of a worker in a job of ``walltime`` seconds.

    The margin before the walltime is :data:`RETIRE_MARGIN_SECONDS`, at most half the
    walltime; the lifetime at least :data:`MIN_LIFETIME_SECONDS`. Dask draws each
    worker's lifetime in ``lifetime +/- stagger``; stagger is half the margin, so every
    worker retires at least half the margin before SLURM's kill.
    """
    if walltime < 2 * MIN_LIFETIME_SECONDS:  # then the margin (<= half) leaves >= 1 min
        raise ClusterError(f"SLURM walltime of {walltime} s is too short: workers must live "
                           f"{MIN_LIFETIME_SECONDS} s and retire before it; give at least "
                           f"{2 * MIN_LIFETIME_SECONDS} s, e.g. '00:30:00'")
    margin = min(RETIRE_MARGIN_SECONDS, walltime // 2)
    return walltime - margin, margin // 2


@dataclass(frozen=True)
class SlurmOptions:
    """What SLURM jobs the workers run in (one line each in ``sbatch``'s script).

    ``queue`` is the partition (``-p``), ``account`` the ``-A``; ``jobs`` SLURM jobs of
    ``cores`` cores and ``memory`` each run ``processes`` workers (default: one
    single-threaded worker per core). ``interface`` is the network interface workers and
    scheduler talk over (``"lo"`` on one machine, e.g. ``"ib0"`` on a cluster).
    ``local_directory`` is the workers' scratch on the node, ``log_directory`` where SLURM
    writes the jobs' output (default: its own, ``slurm-<id>.out`` in the submitting folder).
    ``python`` must exist on the compute nodes: this venv's by default, which a shared
    file system makes visible there.
    """

    queue: str | None = None
    account: str | None = None
    jobs: int = 1
    cores: int | None = None  # None: the site's jobqueue.yaml, else FALLBACK
    processes: int | None = None
    memory: str | None = None
    walltime: str | None = None
    interface: str | None = None
    job_extra_directives: tuple[str, ...] = ()
    local_directory: str | None = None
    log_directory: str | None = None
    python: str = sys.executable
    job_name: str = "tyre-farm"
    dashboard_address: str = ":8787"
    start_timeout: float = START_TIMEOUT_SECONDS

    def __post_init__(self) -> None:
        site = site_settings()
        taken = [name for name in FALLBACK if getattr(self, name) is None and name in site]
        for name, fallback in FALLBACK.items():  # resolved once: the value every check sees
            if getattr(self, name) is None:
                object.__setattr__(self, name, site.get(name, fallback))
        try:
            self._check()
        except ClusterError as e:
            if not taken:
                raise
            raise ClusterError(f"{e} ({', '.join(taken)} from the site's dask config, "
                               f"jobqueue.slurm.*: fix it there or give the option)") from e

    def _check(self) -> None:
        for name in ("jobs", "cores"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ClusterError(f"SLURM {name} must be a whole number >= 1, got {value!r}")
        p, cores = self.processes, int(self.cores or 0)
        if p is not None and (isinstance(p, bool) or not isinstance(p, int) or p < 1
                              or cores % p):
            raise ClusterError(f"SLURM processes must divide cores ({self.cores}), got {p!r}: "
                               "leave it unset for one single-threaded worker per core")
        try:
            if parse_bytes(self.memory) <= 0:  # type: ignore[arg-type]  # TypeError below
                raise ValueError("not positive")
        except (ValueError, TypeError) as e:
            raise ClusterError(f"SLURM memory {self.memory!r} is not an amount of memory: "
                               "give e.g. '4GiB' or '4000MB'") from e
        lifetime_seconds(walltime_seconds(self.walltime))  # type: ignore[arg-type]  # raises
        if not isinstance(self.job_extra_directives, tuple) or not all(
                isinstance(d, str) for d in self.job_extra_directives):
            raise ClusterError("SLURM job_extra_directives must be a tuple of strings, got "
                               f"{self.job_extra_directives!r}, e.g. ('--qos=normal',)")
        if not (isinstance(self.start_timeout, int | float) and self.start_timeout > 0):
            raise ClusterError(f"SLURM start_timeout must be seconds > 0, got "
                               f"{self.start_timeout!r}")

    #: a :class:`jobs.cluster.ClusterSpec`: the workers run on the compute nodes, whose
    #: ccx may differ from this machine's (the driver asks them)
    embedded = False

    def client(self) -> contextlib.AbstractContextManager[Any]:
        """:func:`slurm_client` of these options (:class:`jobs.cluster.ClusterSpec`)."""
        return slurm_client(self)

    @property
    def worker_processes(self) -> int:
        assert self.cores is not None  # resolved in __post_init__
        return self.processes or self.cores

    def worker_extra_args(self) -> list[str]:
        """The site's worker arguments, then the lifetime flags (module docstring)."""
        assert self.walltime is not None  # resolved in __post_init__
        lifetime, stagger = lifetime_seconds(walltime_seconds(self.walltime))
        return [*_site_list("worker-extra-args"),
                "--lifetime", f"{lifetime}s", "--lifetime-stagger", f"{stagger}s"]

    def cluster_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of ``dask_jobqueue.SLURMCluster``."""
        return dict(
            queue=self.queue, account=self.account, cores=self.cores,
            processes=self.worker_processes, memory=self.memory, walltime=self.walltime,
            interface=self.interface,
            job_extra_directives=[*_site_list("job-extra-directives"),
                                  *self.job_extra_directives],
            local_directory=self.local_directory, log_directory=self.log_directory,
            python=self.python, job_name=self.job_name,
            worker_extra_args=self.worker_extra_args(),
            scheduler_options={"dashboard_address": self.dashboard_address})


def _packaged_defaults() -> dict[str, Any]:
    """dask-jobqueue's own ``jobqueue.slurm`` defaults ({} without dask-jobqueue)."""
    import importlib.util
    from pathlib import Path

    import yaml

    spec = importlib.util.find_spec("dask_jobqueue")
    if spec is None or spec.origin is None:
        return {}
    path = Path(spec.origin).with_name("jobqueue.yaml")
    try:
        return dict(yaml.safe_load(path.read_text())["jobqueue"]["slurm"])
    except (OSError, KeyError, TypeError, yaml.YAMLError):
        return {}


def site_settings() -> dict[str, Any]:
    """Cores, memory and walltime the site's dask config (``jobqueue.slurm.*``) sets,
    where they differ from dask-jobqueue's packaged defaults."""
    packaged = _packaged_defaults()
    found = {}
    for name in FALLBACK:
        value = dask.config.get(f"jobqueue.slurm.{name}", None)
        if value is not None and value != packaged.get(name):
            found[name] = value
    return found


def _site_list(key: str) -> list[str]:
    """A list setting of the site's ``jobqueue.slurm`` (job directives, worker args)."""
    value = dask.config.get(f"jobqueue.slurm.{key}", None) or []
    return [str(v) for v in value] if isinstance(value, list | tuple) else []


def _slurm_cluster_class():
    try:
        from dask_jobqueue import SLURMCluster
    except ImportError as e:
        raise ClusterError(f"SLURM clusters need dask-jobqueue: {INSTALL_HINT}") from e
    return SLURMCluster


@contextlib.contextmanager
def slurm_client(options: SlurmOptions) -> Iterator[Any]:
    """Yield a ``distributed.Client`` of workers in ``options.jobs`` SLURM jobs.

    Waits for the first worker (:attr:`SlurmOptions.start_timeout`) and raises
    :class:`ClusterError` if none started. On exit, also on error, closes the client and
    the cluster, which cancels the jobs (``scancel``).
    """
    from distributed import Client

    cls = _slurm_cluster_class()
    # the scheduler runs here: these settings apply to it as to the embedded cluster's
    with dask.config.set(with_farm_page(SCHEDULER_CONFIG)), \
            warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"Port \d+ is already in use",
                                category=UserWarning)
        try:
            cluster = cls(**options.cluster_kwargs())
        except (OSError, ValueError, RuntimeError) as e:
            raise ClusterError(f"cannot start the SLURM cluster's scheduler: {e}; check "
                               f"the interface ({options.interface!r}) and the "
                               "options") from e
        with cluster, Client(cluster) as client:
            cluster.adapt(minimum_jobs=options.jobs, maximum_jobs=options.jobs)
            try:
                client.wait_for_workers(1, timeout=options.start_timeout)
            except TimeoutError as e:
                raise ClusterError(
                    f"no SLURM job started within {options.start_timeout:g} s: check "
                    f"`squeue` (are the {options.job_name!r} jobs pending?) and `sinfo`, "
                    "or raise start_timeout") from e
            yield client
