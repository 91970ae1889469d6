"""The Dask cluster a sweep runs on: an embedded LocalCluster, or an existing scheduler.

The embedded default runs one single-threaded worker process per core: ccx is a
subprocess, and one ccx per core is the throughput optimum on small models
(DESIGN.md). Workers are processes with a nanny, so a crashed worker is restarted and
its task re-run elsewhere; ``allowed-failures`` is raised so that a task is not given up
after three lost workers (set ``DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES`` on an
external scheduler for the same effect).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator

import dask

from jobs.errors import ClusterError

ALLOWED_FAILURES = 10


def default_workers() -> int:
    """One worker per core available to this process."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


@contextlib.contextmanager
def connect(scheduler: str | None = None, workers: int | None = None,
            dashboard: str = "127.0.0.1:8787") -> Iterator[object]:
    """Yield a ``distributed.Client``: to ``scheduler`` if given, else to a new LocalCluster.

    Raises :class:`ClusterError` when the scheduler cannot be reached.
    """
    from distributed import Client, LocalCluster

    with dask.config.set({"distributed.scheduler.allowed-failures": ALLOWED_FAILURES}):
        if scheduler is None:
            n = workers or default_workers()
            with LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                              dashboard_address=dashboard, host="127.0.0.1",
                              silence_logs=40) as cluster, Client(cluster) as client:
                yield client
            return
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as e:
            raise ClusterError(
                f"cannot reach the Dask scheduler at {scheduler}: {e}; start one with "
                "`dask scheduler` (and workers with `dask worker ADDRESS`), or drop "
                "--scheduler to use the embedded cluster") from e
        with client:
            if workers:
                client.wait_for_workers(workers, timeout=300)
            yield client


def dashboard_link(client) -> str:
    """The dashboard URL, or a note when the scheduler runs none."""
    return client.dashboard_link or "(no dashboard)"
