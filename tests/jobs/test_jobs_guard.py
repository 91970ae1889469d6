"""The worker-side guard of loop evaluations: what is retried, what becomes cached data,
and what is raised (so that it is not cached)."""

import numpy as np
import pytest

from farm.errors import SolverError
from farm.specs import SolverSettings
from jobs.loops.guard import guarded


def _solver(*outcomes):
    """A solve that fails with ``outcomes`` in turn, then succeeds; records its settings."""
    calls = []

    def solve(settings):
        calls.append(settings)
        if len(calls) <= len(outcomes):
            raise SolverError(outcomes[len(calls) - 1], ["ccx", "-i", "job"], 255, "tail")
        return {"value": np.array(1.0)}

    return solve, calls


@pytest.mark.parametrize("outcome", ["too_many_cutbacks", "crash"])
def test_one_failure_is_retried_with_smaller_increments(outcome):
    solve, calls = _solver(outcome)
    assert guarded(solve, SolverSettings())["value"] == 1.0
    assert calls[1].initial_increment == calls[0].initial_increment / 4


@pytest.mark.parametrize("outcome", ["too_many_cutbacks", "crash", "input_error"])
def test_a_repeated_failure_is_data_for_the_cache(outcome):
    solve, calls = _solver(outcome, outcome)
    result = guarded(solve, SolverSettings())
    assert outcome in str(result["error"]) and len(calls) == (1 if outcome == "input_error"
                                                             else 2)


@pytest.mark.parametrize("outcomes", [("timeout",), ("crash", "timeout"), ("cancelled",)])
def test_timeouts_and_cancellations_raise_and_are_never_cached(outcomes):
    solve, _ = _solver(*outcomes)
    with pytest.raises(SolverError):
        guarded(solve, SolverSettings())
