"""The one worker-side guard of every job: what is retried, what becomes data (recorded
or cached), what is transient, and what is raised."""

import pytest

from farm.ccx.outcome import Outcome
from farm.errors import MeshError, SolverError
from farm.specs import SolverSettings
from jobs.guard import Failed, Solved, guarded


def _solver(*outcomes):
    """A solve that fails with ``outcomes`` in turn, then succeeds; records its settings."""
    calls = []

    def solve(settings):
        calls.append(settings)
        if len(calls) <= len(outcomes):
            raise SolverError(outcomes[len(calls) - 1], ["ccx", "-i", "job"], 255, "tail")
        return Solved((), 1.0)

    return solve, calls


@pytest.mark.parametrize("outcome", [o for o in Outcome if o.retry_smaller])
def test_one_failure_is_retried_with_smaller_increments(outcome):
    solve, calls = _solver(outcome)
    result = guarded(solve, SolverSettings())
    assert isinstance(result, Solved)
    assert result.ccx_runs == 2 and result.solve_seconds >= 1.0  # the failed try counts
    assert calls[1].initial_increment == calls[0].initial_increment / 4
    assert calls[1].split_rise and not calls[0].split_rise  # a combined path's rise: own step


@pytest.mark.parametrize("outcome", ["too_many_cutbacks", "crash"])
def test_no_retry_when_asked(outcome):
    solve, calls = _solver(outcome)
    result = guarded(solve, SolverSettings(), retry=False)
    assert isinstance(result, Failed) and len(calls) == 1 and result.retry_smaller


@pytest.mark.parametrize("outcome", ["too_many_cutbacks", "crash", "input_error",
                                     "nonpositive_jacobian"])
def test_a_repeated_failure_is_deterministic_data(outcome):
    solve, calls = _solver(outcome, outcome)
    result = guarded(solve, SolverSettings())
    assert isinstance(result, Failed) and not result.transient
    assert result.outcome == outcome and outcome in result.reason
    assert len(calls) == (2 if Outcome(outcome).retry_smaller else 1)


@pytest.mark.parametrize("outcomes", [("timeout",), ("crash", "timeout")])
def test_timeouts_are_transient_data(outcomes):
    solve, _ = _solver(*outcomes)
    result = guarded(solve, SolverSettings())
    assert isinstance(result, Failed) and result.transient and result.outcome == "timeout"


@pytest.mark.parametrize("outcomes", [("cancelled",), ("crash", "cancelled")])
def test_cancellations_raise(outcomes):
    solve, _ = _solver(*outcomes)
    with pytest.raises(SolverError):
        guarded(solve, SolverSettings())


def test_physics_errors_are_data_and_bugs_raise():
    def mesh_fails(settings):
        raise MeshError("gmsh said no")

    result = guarded(mesh_fails, SolverSettings())
    assert isinstance(result, Failed) and result.outcome == "MeshError"
    assert not result.retry_smaller and not result.transient

    def bug(settings):
        raise KeyError("bug")

    with pytest.raises(KeyError):
        guarded(bug, SolverSettings())


def test_outcome_owns_the_policy():
    assert {o for o in Outcome if o.transient} == {Outcome.TIMEOUT, Outcome.CANCELLED}
    assert not Outcome.CONVERGED.retry_smaller and Outcome.CRASH.retry_smaller
    assert not any(o.retry_smaller and o.transient for o in Outcome)


@pytest.mark.parametrize("reached", [(2, 1), (1, 2), (0, 0)])
def test_a_path_that_stops_keeps_the_states_of_the_try_that_got_furthest(reached):
    """Issue 45: a roll that stops carries the states it reached (SolverError.partial,
    measurements by then); after the retry the failure keeps the longer of the two tries'
    states, with both runs counted and the last kept state's seconds; none: no partial."""
    import numpy as np

    from farm.measure.measurement import Measurement

    def state(k: int) -> Measurement:
        z = np.zeros((2, 3))
        return Measurement(10.0, 0.2, z, z, z, z, np.zeros(3), np.zeros(3), np.zeros(3), 1,
                           float(k + 1))

    calls = []

    def solve(settings):
        states = tuple(state(k) for k in range(reached[len(calls)]))
        calls.append(settings)
        raise SolverError("increment_below_minimum", ["ccx", "-i", "roll"], 201, "tail",
                          reached=2.5, partial=states or None)

    result = guarded(solve, SolverSettings())
    assert isinstance(result, Failed) and len(calls) == 2
    if max(reached) == 0:
        assert result.partial is None
        return
    assert len(result.partial.measurements) == max(reached)
    assert result.partial.ccx_runs == 2
    assert result.partial.solve_seconds == float(max(reached))
