"""Run an inverse study on Dask: ``farm invert study.toml``.

A strategy of the one driver (:mod:`jobs.driver`): the client solves (or replays) the
reference experiment, then runs every loop of the study in its own thread; the loops'
evaluations go to the workers through one shared evaluator. When all loops have
ended, the client writes the study's group of the store. Re-running the same study
replays every evaluation from the cache (no ccx): that is how a loop is resumed after
the client died.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from farm.mesh import mesh_for
from jobs.cluster import ClusterSpec
from jobs.driver import LoopThreads, drive
from jobs.errors import StudyError
from jobs.inverse.distribution import (
    TyreDistribution,
    check_mesh,
    fit_distribution,
    training_set,
)
from jobs.inverse.guesses import FieldGuess, check_guess_mesh
from jobs.inverse.loop import LoopResult, LoopState, expand_loops, run_loop
from jobs.inverse.mask import masks_for
from jobs.inverse.problem import Problem, build_problem
from jobs.inverse.store import write_results
from jobs.inverse.study import InverseStudy
from jobs.loops.evaluator import Interrupted, LoopStats
from jobs.progress import Progress, RunReport, Session
from jobs.wording import plural


@dataclass
class InverseReport(RunReport):
    """How an inverse study ended. ``ok`` when every loop ended without failing."""

    study: InverseStudy
    problem: Problem | None = None
    results: list[LoopResult] = field(default_factory=list)
    errors: dict[str, str] = field(default_factory=dict)
    totals: LoopStats = field(default_factory=LoopStats)

    @property
    def ok(self) -> bool:
        return not self.errors and all(r.status != "failed" for r in self.results)

    def summary(self) -> str:
        """One line: loops, evaluations, solver runs and time."""
        t, n = self.totals, len(self.results)
        best = np.nanmedian([r.objective for r in self.results]) if n else float("nan")
        return (f"{plural(n, 'solve')}, {plural(t.evaluations, 'evaluation')} ({t.solved} "
                f"solved by ccx, {t.cached} from the cache, {t.shared} shared between loops), "
                f"{plural(t.rounds, 'round')}, median final objective {best:.3g}, "
                f"{self.wall_seconds:.1f} s wall")


class Inverse(LoopThreads[InverseReport]):
    """The inverse strategy: the reference, then one loop per condition x method x
    optimiser x repeat; the progress state is the list of :class:`LoopState`."""

    def __init__(self, study: InverseStudy, write: bool = True,
                 surrogate: FieldGuess | None = None) -> None:
        super().__init__(study.cache)
        self.study, self.write, self.surrogate = study, write, surrogate
        if surrogate is None and any(c.initial == "surrogate" for c in study.conditions):
            raise StudyError("initial = \"surrogate\" needs the trained surrogate guess: "
                             "`farm invert` builds it from the [distribution] group; in Python "
                             "pass run_inverse(..., surrogate=analysis.surrogate_guess."
                             "from_group(store, group))")
        self.specs = expand_loops(study)
        mesh = mesh_for(study.model)
        if surrogate is not None:
            check_guess_mesh(surrogate, mesh.inner_nodes, mesh.tread_nodes)
        self.masks = masks_for(study.mask, mesh.inner_nodes,
                               {m for c in study.conditions for m in c.methods})  # bad input: now
        self.distribution = train_distribution(study, mesh)  # likewise: before anything runs
        self.states = [LoopState(s.label, s.optimizer.max_evaluations) for s in self.specs]
        self.report = InverseReport(study)
        self._results: dict[int, LoopResult] = {}

    def loops(self, session: Session) -> list[Callable[[], LoopResult]]:
        study, ev = self.study, self.started_evaluator
        self.report.problem = problem = build_problem(study, ev, session.solver)
        return [functools.partial(run_loop, study, problem, s, ev, st, self.masks.get(s.method),
                                  distribution=self.distribution, surrogate=self.surrogate)
                for s, st in zip(self.specs, self.states, strict=True)]

    def collected(self, index: int, result, error) -> None:
        state = self.states[index]
        if isinstance(error, Interrupted):
            state.status = "interrupted"
        elif error is not None:  # one loop's failure (e.g. its guess) does not stop the others
            state.status = "failed"
            state.error = self.report.errors[state.label] = f"{type(error).__name__}: {error}"
        else:
            self._results[index] = state.result = result

    def state(self) -> list[LoopState]:
        return self.states

    def finish(self, session: Session) -> InverseReport:
        report = self.report
        report.results = [self._results[k] for k in sorted(self._results)]
        report.totals = self.started_evaluator.total
        if self.write and report.results:
            assert report.problem is not None  # loops() built it before any loop ran
            write_results(self.study, report.problem, report.results)
        return report


def train_distribution(study: InverseStudy, mesh) -> TyreDistribution | None:
    """The "tyre distribution" of the study's ``[distribution]`` group, trained now (None
    when no condition uses it). A missing or unsuitable group is one StudyError."""
    spec = study.distribution
    if spec is None or all(c.initial != "distribution" for c in study.conditions):
        return None
    data = training_set(spec.store, spec.group)
    check_mesh(data, mesh.tread_nodes, mesh.xyz(mesh.tread_nodes))
    return fit_distribution(data, n_components=spec.components, degree=spec.degree,
                            exclude={"deflection": study.deflection},
                            within=spec.exclude_within)


def run_inverse(study: InverseStudy, *, scheduler: str | None = None,
                workers: int | None = None, progress: Progress | None = None,
                on_client: Callable[[object], None] | None = None,
                write: bool = True, cluster: ClusterSpec | None = None,
                surrogate: FieldGuess | None = None) -> InverseReport:
    """Run every loop of ``study`` and write the results group; return the report.

    ``cluster`` (:class:`jobs.cluster.ClusterSpec`) replaces ``scheduler``/``workers``;
    ``surrogate`` is the guess of ``initial = "surrogate"`` conditions."""
    return drive(Inverse(study, write, surrogate), cluster=cluster, scheduler=scheduler,
                 workers=workers, progress=progress, on_client=on_client)
