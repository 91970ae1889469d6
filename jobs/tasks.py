"""What a worker runs for a sweep: solve one load path and write its experiments.

A task is idempotent: it first skips experiments the store already holds as done (a
task re-run after its worker died redoes only what was lost), writes each experiment
into its own store slot (status last), and records solver failures as data.

Failure policy: the one of every job (:mod:`jobs.guard`, owned by
:class:`farm.ccx.outcome.Outcome`): one retry with four times smaller increments where
the outcome is worth it, failures recorded with their reason, cancellations raised. On
top of it, a path of several deflections that still fails for such an outcome is solved
deflection by deflection, so that one deflection beyond the model's reach does not take
its neighbours down.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import storage
from farm.errors import SolverError
from farm.experiment import run_load_path
from farm.specs import LoadPath, ModelSpec, SolverSettings
from jobs.expand import Experiment, PathPlan
from jobs.guard import Failed, Solved, cancellation_check, guarded


@dataclass(frozen=True)
class PathTask:
    """Everything a worker needs, as plain picklable values.

    ``store`` is a location (path or URL), or a zarr store opened with storage options
    (:attr:`jobs.study.Study.store`): an fsspec store pickles with its options, so the
    worker's copy reaches the same endpoint as the client without any environment.
    """

    path: PathPlan
    model: ModelSpec
    settings: SolverSettings
    store: storage.StoreLike
    group: str
    retry_smaller_increments: bool = True


@dataclass(frozen=True)
class PathOutcome:
    """What a task did: experiment ids done, failed (with reasons) and skipped."""

    key: str
    done: tuple[str, ...] = ()
    failed: tuple[tuple[str, str], ...] = ()
    skipped: tuple[str, ...] = ()
    solve_seconds: float = 0.0
    ccx_runs: int = 0


def load_path(task: PathTask, exps: list[Experiment]) -> LoadPath:
    """The load path that solves ``exps`` (some or all of ``task.path``'s): its
    deflections under its road motion (combined loads; None: vertical), which acts on
    the whole path. A roll (issue 45) is the task's whole roll with every state of it,
    whichever are still to do (:func:`_kept` picks those): its output times set ccx's
    increments, so a state's values never depend on which others a run still needs."""
    motion = exps[0].motion
    if motion is not None and motion.rolls:
        states = [e.motion for e in task.path.experiments if e.motion is not None]
        whole = states[-1]
        return LoadPath((exps[0].deflection,), exps[0].pressure, whole,
                        tuple(m.roll / whole.roll for m in states))
    if motion is not None and motion.moves and len(exps) != 1:
        raise ValueError("a path with a road shift holds one experiment (jobs.expand.plan)")
    return LoadPath(tuple(e.deflection for e in exps), exps[0].pressure, motion)


def _guarded_path(task: PathTask, exps: list[Experiment], should_stop, retry: bool):
    path = load_path(task, exps)

    def solve(settings: SolverSettings) -> Solved:
        try:
            r = run_load_path(task.model, path, settings, should_stop=should_stop)
        except SolverError as e:  # a roll that stopped: the states it reached
            if isinstance(e.partial, tuple):
                raise e.with_partial(_kept(task, exps, e.partial)) from e
            raise
        # With a shift the path's states are its deflections (unshifted) and then the
        # shift's ramp; the experiment is the last state (jobs.expand.plan gives such a
        # path one deflection). A roll: one state per state of the task's roll.
        # Otherwise one state per deflection.
        states = (_kept(task, exps, r.measurements) if path.motion and path.motion.rolls
                  else r.measurements[-len(exps):])
        return Solved(states, r.solve_seconds, r.ccx_runs, r.increments)

    return guarded(solve, task.settings, retry=retry)


def _kept(task: PathTask, exps: list[Experiment], states: tuple) -> tuple:
    """Of a roll's states (the first of ``task.path``'s, in order), those of ``exps``,
    up to the first that was not reached."""
    wanted = {e.id for e in exps}
    return tuple(m for e, m in zip(task.path.experiments, states, strict=False)
                 if e.id in wanted)


def solve_experiments(task: PathTask, exps: list[Experiment], should_stop) -> PathOutcome:
    """Solve the experiments as one path; split it if it fails for a solver outcome."""
    result = _guarded_path(task, exps, should_stop, task.retry_smaller_increments)
    rolls = exps[0].motion is not None and exps[0].motion.rolls  # keeps what it reached
    if isinstance(result, Failed) and result.retry_smaller and len(exps) > 1 and not rolls:
        # each deflection on its own, with the study's settings and no second retry
        results = [_guarded_path(task, [x], should_stop, False) for x in exps]
        return _combine(task, [write_outcome(task, [x], r) for x, r in zip(exps, results,
                                                                     strict=True)])
    return write_outcome(task, exps, result)


def write_outcome(task: PathTask, exps: list[Experiment], result) -> PathOutcome:
    if isinstance(result, Failed) and result.partial is not None:
        # a roll that stopped (issue 45): the states it reached are experiments done
        k = len(result.partial.measurements)
        done = write_outcome(task, exps[:k], result.partial)
        rest = write_outcome(task, exps[k:], dataclasses.replace(
            result, reason=f"{_stopped(exps[k - 1])}: {result.reason}", partial=None))
        return _combine(task, [done, rest])
    if isinstance(result, Failed):
        for x in exps:
            storage.write_failure(task.store, task.group, x.id, result.reason, {})
        return PathOutcome(task.path.key, failed=tuple((x.id, result.reason) for x in exps))
    for x, m in zip(exps, result.measurements, strict=True):
        # combined_arrays() is empty for a vertical state: the store then keeps the
        # combined variables (combined-load groups only) as not recorded
        storage.write_experiment(task.store, task.group, x.id,
                                 {**m.arrays(), **m.combined_arrays()}, {
            "solve_seconds": m.solve_seconds, "increments": result.increments,
            "ccx_runs": result.ccx_runs, "contact_nodes": m.contact_nodes,
            **m.patch_values()})  # contact patch, inflation growth (issue 24)
    return PathOutcome(task.path.key, done=tuple(x.id for x in exps),
                       solve_seconds=result.solve_seconds, ccx_runs=result.ccx_runs)


def _stopped(last: Experiment) -> str:
    """What a roll or a slide that stopped kept, for the reason of the states it did
    not reach."""
    m = last.motion
    where = (f"roll: stopped after the state at {m.roll:g} mm of travel" if m is not None
             and m.rolls else "slide: stopped after the state at a shift of "
             f"({m.shift_x if m else 0:.4g}, {m.shift_y if m else 0:.4g}) mm")
    return f"partial {where} (stored, {last.id}) and before this one"


def _combine(task: PathTask, parts: list[PathOutcome]) -> PathOutcome:
    return PathOutcome(task.path.key, sum((p.done for p in parts), ()),
                       sum((p.failed for p in parts), ()), (),
                       sum(p.solve_seconds for p in parts), sum(p.ccx_runs for p in parts))


def run_path(task: PathTask) -> PathOutcome:
    """Worker entry point: solve the path's experiments not yet done, write them.

    Under the path's claim (:func:`storage.claim`): a cluster that shares no scheduler
    with another one on the same store (two embedded clusters) waits while the other
    solves the path, then reads the statuses and skips what it wrote. Tasks of one
    scheduler never meet here: their Dask key is the path's key.
    """
    should_stop = cancellation_check()
    with storage.claim(task.store, task.group, task.path.key, should_stop=should_stop) as go:
        if not go:  # cancelled while another cluster's worker held the path
            return PathOutcome(task.path.key)
        ids = [e.id for e in task.path.experiments]
        status = storage.statuses(task.store, task.group, ids)
        todo = [e for e in task.path.experiments if status.get(e.id) != storage.DONE]
        skipped = tuple(e.id for e in task.path.experiments
                        if status.get(e.id) == storage.DONE)
        if not todo:
            return PathOutcome(task.path.key, skipped=skipped)
        outcome = solve_experiments(task, todo, should_stop)
        return dataclasses.replace(outcome, skipped=skipped)
