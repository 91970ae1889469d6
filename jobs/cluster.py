"""The Dask cluster a run uses: an embedded LocalCluster, or a scheduler already running.

Which one: ``--scheduler``, else ``$FARM_SCHEDULER``, else ``$DASK_SCHEDULER_ADDRESS``,
else an embedded LocalCluster (:func:`resolve_scheduler`); with TLS certificates
(:mod:`jobs.tls`) both are reached over ``tls://``. Other clusters (SLURM:
:mod:`jobs.slurm`) plug in as a :class:`ClusterSpec`, the one thing
:func:`jobs.driver.drive` connects through. The embedded cluster runs one
single-threaded worker process per core: ccx is a subprocess, and one ccx per core is the
throughput optimum on small models (docs/architecture.md). Its dashboard is asked for on port 8787;
when that port is taken the scheduler serves it on a free one, silently, and
:func:`dashboard_link` gives the real address.

Lost workers. A scheduler gives a task up with ``KilledWorker`` once more than its
``distributed.scheduler.allowed-failures`` workers died running it (Dask's default is 3;
the embedded cluster raises it to :data:`ALLOWED_FAILURES`). A client cannot change that
setting on a scheduler already running, so the farm does not depend on it: every task
the farm submits goes through :class:`Attempts`, which resubmits a task given up that way
under a new key (``<key>-retry<n>``), up to :data:`LOST_WORKER_RESUBMITS` times, and logs
each resubmission. That is safe because the farm's tasks are idempotent: a sweep task
skips experiments already done, an evaluation is a pure function of its key. With a
plain ``dask scheduler`` a task is thus given up only after
``(3 + 1) x (1 + LOST_WORKER_RESUBMITS)`` = 44 lost workers, on the embedded cluster
after 121 (a task that kills its worker every time, e.g. through the kernel's OOM killer).
"""

from __future__ import annotations

import contextlib
import logging
import os
import threading
import warnings
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Any, Protocol

import dask

from jobs.errors import ClusterError, StudyError
from jobs.handshake import check_scheduler
from jobs.tls import TlsFiles, check_address
from jobs.wording import plural

ALLOWED_FAILURES = 10  # the embedded scheduler's allowed-failures (Dask's default: 3)
#: Expected durations of the farm's long tasks by key prefix (jobs.expand's keys). Dask
#: runs a task where its inputs are and moves it only by work stealing, which weighs the
#: transfer of the inputs against the task's expected time, 0.5 s while unknown: the
#: slides of a load-path tree (their trunk's saved states as input, megabytes) then
#: queued on the trunk's worker one after another while the other worker idled
#: (benchmarks/bench_throughput.py). Measured on the patch mesh: trunk 2 min, slide 1 min.
TASK_DURATIONS = {"trunk": "2m", "slide": "1m", "path": "1m"}
#: What every scheduler the farm starts gets (embedded here, SLURM's in jobs.slurm), with
#: the farm's page (:func:`with_farm_page`).
SCHEDULER_CONFIG = {
    "distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
    **{f"distributed.scheduler.default-task-durations.{k}": v
       for k, v in TASK_DURATIONS.items()},
}
EMBEDDED_CONFIG = {
    **SCHEDULER_CONFIG,
    # A LocalCluster closes a worker's nanny when, 15 s after *any* earlier loss of that
    # worker, no worker of that name is registered: a worker lost again just then (it is
    # restarting) is gone for good, and the cluster a worker short (seen in
    # tests/jobs/test_jobs_worker_loss.py). Our nannies restart their workers: keep them.
    "distributed.deploy.lost-worker-timeout": "1 day",
}
DASHBOARD_MODULE = "jobs.dashboard"


def with_farm_page(config: dict[str, Any]) -> dict[str, Any]:
    """``config`` with the farm's page on the dashboard (:mod:`jobs.dashboard`): its
    module added to Dask's own HTTP routes, read when a scheduler starts (issue 48).
    Dask's defaults exist once distributed is imported, so this imports it."""
    import distributed  # noqa: F401  (registers distributed's config defaults)

    routes = list(dask.config.get("distributed.scheduler.http.routes", []))
    if DASHBOARD_MODULE not in routes:
        routes.append(DASHBOARD_MODULE)
    return {**config, "distributed.scheduler.http.routes": routes}


LOST_WORKER_RESUBMITS = 10  # resubmissions of a task whose workers kept dying
SCHEDULER_VARIABLES = ("FARM_SCHEDULER", "DASK_SCHEDULER_ADDRESS")  # in this order
CONNECT_TIMEOUT = "20s"  # to reach a running scheduler (and finish a TLS handshake)
WAIT_FOR_WORKERS_SECONDS = 300  # for the --workers an external scheduler is asked to have

log = logging.getLogger(__name__)


def default_workers() -> int:
    """One worker per core available to this process."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def resolve_scheduler(scheduler: str | None) -> str | None:
    """The scheduler address to join: ``scheduler``, else the first of
    :data:`SCHEDULER_VARIABLES` set (blank counts as unset); ``None`` means embedded."""
    if scheduler:
        return scheduler
    for name in SCHEDULER_VARIABLES:
        value = os.environ.get(name, "").strip()
        if value:
            return value
    return None


class ClusterSpec(Protocol):
    """Where a run's workers come from (what :func:`jobs.driver.drive` connects through).

    ``embedded``: the workers run this machine's ccx (no need to ask them its version);
    ``client()``: a context manager yielding a ``distributed.Client``, closing whatever
    it started on exit.
    """

    @property
    def embedded(self) -> bool: ...

    def client(self) -> AbstractContextManager[Any]: ...


@dataclass(frozen=True)
class DaskCluster:
    """An embedded LocalCluster or a running scheduler (:func:`connect`), TLS if ``tls``.

    Checked when made: a malformed address, or TLS settings that do not fit the address
    (``tls://`` without certificates, certificates with ``tcp://``), raise
    :class:`ClusterError` before anything starts.
    """

    scheduler: str | None = None
    workers: int | None = None
    tls: TlsFiles | None = None

    def __post_init__(self) -> None:
        address = resolve_scheduler(self.scheduler)
        if address is not None:
            _check_address(address)
        check_address(address, self.tls)

    @property
    def embedded(self) -> bool:
        return resolve_scheduler(self.scheduler) is None

    def client(self) -> AbstractContextManager[Any]:
        return connect(self.scheduler, self.workers, tls=self.tls)


@contextlib.contextmanager
def connect(scheduler: str | None = None, workers: int | None = None,
            dashboard: str = "127.0.0.1:8787", tls: TlsFiles | None = None) -> Iterator[Any]:
    """Yield a ``distributed.Client``: to the scheduler :func:`resolve_scheduler` names,
    else to a new embedded LocalCluster of ``workers`` processes; over TLS with ``tls``
    (the embedded cluster then encrypted too, :mod:`jobs.tls`).

    Raises :class:`ClusterError` when the scheduler cannot be reached.
    """
    from distributed import Client

    address = resolve_scheduler(scheduler)
    if address is None:
        security = tls.cluster_security() if tls is not None else None
        # the settings are read while the cluster runs, not only when it starts
        from jobs.worker_log import WorkerLog, log_path, name_the_log

        path = log_path()
        with dask.config.set(with_farm_page(EMBEDDED_CONFIG)), \
                _embedded(workers or default_workers(), dashboard, security) as cluster, \
                Client(cluster) as client:
            client.register_plugin(WorkerLog(path))
            try:
                yield client
            except Exception as e:
                name_the_log(e, path)
                raise
        return
    _check_address(address)
    check_address(address, tls)
    kwargs = {"security": tls.client_security()} if tls is not None else {}
    try:
        # Client's timeout does not cover Dask's handshake: ask who is there first (issue 26)
        check_scheduler(address, dask.utils.parse_timedelta(CONNECT_TIMEOUT),
                        kwargs["security"].get_connection_args("client") if kwargs else None)
        client = Client(address, timeout=CONNECT_TIMEOUT, **kwargs)
    except (OSError, TimeoutError, ValueError) as e:
        raise ClusterError(_unreachable(address, e)) from e
    with client:
        if workers:
            try:
                client.wait_for_workers(workers, timeout=WAIT_FOR_WORKERS_SECONDS)
            except TimeoutError as e:
                have = len(client.scheduler_info().get("workers", {}))
                raise ClusterError(
                    f"the scheduler at {address} has {have} of the "
                    f"{plural(workers, 'worker')} asked for after {WAIT_FOR_WORKERS_SECONDS} "
                    "s: start more with `dask worker ADDRESS`, or ask for fewer with "
                    "--workers") from e
        yield client


def _unreachable(address: str, error: BaseException) -> str:
    """The one line of a scheduler that did not answer (or refused our handshake)."""
    if address.startswith("tls://"):
        return (f"cannot reach the Dask scheduler at {address!r} over TLS: {error}; check that "
                "it runs with TLS and that --tls-ca-file is the CA that signed its "
                "certificate and --tls-cert/--tls-key a certificate it trusts")
    return (f"cannot reach the Dask scheduler at {address!r}: {error}; give a running one as "
            "tcp://host:8786 (--scheduler, $FARM_SCHEDULER or $DASK_SCHEDULER_ADDRESS; "
            "start one with `dask scheduler` and workers with `dask worker ADDRESS`; one run "
            "with TLS as tls://host:port with --tls-*), or set none of them to use the "
            "embedded cluster")


def _embedded(workers: int, dashboard: str, security: Any = None):
    """A LocalCluster (over TLS with ``security``); a busy dashboard port moves to a free
    one without a raw warning."""
    from distributed import LocalCluster

    with warnings.catch_warnings():
        # distributed warns "Port 8787 is already in use ... Hosting the HTTP server on port
        # N instead" - and does so; the link we print is the real one (issue 12)
        warnings.filterwarnings("ignore", message=r"Port \d+ is already in use",
                                category=UserWarning)
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                            dashboard_address=dashboard, host="127.0.0.1",
                            silence_logs=logging.CRITICAL,  # to a file: jobs.worker_log
                            security=security)


def _check_address(address: str) -> None:
    """Refuse a malformed address before distributed sees it: for an unknown protocol it
    can fail deep in its event-loop start-up with a bare AssertionError."""
    from jobs.validate.addresses import scheduler_address

    try:
        scheduler_address(address, "scheduler")
    except StudyError as e:
        raise ClusterError(f"{e} (from --scheduler, $FARM_SCHEDULER or "
                           "$DASK_SCHEDULER_ADDRESS)") from e


def dashboard_link(client) -> str:
    """The dashboard URL, or a note when the scheduler runs none."""
    return client.dashboard_link or "(no dashboard)"


# ---------------------------------------------------------------- tasks that outlive workers

def lost_worker(error: BaseException | None) -> bool:
    """True if ``error`` says the scheduler gave a task up because its workers died."""
    from distributed import KilledWorker

    return isinstance(error, KilledWorker)


def attempt_key(key: str, attempt: int) -> str:
    """The task key of ``attempt`` (0: the key itself): a given-up key cannot be reused."""
    return key if attempt == 0 else f"{key}-retry{attempt}"


class Attempts:
    """One task and its attempts: resubmitted under a new key when its workers are lost.

    Behaves like the current attempt's future (``status``, ``result``, ``exception``,
    ``cancel``, ``release``). ``result`` resubmits by itself; a polling caller calls
    :meth:`resubmit` when ``status`` is ``"error"``. Thread-safe: several threads may
    wait on one task (loops sharing an evaluation).
    """

    def __init__(self, client, function: Callable, args: tuple, key: str,
                 limit: int = LOST_WORKER_RESUBMITS, **kwargs) -> None:
        self._client, self._function, self._args, self._kwargs = client, function, args, kwargs
        self.base_key, self.limit, self.attempt = key, limit, 0
        self._lock = threading.Lock()
        self._cancelled = False
        self.future = self._submit()

    @property
    def key(self) -> str:
        return attempt_key(self.base_key, self.attempt)

    @property
    def status(self) -> str:
        return self.future.status

    def _submit(self):
        return self._client.submit(self._function, *self._args, key=self.key, pure=False,
                                   **self._kwargs)

    def resubmit(self, failed=None, error: BaseException | None = None) -> bool:
        """Submit the next attempt if ``failed`` (default: the current one) lost its workers.

        True if the task goes on (resubmitted now, or by another thread already); False
        if it failed for another reason, ran out of attempts or was cancelled.
        """
        with self._lock:
            failed = self.future if failed is None else failed
            if self._cancelled:
                return False
            if self.future is not failed:
                return True
            if failed.status != "error" or self.attempt >= self.limit:
                return False
            if not lost_worker(error if error is not None else failed.exception()):
                return False
            self.attempt += 1
            log.warning("the workers running task %s were lost; resubmitted as %s "
                        "(resubmission %d of %d)", attempt_key(self.base_key, self.attempt - 1),
                        self.key, self.attempt, self.limit)
            self.future = self._submit()
        failed.release()
        return True

    def result(self, timeout: float | None = None):
        """The task's result, through as many attempts as it takes (up to the limit)."""
        while True:
            future = self.future
            try:
                return future.result(timeout)
            except Exception as e:
                if not (lost_worker(e) and self.resubmit(future, e)):
                    raise

    def exception(self):
        return self.future.exception()

    def stop(self) -> Any:
        """Let no later attempt follow; return the current future (for a batch cancel)."""
        with self._lock:
            self._cancelled = True
            return self.future

    def cancel(self) -> None:
        self.stop().cancel()

    def release(self) -> None:
        self.future.release()


class ResubmittingClient:
    """A ``distributed.Client`` whose tasks survive lost workers.

    ``submit`` returns :class:`Attempts`; ``cancel`` takes them (or plain futures);
    everything else is the wrapped client's.
    """

    def __init__(self, client, limit: int = LOST_WORKER_RESUBMITS) -> None:
        self.client, self.limit = client, limit

    def submit(self, function: Callable, *args, key: str, **kwargs) -> Attempts:
        kwargs.pop("pure", None)  # always impure: a retry must run, never reuse a result
        return Attempts(self.client, function, args, key, self.limit, **kwargs)

    def cancel(self, futures, **kwargs) -> None:
        plain = [f.stop() if isinstance(f, Attempts) else f for f in futures]
        if plain:
            self.client.cancel(plain, **kwargs)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.client, name)
