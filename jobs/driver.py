"""One driver for every study kind: connect, solver version, progress, polling,
cancellation and the run's summary.

A study kind is a :class:`Strategy`: what it submits when the cluster is there
(:meth:`~Strategy.start`), how it collects what finished (:meth:`~Strategy.poll`), what
a progress display sees (:meth:`~Strategy.state`), how it stops (:meth:`~Strategy.cancel`)
and the report it ends with (:meth:`~Strategy.finish`). :func:`drive` does the rest, the
same way for all of them:

1. connect through a :class:`jobs.cluster.ClusterSpec` - by default a
   :class:`jobs.cluster.DaskCluster`: an embedded LocalCluster, or the scheduler of
   ``--scheduler``, ``$FARM_SCHEDULER`` or ``$DASK_SCHEDULER_ADDRESS``, over TLS with
   certificates; or SLURM jobs (:class:`jobs.slurm.SlurmOptions`) - and learn the
   workers' solver version, which is part of every key (:mod:`jobs.identity`);
2. start the strategy, then poll it until everything ended, telling the front end
   (without one, :class:`Announce` prints where the dashboard is: every run that starts
   or joins a cluster says where to watch it);
3. on any interruption (Ctrl-C, an error of the client) cancel what is in flight - the
   workers' cancellation checks kill their ccx - and re-raise;
4. fill the summary every report shares (dashboard, workers, solver, wall time).

Sweeps (:mod:`jobs.sweep`) submit one task per load path; optimisation loops
(:class:`LoopThreads`: :mod:`jobs.inverse.run`, :mod:`jobs.calibrate.run`) run in client
threads whose evaluations go to the workers through one shared evaluator. Both submit
through :class:`jobs.cluster.Attempts`, so a task whose workers die is resubmitted
whatever the scheduler's ``allowed-failures``.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Generic, TypeVar

from farm.ccx.runner import ccx_version
from jobs.cluster import ClusterSpec, DaskCluster, ResubmittingClient, dashboard_link
from jobs.errors import ClusterError
from jobs.events import CcxFeed, StudyEvents
from jobs.loops.cache import EvaluationCache
from jobs.loops.evaluator import Evaluator
from jobs.progress import Progress, RunReport, Session


class Announce(Progress):
    """The front end of runs that have none (``farm reproduce``'s stages, scripts): one
    line on stderr saying where the dashboard is."""

    def started(self, session: Session, state: Any) -> None:
        print(f"{session.where}   workers: {session.workers}",
              file=sys.stderr, flush=True)


R = TypeVar("R", bound=RunReport)


class Strategy(Generic[R]):
    """One study kind on the driver (see the module docstring), ending with a report
    of type ``R``."""

    poll_seconds = 0.5

    def start(self, session: Session) -> None:
        """Submit the work (may block, e.g. to solve a reference first)."""

    def poll(self) -> bool:
        """Collect what finished; True once nothing is left."""
        raise NotImplementedError

    def state(self) -> Any:
        """What a progress display shows."""

    def cancel(self) -> None:
        """Stop everything in flight (called on interruption)."""

    def finish(self, session: Session) -> R:
        """The report, once :meth:`poll` said everything ended (cluster still up)."""
        raise NotImplementedError


def solver_version(client, embedded: bool) -> str:
    """``CalculiX <version>`` of the workers (part of every key)."""
    if embedded:
        return f"CalculiX {ccx_version()}"
    if not client.scheduler_info().get("workers"):
        try:
            client.wait_for_workers(1, timeout=60)
        except TimeoutError as e:
            raise ClusterError("the scheduler has no workers: start some with "
                               "`dask worker <scheduler address>`") from e
    return f"CalculiX {client.submit(ccx_version, pure=False).result()}"


def cluster_spec(cluster: ClusterSpec | None, scheduler: str | None,
                 workers: int | None) -> ClusterSpec:
    """``cluster``, else a :class:`DaskCluster` of ``scheduler`` and ``workers`` (the
    shorthand of callers that know no other cluster); both is a programming error."""
    if cluster is None:
        return DaskCluster(scheduler, workers)
    if scheduler is not None or workers is not None:
        raise TypeError("give cluster= or scheduler=/workers=, not both")
    return cluster


def drive(strategy: Strategy[R], *, cluster: ClusterSpec | None = None,
          scheduler: str | None = None, workers: int | None = None,
          progress: Progress | None = None,
          on_client: Callable[[Any], None] | None = None) -> R:
    """Run ``strategy`` on ``cluster`` (default: :class:`DaskCluster` of ``scheduler``
    and ``workers``) to its end; return its report."""
    progress = progress or Announce()
    start = time.perf_counter()
    cluster = cluster_spec(cluster, scheduler, workers)
    with cluster.client() as client:
        if on_client is not None:
            on_client(client)
        session = Session(client, solver_version(client, cluster.embedded),
                          dashboard_link(client), len(client.scheduler_info()["workers"]),
                          CcxFeed(client))
        page = StudyEvents(client, _study_name(strategy), type(strategy).__name__.lower())
        try:
            strategy.start(session)
            progress.started(session, strategy.state())
            while not strategy.poll():
                progress.advanced(strategy.state())
                page.update(strategy.state())
                time.sleep(strategy.poll_seconds)
            progress.advanced(strategy.state())
        except BaseException:
            strategy.cancel()
            page.update(strategy.state(), ended=True)
            raise
        page.update(strategy.state(), ended=True)
        session.feed.close()
        report = strategy.finish(session)
    report.dashboard, report.workers, report.solver = (session.dashboard, session.workers,
                                                       session.solver)
    report.wall_seconds = time.perf_counter() - start
    progress.finished(report)
    return report


def _study_name(strategy: Strategy) -> str:
    """What the farm page calls a run: its study's name, else its kind."""
    study = getattr(strategy, "study", None)
    return str(getattr(study, "name", None) or type(strategy).__name__)


class LoopThreads(Strategy[R]):
    """Optimisation loops in client threads, sharing one :class:`Evaluator`.

    Tasks never wait on tasks: a loop blocks only its own client thread while its
    evaluations run on the workers, so any number of loops share any number of workers
    without deadlock (docs/architecture.md, "Jobs on Dask"). Subclasses give the loops
    (:meth:`loops`) and collect each one's end (:meth:`collected`).
    """

    def __init__(self, cache: str | None) -> None:
        self.cache = cache
        self.evaluator: Evaluator | None = None
        self._pool: ThreadPoolExecutor | None = None
        self._pending: dict[Future, int] = {}

    @property
    def started_evaluator(self) -> Evaluator:
        """The evaluator :meth:`start` made: the loops and :meth:`finish` run after it."""
        assert self.evaluator is not None, "start() makes the evaluator"
        return self.evaluator

    def loops(self, session: Session) -> list[Callable[[], Any]]:
        raise NotImplementedError

    def collected(self, index: int, result: Any, error: BaseException | None) -> None:
        raise NotImplementedError

    def start(self, session: Session) -> None:
        # lost workers cost a resubmission, not a failed evaluation (jobs.cluster)
        self.evaluator = Evaluator(ResubmittingClient(session.client),
                                   EvaluationCache(self.cache))
        loops = self.loops(session)
        self._pool = ThreadPoolExecutor(max_workers=max(1, len(loops)),
                                        thread_name_prefix="loop")
        self._pending = {self._pool.submit(fn): k for k, fn in enumerate(loops)}

    def poll(self) -> bool:
        for fut in [f for f in self._pending if f.done()]:
            k = self._pending.pop(fut)
            error = fut.exception()
            self.collected(k, None if error else fut.result(), error)
        if not self._pending and self._pool is not None:
            self._pool.shutdown(wait=True)
        return not self._pending

    def cancel(self) -> None:
        if self.evaluator is not None:
            self.evaluator.close()  # loops stop at their next evaluation; tasks cancelled
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
