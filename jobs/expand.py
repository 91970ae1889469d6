"""Expand a study into experiments and load-path tasks, with content-hash identities.

An experiment is one (model, load case) pair; its id comes from :mod:`jobs.identity`
(model spec, mesh key, solver version and load case): the same inputs give the same id,
any change gives a new one. Cases with the same model, pressure and road motion
form one load path - one ccx run for all its deflections, the big saving measured on the
physics layer - optionally split into pieces of ``max_path_length`` deflections to spread
a long path over several workers. A combined-load case whose road shifts is a path of
its own (:func:`plan` says why). A path's task key derives from its experiments' ids,
so Dask never runs the same path twice at once.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.stats import qmc

from farm.specs import RoadMotion
from jobs import nested
from jobs.identity import (
    experiment_id,
    legacy_experiment_id,
    load_label,
    path_key,
    resolve_ids,
)
from jobs.study import (
    CASE_PARAMETERS,
    MOTION_PARAMETERS,
    ROLL_PARAMETERS,
    RollBranches,
    Study,
)


@dataclass(frozen=True)
class Experiment:
    """One virtual experiment: a load case of the study's model, and its id."""

    id: str
    deflection: float  # mm
    pressure: float  # MPa
    motion: RoadMotion | None = None  # combined loads; None: the vertical experiment


@dataclass(frozen=True)
class PathPlan:
    """The experiments of one load path (one pressure and road motion, increasing
    deflections)."""

    key: str
    pressure: float
    experiments: tuple[Experiment, ...]
    motion: RoadMotion | None = None

    @property
    def deflections(self) -> tuple[float, ...]:
        return tuple(e.deflection for e in self.experiments)


def cases(study: Study) -> list[tuple[float, float, RoadMotion | None]]:
    """(deflection mm, pressure MPa, road motion or None) of every case: the grid, or
    the sampled design, each design point with every listed value of what it does not
    sample. Without combined-load keys: exactly the vertical cases of before, in order.
    A ``[loads.tree]`` study: its nested design's cases (:func:`jobs.nested.cases`)."""
    if study.tree is not None:
        return nested.cases(study.tree)
    listed = {"deflection": study.deflections or (None,),
              "pressure": study.pressures or (None,),
              **dict(study.motions)}
    order = ("deflection", "pressure", *(n for n in CASE_PARAMETERS if n in listed))
    rows: list[dict[str, float]]
    if study.sampling is None:
        rows = [{}]
        names: list[str] = []
    else:
        s = study.sampling
        names = [name for name, _, _ in s.ranges]
        engine = (qmc.LatinHypercube(d=len(names), seed=s.seed) if s.method == "lhs"
                  else qmc.Sobol(d=len(names), scramble=True, seed=s.seed))
        # a population's tyre takes its slice of one design over all tyres (loads = "own")
        unit = engine.random(s.n * s.parts)[s.part * s.n:(s.part + 1) * s.n]
        points = qmc.scale(unit, [low for _, low, _ in s.ranges],
                           [high for _, _, high in s.ranges])
        # then the points an adaptive study's rounds added (jobs.adaptive), in order
        rows = [dict(zip(names, row, strict=True)) for row in [*points, *s.points]]
        order = (*order, *(n for n in names if n not in order))
    out: list[tuple[float, float, RoadMotion | None]] = []
    axes: list[tuple[str, Sequence[float | None]]]
    for values in rows:
        if study.sampling is None:
            # the grid of before: every pressure x every deflection (pressure outer)
            axes = [("pressure", listed["pressure"]), ("deflection", listed["deflection"]),
                    *((n, listed[n]) for n in CASE_PARAMETERS if n in listed)]
        else:
            axes = [(k, [values[k]] if k in values else listed[k]) for k in order]
        for combo in itertools.product(*(vals for _, vals in axes)):
            case = dict(zip((k for k, _ in axes), combo, strict=True))
            motion: dict[str, Any] = {
                n: round(_value(case, n), 9) + 0.0 for n in CASE_PARAMETERS if n in case}
            if study.rolling is not None:  # every case of a rolling study rolls
                motion |= study.rolling.case_fields(motion)
            m = RoadMotion(**motion, rise=study.rise) if motion else None
            out.append((round(_value(case, "deflection"), 9), round(_value(case, "pressure"), 12),
                        None if m is None or m.is_identity else m))
    if study.rolling is not None and study.rolling.branches is not None:
        return _branched(out, study.rolling.branches)
    return out


def _branched(trunks: list[tuple[float, float, RoadMotion | None]], branches: RollBranches
              ) -> list[tuple[float, float, RoadMotion | None]]:
    """Each case of ``trunks`` (a rolling tree's trunk) with its ``branches.n`` sampled
    slips: a design of its own per trunk, seeded by the study's branch seed and the
    trunk's place (:func:`jobs.nested.sample`, as the static trees' levels are)."""
    names = [name for name, _, _ in branches.ranges]
    out: list[tuple[float, float, RoadMotion | None]] = []
    for k, (d, p, m) in enumerate(trunks):
        assert m is not None and m.rolls
        points = nested.sample(branches.method, branches.n,
                               [low for _, low, _ in branches.ranges],
                               [high for _, _, high in branches.ranges],
                               nested.sub_seed(branches.seed, k))
        for row in points:
            slips = {n: round(float(v), 9) + 0.0 for n, v in zip(names, row, strict=True)}
            out.append((d, p, dataclasses.replace(
                m, slip_ratio=slips.get("slip_ratio", 0.0),
                slip_angle=slips.get("slip_angle", 0.0))))
    return out


def _value(case: dict[str, float | None], name: str) -> float:
    """The case's ``name``. None stands only for a load the study samples, and the
    sampled value takes its place (jobs.study refuses a load neither listed nor sampled)."""
    value = case[name]
    assert value is not None, f"{name}: neither listed nor sampled"
    return float(value)


def load_cases(study: Study) -> list[tuple[float, float]]:
    """(deflection mm, pressure MPa) of every case (:func:`cases` without the motion)."""
    return [(d, p) for d, p, _ in cases(study)]


def _motion_key(m: RoadMotion | None) -> tuple:
    return () if m is None else tuple(sorted(m.to_dict().items()))


def plan(study: Study, solver: str, held: frozenset[str] = frozenset()
         ) -> list[PathPlan | RollTreePlan]:
    """Load paths of the study, each with its experiments sorted by deflection.

    ``held``: the ids the study's group already holds; an experiment stored under its
    recipe-1 id keeps it (:func:`jobs.identity.resolve_ids`).

    Grouping: cases of one pressure and one road motion share a ccx run. A motion's
    friction and tilt act on the whole path (the road is tilted before contact and
    friction holds from the first touch), so every deflection of such a path is the
    state of its own experiment; but the shift is ramped after the LAST deflection
    only (``LoadPath``: the states at the earlier deflections are unshifted). A case
    with a shift therefore gets a path of its own, one deflection, and its experiment
    is the path's final state. With ``[loads.roll] branch_from_mm`` the rolls are
    rolling trees instead (:func:`roll_tree_plan`).
    """
    if study.rolling is not None and study.rolling.branch_from:
        return list(roll_tree_plan(study, solver))
    groups: dict[tuple, tuple[float, RoadMotion | None, set[float]]] = {}
    for d, p, m in cases(study):
        key = (p, _motion_key(m))
        groups.setdefault(key, (p, m, set()))[2].add(d)
    paths: list[PathPlan | RollTreePlan] = []
    for key in sorted(groups):
        p, m, ds = groups[key]
        found = sorted(ds)
        ids = [experiment_id(study.model, d, p, solver, m) for d in found]
        if held and m is None:  # recipe-1 ids exist only for vertical experiments
            ids = resolve_ids(ids, [legacy_experiment_id(study.model, d, p, solver)
                                    for d in found], held)
        if m is not None and m.rolls:  # one path per roll, its states its experiments
            paths += [_roll_plan(study, solver, d, p, m) for d in found]
            continue
        experiments = [Experiment(i, d, p, m) for i, d in zip(ids, found, strict=True)]
        size = (1 if m is not None and m.moves
                else (study.max_path_length or len(experiments)))
        for k in range(0, len(experiments), size):
            piece = tuple(experiments[k:k + size])
            label = load_label(p, (e.deflection for e in piece), m)
            paths.append(PathPlan(path_key((e.id for e in piece), label), p, piece, m))
    return paths


def _roll_plan(study: Study, solver: str, deflection: float, pressure: float,
               motion: RoadMotion) -> PathPlan:
    """One roll (issue 45: a roll is a load path): an experiment per state it keeps
    (``[loads.roll] states``), each labelled by its travel, with the id a roll of that
    travel from rest has, as a slide's fractions have theirs."""
    assert study.rolling is not None
    exps = tuple(Experiment(experiment_id(study.model, deflection, pressure, solver, m),
                            deflection, pressure, m)
                 for m in (dataclasses.replace(motion, roll=t)
                           for t in study.rolling.travels))
    label = load_label(pressure, (deflection,), motion)
    return PathPlan(path_key((e.id for e in exps), label), pressure, exps, motion)


@dataclass(frozen=True)
class RollBranchPlan:
    """One branch of a rolling tree: the trunk's roll continued at ``slip_ratio`` and
    ``slip_angle`` (degrees); one experiment per state it keeps."""

    key: str
    slip_ratio: float
    slip_angle: float
    experiments: tuple[Experiment, ...]


@dataclass(frozen=True)
class RollTreePlan:
    """A rolling tree (issue 45, :mod:`farm.solve.rolling_tree`): the cases of a rolling
    study that share pressure, deflection, friction, camber and rolling radius. The trunk
    rolls ``motion.roll`` mm (``[loads.roll] branch_from_mm``) straight at kappa = 0 and
    keeps the states of the study's travels it passes (``trunk``); each case is a branch
    that rolls on from there to the study's distance at its own slips."""

    key: str
    pressure: float
    deflection: float
    motion: RoadMotion  # the trunk's roll: friction, tilt, radius, roll = branch_from
    trunk: tuple[Experiment, ...]
    branches: tuple[RollBranchPlan, ...]

    @property
    def experiments(self) -> tuple[Experiment, ...]:
        return (*self.trunk, *(e for b in self.branches for e in b.experiments))


def roll_tree_plan(study: Study, solver: str) -> list[RollTreePlan]:
    """The rolling trees of a study with ``[loads.roll] branch_from_mm``, with the ids
    their states have (a branch without slips is the straight roll from rest, and has its
    id: :attr:`farm.specs.RoadMotion.roll_from`)."""
    rolling = study.rolling
    assert rolling is not None and rolling.branch_from > 0
    start = rolling.branch_from
    trees: dict[tuple, list[RoadMotion]] = {}
    for d, p, m in cases(study):
        assert m is not None and m.rolls
        key = (p, d, m.friction, m.tilt, m.rolling_radius, m.radius_estimate, m.stick_slope,
               m.friction_from)
        if m not in trees.setdefault(key, []):
            trees[key].append(m)

    def exp(d: float, p: float, m: RoadMotion) -> Experiment:
        return Experiment(experiment_id(study.model, d, p, solver, m), d, p, m)

    out = []
    for (p, d, *_), motions in sorted(trees.items(), key=lambda kv: str(kv[0])):
        trunk_roll = dataclasses.replace(motions[0], roll=start, slip_ratio=0.0,
                                         slip_angle=0.0, roll_from=0.0)
        trunk = tuple(exp(d, p, dataclasses.replace(trunk_roll, roll=t))
                      for t in rolling.travels if t <= start)
        branches = []
        for m in motions:
            exps = tuple(exp(d, p, dataclasses.replace(m, roll=t, roll_from=start))
                         for t in rolling.travels if t > start)
            label = load_label(p, (d,), m)
            branches.append(RollBranchPlan(path_key((e.id for e in exps), label, "branch"),
                                           m.slip_ratio, m.slip_angle, exps))
        ids = [e.id for e in trunk] + [b.key for b in branches]
        out.append(RollTreePlan(path_key(ids, load_label(p, (d,), trunk_roll), "rolltree"),
                                p, d, trunk_roll, trunk, tuple(branches)))
    return out


@dataclass(frozen=True)
class BranchPlan:
    """One slide of a tree (:mod:`farm.solve.tree`): from the trunk's state at
    ``level``, the road slid to ``shift`` (mm); one experiment per slide fraction."""

    key: str
    level: int
    shift: tuple[float, float]
    experiments: tuple[Experiment, ...]


@dataclass(frozen=True)
class TreePlan:
    """A load-path tree of a ``[loads.tree]`` study: the trunk (one pressure, friction
    and tilt, rising through ``deflections``; one experiment per level) and its slides."""

    key: str
    pressure: float
    motion: RoadMotion | None  # friction and tilt of the trunk; None: vertical
    deflections: tuple[float, ...]
    trunk: tuple[Experiment, ...]
    branches: tuple[BranchPlan, ...]
    fractions: tuple[float, ...]

    @property
    def experiments(self) -> tuple[Experiment, ...]:
        return (*self.trunk, *(e for b in self.branches for e in b.experiments))


def tree_plan(study: Study, solver: str) -> list[TreePlan]:
    """The trees of a ``[loads.tree]`` study (:func:`jobs.nested.trunk_points`), with the
    ids their load cases have from rest (:func:`jobs.identity.experiment_id`)."""
    design = study.tree
    if design is None:
        raise ValueError("tree_plan needs a study with [loads.tree]")

    def exp(d: float, p: float, m: RoadMotion | None) -> Experiment:
        return Experiment(experiment_id(study.model, d, p, solver, m), d, p, m)

    out = []
    for t in nested.trunk_points(design):
        trunk = tuple(exp(d, t.pressure, t.motion()) for d in t.deflections)
        branches = []
        for level, (d, slides) in enumerate(zip(t.deflections, t.slides, strict=True)):
            for s in slides:
                shift = (s.shift_x, s.shift_y)
                exps = tuple(exp(d, t.pressure, t.motion(shift, f)) for f in design.fractions)
                label = load_label(t.pressure, (d,), t.motion(shift, 1.0))
                branches.append(BranchPlan(path_key((e.id for e in exps), label, "slide"),
                                           level, shift, exps))
        label = load_label(t.pressure, t.deflections, t.motion())
        out.append(TreePlan(path_key((e.id for e in trunk), label, "trunk"), t.pressure,
                            t.motion(), t.deflections, trunk, tuple(branches),
                            design.fractions))
    return out


def experiments(paths: Sequence[PathPlan | TreePlan | RollTreePlan]) -> list[Experiment]:
    """All experiments of a plan, in path order."""
    return [e for path in paths for e in path.experiments]


def parameters(exps: list[Experiment], combined: bool = False,
               rolling: bool = False, trees: bool = False) -> dict[str, np.ndarray]:
    """The load-case parameters the store keeps per experiment: deflection (mm) and
    pressure (MPa); with ``combined`` (a study with combined-load keys) also friction,
    shift_x (mm), shift_y (mm) and tilt (deg), 0 for a vertical case among them; with
    ``rolling`` (issue 30) also slip_ratio and slip_angle (deg), and ``travel`` (mm, issue
    45): how far the road had travelled at the state; with ``trees`` (rolling trees,
    issue 45) also ``roll_from`` (mm): how far the roll went straight before its slips
    applied (:attr:`farm.specs.RoadMotion.roll_from`)."""
    out = {"deflection": np.array([e.deflection for e in exps]),
           "pressure": np.array([e.pressure for e in exps])}
    names = (*(MOTION_PARAMETERS if combined else ()), *(ROLL_PARAMETERS if rolling else ()))
    for name in names:
        out[name] = np.array([getattr(e.motion, name) if e.motion else 0.0 for e in exps])
    if rolling:
        out["travel"] = np.array([e.motion.roll if e.motion else 0.0 for e in exps])
    if trees:
        out["roll_from"] = np.array([e.motion.roll_from if e.motion else 0.0 for e in exps])
    return out
