"""Worker-side guard around a solve: one retry with smaller increments, failures as data.

Shared by every loop's worker tasks. Non-convergence and a ccx crash are retried once
with four times smaller increments (as sweeps retry non-convergence, :mod:`jobs.tasks`);
what still fails is returned as ``{"error": message}`` so that the client caches it:
the same input would fail again. A crash that repeats is such a failure - measured: one
forward evaluation of the reproduction's inverse study crashed ccx's spooles solver
(exit 255) every time, and while crashes were not cached every re-run solved it again.
Timeouts and cancellations raise: they are not properties of the input, so they are
not cached.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from farm.errors import FarmError, SolverError
from farm.specs import SolverSettings

NON_CONVERGED = {"too_many_cutbacks", "increment_below_minimum", "max_increments", "diverged"}
RETRIED = NON_CONVERGED | {"crash"}
TRANSIENT = {"timeout", "cancelled"}


def smaller_increments(settings: SolverSettings) -> SolverSettings:
    return dataclasses.replace(
        settings, initial_increment=settings.initial_increment / 4,
        max_increment=settings.max_increment / 4,
        min_increment=min(settings.min_increment, settings.initial_increment / 400),
        max_increments=settings.max_increments * 4)


def guarded(solve: Callable[[SolverSettings], dict[str, np.ndarray]],
            settings: SolverSettings) -> dict[str, np.ndarray]:
    """Run ``solve(settings)`` under the policy above."""
    try:
        try:
            return solve(settings)
        except SolverError as e:
            if e.outcome not in RETRIED:
                raise
            return solve(smaller_increments(settings))
    except SolverError as e:
        if e.outcome in TRANSIENT:
            raise
        return {"error": np.array(str(e)), "seconds": np.array(0.0)}
    except FarmError as e:  # a spec the mesher or the results reader rejects: deterministic
        return {"error": np.array(f"{type(e).__name__}: {e}"), "seconds": np.array(0.0)}
