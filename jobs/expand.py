"""Expand a study into experiments and load-path tasks, with content-hash identities.

An experiment is one (model, load case) pair; its id comes from :mod:`jobs.identity`
(model spec, mesh key, solver version and load case): the same inputs give the same id,
any change gives a new one. Cases with the same model and pressure
form one load path - one ccx run for all its deflections, the big saving measured on the
physics layer - optionally split into pieces of ``max_path_length`` deflections to spread
a long path over several workers. A path's task key derives from its experiments' ids,
so Dask never runs the same path twice at once.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.stats import qmc

from jobs.identity import experiment_id, legacy_experiment_id, path_key, resolve_ids
from jobs.study import Study


@dataclass(frozen=True)
class Experiment:
    """One virtual experiment: a load case of the study's model, and its id."""

    id: str
    deflection: float  # mm
    pressure: float  # MPa


@dataclass(frozen=True)
class PathPlan:
    """The experiments of one load path (one pressure, increasing deflections)."""

    key: str
    pressure: float
    experiments: tuple[Experiment, ...]

    @property
    def deflections(self) -> tuple[float, ...]:
        return tuple(e.deflection for e in self.experiments)


def load_cases(study: Study) -> list[tuple[float, float]]:
    """(deflection mm, pressure MPa) of every case: the grid, or the sampled design."""
    if study.sampling is None:
        return [(d, p) for p, d in itertools.product(study.pressures, study.deflections)]
    s = study.sampling
    names = [name for name, _, _ in s.ranges]
    engine = (qmc.LatinHypercube(d=len(names), seed=s.seed) if s.method == "lhs"
              else qmc.Sobol(d=len(names), scramble=True, seed=s.seed))
    unit = engine.random(s.n)
    points = qmc.scale(unit, [low for _, low, _ in s.ranges], [high for _, _, high in s.ranges])
    fixed = {"deflection": study.deflections or (None,), "pressure": study.pressures or (None,)}
    cases = []
    for row in points:
        values = dict(zip(names, row, strict=True))
        for d, p in itertools.product(*(
            ([values[k]] if k in values else fixed[k]) for k in ("deflection", "pressure")
        )):
            cases.append((round(float(d), 9), round(float(p), 12)))
    return cases


def plan(study: Study, solver: str, held: frozenset[str] = frozenset()) -> list[PathPlan]:
    """Load paths of the study, each with its experiments sorted by deflection.

    ``held``: the ids the study's group already holds; an experiment stored under its
    recipe-1 id keeps it (:func:`jobs.identity.resolve_ids`).
    """
    by_pressure: dict[float, set[float]] = {}
    for d, p in load_cases(study):
        by_pressure.setdefault(p, set()).add(d)
    paths = []
    for p in sorted(by_pressure):
        cases = sorted(by_pressure[p])
        ids = [experiment_id(study.model, d, p, solver) for d in cases]
        if held:
            ids = resolve_ids(ids, [legacy_experiment_id(study.model, d, p, solver)
                                    for d in cases], held)
        experiments = [Experiment(i, d, p) for i, d in zip(ids, cases, strict=True)]
        size = study.max_path_length or len(experiments)
        for k in range(0, len(experiments), size):
            piece = tuple(experiments[k:k + size])
            paths.append(PathPlan(path_key(e.id for e in piece), p, piece))
    return paths


def experiments(paths: list[PathPlan]) -> list[Experiment]:
    """All experiments of a plan, in path order."""
    return [e for path in paths for e in path.experiments]


def parameters(exps: list[Experiment]) -> dict[str, np.ndarray]:
    """The load-case parameters the store keeps per experiment."""
    return {"deflection": np.array([e.deflection for e in exps]),
            "pressure": np.array([e.pressure for e in exps])}
