"""Warm starts (jobs/inverse/warm.py): which evaluations a loop's batches become.

A stub forward model stands in for ccx (the real one: tests/farm/test_continuation.py
and tests/jobs/inverse/test_jacobian_reuse_farm.py); what is checked here is the
bookkeeping: a point without a base is solved from rest and keeps its state, a trial
point continues from its base, a Jacobian's columns are solved ``columns_per_run`` to a
run from their point, a point asked for again is the same evaluation, and keys name
the state they start from.
"""

from types import SimpleNamespace

import numpy as np
import pytest

from farm.presets import default_model
from farm.specs import MeshDensity, SolverSettings
from jobs.guard import Failed, Solved
from jobs.identity import canonical, value_key
from jobs.inverse.evaluate import ForwardTask, task_key
from jobs.inverse.warm import WarmStarts
from jobs.loops.cache import EvaluationCache
from jobs.loops.evaluator import Evaluation, Evaluator, LoopStats


def _solve(task) -> Solved:
    points = [task.forces, *task.then]
    ms = tuple(SimpleNamespace(point=np.array(p), solve_seconds=0.5) for p in points)
    state = f"state of {task.forces}".encode() if task.keep_state else None
    return Solved(ms, 0.5 * len(points), 1, len(points), state)


class StubProblem:
    """forward_evaluation as jobs.inverse.problem.Problem makes it, without a model."""

    def __init__(self) -> None:
        self.asked: list[SimpleNamespace] = []

    def forward_evaluation(self, x, *, then=(), keep_state=False, start=None):
        key, state = start if start is not None else (None, None)
        task = SimpleNamespace(forces=canonical(x), then=tuple(canonical(p) for p in then),
                               keep_state=keep_state, start=key, start_state=state)
        self.asked.append(task)
        body = {"x": task.forces, "then": task.then, "keep": keep_state, "start": key}
        return Evaluation(value_key(body), _solve, task, "stub", 1 + len(task.then))


@pytest.fixture
def warm():
    problem = StubProblem()
    return WarmStarts(problem, Evaluator(None, EvaluationCache(None)), LoopStats(), 4)


def _points(results) -> list:
    return [r.measurement.point.tolist() for r in results]


def test_a_point_without_a_base_is_solved_from_rest_and_keeps_its_state(warm):
    (r,) = warm.run([np.array([1.0, 2.0])])
    (task,) = warm.problem.asked
    assert task.keep_state and task.start is None and r.state is not None


def test_a_trial_point_continues_from_its_base(warm):
    x = np.array([1.0, 2.0])
    warm.run([x])
    base_key = warm.problem.forward_evaluation(x, keep_state=True).key
    (r,) = warm.run([x + 0.5], base=x)
    task = warm.problem.asked[-1]
    assert task.start == base_key and task.start_state == b"state of (1.0, 2.0)"
    assert task.keep_state  # the next step may continue from it
    assert _points([r]) == [[1.5, 2.5]]


def test_jacobian_columns_are_solved_a_run_of_columns_at_a_time(warm):
    x = np.arange(10.0)
    warm.run([x])
    columns = [x + 0.1 * np.eye(10)[k] for k in range(10)]
    results = warm.run(columns, base=x)
    runs = warm.problem.asked[1:]
    assert [1 + len(t.then) for t in runs] == [4, 4, 2]  # columns_per_run = 4
    assert all(t.start is not None and not t.keep_state for t in runs)
    np.testing.assert_allclose(_points(results), np.array(columns))
    assert warm.stats.evaluations == 11 and warm.stats.solved == 4 and warm.stats.rounds == 2


def test_a_base_not_solved_by_this_loop_means_from_rest(warm):
    warm.run([np.array([3.0])], base=np.array([9.0]))
    assert warm.problem.asked[0].start is None


def test_a_point_asked_for_again_is_the_same_evaluation(warm):
    x = np.array([1.0, 2.0])
    first = warm.run([x])[0]
    again = warm.run([x + 1e-12])[0]  # the same point as the solver sees it (rounded)
    assert again is first and warm.stats.solved == 1 and warm.stats.cached == 1


def test_around_solves_the_point_first_then_its_columns_from_it(warm):
    x = np.array([1.0, 2.0])
    out = warm.around(x, [x + np.array([0.1, 0]), x + np.array([0, 0.1])])
    assert len(out) == 3 and warm.stats.rounds == 2
    assert warm.problem.asked[1].start is not None


def test_without_warm_starts_every_point_is_the_plain_evaluation():
    problem = StubProblem()
    cold = WarmStarts(problem, Evaluator(None, EvaluationCache(None)), LoopStats(), 4,
                      enabled=False)
    x = np.array([1.0, 2.0])
    cold.run([x])
    cold.run([x + 1, x + 2], base=x)
    assert all(not t.keep_state and t.start is None and not t.then for t in problem.asked)
    assert cold.around(x, [x + 1]) and cold.stats.rounds == 3


def test_a_failed_run_of_columns_fails_each_of_its_points():
    def failing(task):
        return Failed("no convergence", "diverged")

    problem = StubProblem()
    warm = WarmStarts(problem, Evaluator(None, EvaluationCache(None)), LoopStats(), 4)
    x = np.array([1.0, 2.0])
    warm.run([x])
    original = problem.forward_evaluation
    problem.forward_evaluation = lambda *a, **k: Evaluation(
        original(*a, **k).key, failing, None, "stub", original(*a, **k).points)
    out = warm.run([x + np.array([0.1, 0]), x + np.array([0, 0.1])], base=x)
    assert all(isinstance(r, Failed) for r in out) and len(out) == 2


MODEL = default_model("reduced", mesh=MeshDensity(tread=4, sidewall=2, bead=1,
                                                  circumferential=8))


def _task(**changes) -> ForwardTask:
    return ForwardTask(MODEL, (1, 2), (10.0, 20.0), -380.0, SolverSettings(), **changes)


def test_the_plain_evaluation_keeps_its_key():
    """Keys of evaluations cached before continuations existed still find them."""
    from jobs.identity import evaluation_key
    from jobs.inverse.evaluate import OUTPUTS_VERSION

    before = evaluation_key("inverse-forward", MODEL, "2.20", OUTPUTS_VERSION,
                            {"nodes": (1, 2), "forces": (10.0, 20.0), "road_z": -380.0})
    assert task_key("inverse-forward", _task(), "2.20") == before
    assert not _task().continued and _task(keep_state=True).continued


def test_a_continuation_is_keyed_by_what_it_starts_from_not_by_its_bytes():
    keys = {task_key("inverse-forward", t, "2.20") for t in (
        _task(), _task(keep_state=True), _task(start="a" * 64), _task(start="b" * 64),
        _task(then=((11.0, 20.0),), start="a" * 64))}
    assert len(keys) == 5
    same = [task_key("inverse-forward", _task(start="a" * 64, start_state=s), "2.20")
            for s in (b"one", b"two", None)]
    assert len(set(same)) == 1
