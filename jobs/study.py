"""Study files: a TOML description of a sweep, validated once into frozen values.

A study names a store, a model and its load cases::

    [study]
    name = "thesis-ch5"
    store = "results/thesis.zarr"     # a directory or an fsspec URL
    group = "full-table-3.1"          # optional: default "<kind>-<model hash>"

    [study.adaptive]                  # optional: rounds chosen by a surrogate, after
    rounds = 4                        #   the [loads.sample] design (jobs/adaptive/,
    batch = 4                         #   jobs/validate/adaptive.py)

    [study.storage_options]           # optional, URL stores only: fsspec options
    endpoint_url = "http://minio:9000" # (s3fs: endpoint_url, anon, client_kwargs, ...)

    [model]                           # as farm.specs.ModelSpec; units mm, MPa
    kind = "full"
    materials = "table-3.1"           # a preset, or a table per region
    [model.mesh]
    circumferential = 40

    [loads]                           # a grid: every pressure x every deflection
    pressure_kpa = [200]
    deflection_mm = { start = 10, stop = 40, step = 5 }

    # or, instead of the grid, a design over ranges (scipy.stats.qmc)
    # [loads.sample]
    # method = "lhs"                  # or "sobol"
    # n = 16
    # seed = 0
    # deflection_mm = [10, 40]
    # pressure_kpa = [80, 200]
    # friction = [0.3, 1.0]           # combined loads (road = "contact"), also as lists
    # shift_x_mm = [-5, 5]            #   in [loads]: Coulomb mu, the road's slide along
    # shift_y_mm = [-5, 5]            #   x and y after the deflection (mm), its tilt
    # tilt_deg = [-4, 4]              #   about x (degrees): docs/combined-loads.md

    # a rolling study (issue 30; slip_ratio / slip_angle_deg as lists or ranges)
    # [loads.roll]
    # distance_mm = 150               # road travel of every roll
    # rolling_radius_mm = "free"      # or mm, or "estimate" (no search: R - 0.59 d)
    # states = 1                      # states kept along each roll (issue 45)
    # branch_from_mm = 0              # > 0: rolling trees (straight trunk, then branches)
    # friction_from = "touch"         # or "roll": rise without friction (group "...-rise")
    # lead_sigma_mm = 0               # > 0: each roll led by -sigma tan(alpha) (group "...-lead")
    # lead_sigma_x_mm = 0             # > 0: each roll led along x by sigma kappa (group "...-lead")
    # [loads.roll.branches]           # optional: slips sampled per trunk, not listed
    # n = 20                          #   branches of every trunk (each case of [loads])
    # slip_ratio = [-0.1, 0.1]        #   ranges; method = "lhs" | "sobol", seed
    # slip_angle_deg = [-4, 4]

    # or a nested design solved as load-path trees (jobs/nested.py, issue 29)
    # [loads.tree]
    # trunks = 8                      # pressure, friction, tilt: once per trunk
    # levels = 4                      # deflections each trunk rises through
    # slides = 4                      # slides from each level's saved state

    [solver]                          # optional, as farm.specs.SolverSettings
    timeout_s = 1800
    max_path_length = 0               # split load paths longer than this (0: never)
    # grow_after = 4                  # ccx's IG on frictional paths (issue 45)
    # restart_every_mm = 0            # rolls: a restart point every so many mm (0: none)

    [models]                          # optional: a design over [model]'s fields
    method = "sobol"                  # grid | lhs | sobol | morris (jobs/design.py)
    n = 8
    [models.parameters]
    "materials.tread.youngs_modulus" = [2.0, 12.0]

Every key is checked: an unknown key, a wrong type or an out-of-range value is one
:class:`~jobs.errors.StudyError` naming the key, the value given and what is allowed.
Storage options reach every storage call of the client and of the workers: the study's
``store`` is then the zarr store opened with them, which Dask pickles into each task,
options included. Credentials are refused there (:data:`jobs.validate.locations.SECRET_OPTIONS`):
they stay in the environment of the client and the workers (``AWS_ACCESS_KEY_ID``...).
The study's experiment count is computed from its lists before anything is expanded and
is at most :data:`jobs.validate.limits.EXPERIMENTS` (docs/limits.md); with ``[models]`` the
design's model count times the load cases counts. Every model of a design is made and
checked (fields, mesh size, the loads it must take) when the study is loaded.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from collections.abc import Set as AbstractSet
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import storage
from farm.errors import SpecError
from farm.specs import (
    FRICTION,
    FRICTION_FROM,
    LEAD_RAMP_MM,
    MAX_BRANCH_MM,
    MAX_PRESSURE_MPA,
    RISES,
    ROLL_MM,
    ROLLING_RADIUS_MM,
    SHIFT_MM,
    SLIP_ANGLE_DEG,
    SLIP_RATIO,
    TILT_DEG,
    LoadPath,
    ModelSpec,
    RoadMotion,
    SolverSettings,
)
from jobs.design import ModelsSpec, design, parse_models
from jobs.errors import StudyError
from jobs.identity import model_hash
from jobs.nested import METHODS, TreeDesign, parse_tree, sub_seed
from jobs.validate import limits, lists, locations, reading, scalars, spec_tables
from jobs.validate.adaptive import AdaptiveSpec, check_loads, parse_adaptive
from jobs.validate.messages import fail, located, shown
from storage.paths import describe

SAMPLING_METHODS = ("lhs", "sobol")
#: Combined-load keys of a study file -> (store parameter = RoadMotion field, bounds).
#: The bounds are RoadMotion's own (farm.specs), so a study is refused at the boundary
#: for exactly what the physics layer would refuse (docs/combined-loads.md).
MOTION_KEYS = {
    "friction": ("friction", FRICTION),
    "shift_x_mm": ("shift_x", SHIFT_MM),
    "shift_y_mm": ("shift_y", SHIFT_MM),
    "tilt_deg": ("tilt", TILT_DEG),
}
#: The store's names of the combined-load parameters (RoadMotion's fields), in order.
MOTION_PARAMETERS = tuple(name for name, _ in MOTION_KEYS.values())
#: Keys of a rolling study (issue 30; listed in [loads] or sampled): RoadMotion's fields
ROLL_KEYS = {
    "slip_ratio": ("slip_ratio", SLIP_RATIO),
    "slip_angle_deg": ("slip_angle", SLIP_ANGLE_DEG),
}
ROLL_PARAMETERS = tuple(name for name, _ in ROLL_KEYS.values())
#: Every key of a load case beyond deflection and pressure, in design order
CASE_KEYS = {**MOTION_KEYS, **ROLL_KEYS}
CASE_PARAMETERS = (*MOTION_PARAMETERS, *ROLL_PARAMETERS)
LOAD_KEYS = {"pressure_kpa", "deflection_mm", "sample", "tree", "rise", "roll", *CASE_KEYS}
#: [loads.roll]: the road travel of every roll (mm), the free-rolling radius, how many
#: states along each roll are stored experiments and where rolling trees branch (issue 45)
#: rolling_radius_mm's words: a search per case, or the estimate from the inflated radius
RADIUS_WORDS = ("free", "estimate")
ROLL_DEFAULTS = {"distance_mm": 150.0, "rolling_radius_mm": "free", "states": 1,
                 "branch_from_mm": 0.0, "friction_from": "touch", "lead_sigma_mm": 0.0,
                 "lead_sigma_x_mm": 0.0}
#: The largest sigma a lead is taken from, mm (measured: the flat lead's 0.67 m on the
#: thesis wall and about 0.55 m on `lean`, docs/rolling.md "A steady roll"; a
#: revolution is about 2.5 m)
MAX_LEAD_SIGMA_MM = 5000.0
#: The most states one roll may keep (a 2000 mm roll's are then 10 mm apart)
MAX_ROLL_STATES = 200

#: [loads.roll.branches]: a design of slips per trunk (issue 45/46: nested rolling trees)
BRANCH_KEYS = {"n", "method", "seed", "slip_ratio", "slip_angle_deg"}


@dataclass(frozen=True)
class RollBranches:
    """``[loads.roll.branches]``: each trunk of a rolling tree study (each case of the
    grid or sample in ``[loads]``) gets ``n`` branches, their slips sampled over
    ``ranges`` ((name, low, high): slip_ratio, slip_angle in degrees) by a design of
    their own, seeded by ``seed`` and the trunk (a nested, sliced design, as
    :mod:`jobs.nested` makes for the static trees)."""

    n: int
    method: str
    seed: int
    ranges: tuple[tuple[str, float, float], ...]


@dataclass(frozen=True)
class Rolling:
    """``[loads.roll]`` of a rolling study: how far every roll goes (mm), the
    free-rolling radius (mm; None: found for each experiment) and ``states``: how many
    states along each roll are experiments of their own, evenly spaced in travel, the
    last at the roll's end (issue 45: a roll is a load path; 1 keeps the end alone).

    ``branch_from`` (mm, issue 45: rolling trees, :mod:`jobs.rolling_trees`): the cases
    that share pressure, deflection, friction and camber roll straight at kappa = 0 in
    one trunk for this far, and each case's slips apply from there on, in a branch
    continued from the trunk's end; 0: every case rolls from rest at its slips."""

    distance: float = 150.0
    rolling_radius: float | None = None
    states: int = 1
    branch_from: float = 0.0
    branches: RollBranches | None = None  # [loads.roll.branches]: slips per trunk
    radius_estimate: bool = False  # rolling_radius_mm = "estimate" (issue 46)
    friction_from: str = "touch"  # "roll": a frictionless rise (RoadMotion.friction_from)
    #: mm, > 0: every roll led by -lead_sigma tan(alpha) (RoadMotion.lead, a steady roll)
    lead_sigma: float = 0.0
    #: mm, > 0: every roll led along x by lead_sigma_x kappa (RoadMotion.lead_x)
    lead_sigma_x: float = 0.0

    @property
    def leads(self) -> bool:
        """Whether the rolls are led (a lateral or a longitudinal lead)."""
        return self.lead_sigma > 0 or self.lead_sigma_x > 0

    def lead_x(self, slip_ratio: float) -> float:
        """The longitudinal lead (mm) of a roll at ``slip_ratio``, sigma_x kappa: the
        carcass's steady longitudinal deflection in the stretched-string model, whose
        length sigma_x = C_kappa / c_x is the tyre's own (about 540 mm on ``lean`` at 200
        kPa, 15 mm). The linear part only: the flat lead is the steady Fx over about 520
        N/mm, so it saturates with the force, and kappa counts from the rolled radius, so
        an estimated radius's own offset from free rolling is not led (docs/rolling.md,
        "A longitudinal lead"). 0 without ``lead_sigma_x``."""
        return round(self.lead_sigma_x * slip_ratio, 6) + 0.0

    def lead(self, slip_angle: float) -> float:
        """The lead (mm) of a roll at ``slip_angle`` degrees, -sigma tan(alpha): about the
        carcass's steady deflection in the stretched-string model; the sigma that starts a
        roll at its steady force is the tyre's own, found by two bracketing leads
        (docs/rolling.md, "A steady roll"). The linear part only: the flat lead is the
        steady force over the carcass's lateral stiffness (on ``lean`` 4.8, 7.3 and 10.0
        mm at 0.5, 1 and 2 degrees), so it saturates with the force. 0 without
        ``lead_sigma``."""
        return round(-self.lead_sigma * math.tan(math.radians(slip_angle)), 6) + 0.0

    def case_fields(self, slips: Mapping[str, Any]) -> dict[str, Any]:
        """What a case with ``slips`` (its ``slip_angle`` and ``slip_ratio``, 0 where
        absent) takes of the roll: :attr:`motion_fields` and its leads, where set."""
        fields = dict(self.motion_fields)
        if self.lead_sigma:  # a steady roll (RoadMotion.lead)
            fields["lead"] = self.lead(slips.get("slip_angle", 0.0))
        if self.lead_sigma_x:  # RoadMotion.lead_x
            fields["lead_x"] = self.lead_x(slips.get("slip_ratio", 0.0))
        return fields

    @property
    def motion_fields(self) -> dict[str, Any]:
        """What every case's :class:`~farm.specs.RoadMotion` takes of the roll."""
        return {"roll": self.distance, "rolling_radius": self.rolling_radius,
                "radius_estimate": self.radius_estimate, "friction_from": self.friction_from}

    @property
    def travels(self) -> tuple[float, ...]:
        """Road travel (mm) of each stored state, increasing, the last ``distance``."""
        return tuple(round(self.distance * k / self.states, 9)
                     for k in range(1, self.states + 1))

MAX_KPA = 1000 * MAX_PRESSURE_MPA


@dataclass(frozen=True)
class Sampling:
    """A quasi-random design over load ranges (``scipy.stats.qmc``)."""

    method: str
    n: int
    seed: int
    ranges: tuple[tuple[str, float, float], ...]  # (parameter, low, high), internal units
    #: design points added to the sampled ones, in ``ranges`` order and internal units:
    #: the points an adaptive study's rounds chose (jobs.adaptive), none in a study file
    points: tuple[tuple[float, ...], ...] = ()
    #: slice ``part`` of ``parts`` of a design of n x parts points: a population's tyre
    #: (``[models] loads = "own"``, :func:`with_own_loads`); 0 of 1: the whole design
    part: int = 0
    parts: int = 1


@dataclass(frozen=True)
class Study:
    """A validated study: where results go, which model, which load cases, how to solve.

    Pressures are in MPa and deflections in mm (the file says kPa and mm). ``store`` is
    what every storage call gets: the location as text, or, with ``storage_options``,
    the zarr store opened with them (picklable: each Dask task gets a copy, options
    included); :attr:`location` is the text either way.
    """

    name: str
    store: storage.StoreLike
    group: str | None
    model: ModelSpec
    pressures: tuple[float, ...]
    deflections: tuple[float, ...]
    sampling: Sampling | None
    settings: SolverSettings
    max_path_length: int
    retry_smaller_increments: bool
    source: str
    storage_options: dict[str, Any] | None = field(default=None, hash=False)
    models: ModelsSpec | None = None  # a design over model fields (jobs.design)
    # combined loads: (parameter, listed values) of the motion keys listed in [loads]
    motions: tuple[tuple[str, tuple[float, ...]], ...] = ()
    adaptive: AdaptiveSpec | None = None  # [study.adaptive]: rounds chosen by a surrogate
    tree: TreeDesign | None = None  # [loads.tree]: a nested design solved as trees
    rise: str = "vertical"  # how tilted roads rise (farm.specs.RoadMotion.rise)
    rolling: Rolling | None = None  # rolling cases (issue 30): [loads.roll] or slip keys

    @property
    def combined(self) -> bool:
        """Whether the study gives combined-load keys (listed or sampled): its group then
        holds the parameters friction, shift_x, shift_y, tilt and the combined variables."""
        sampled = {name for name, _, _ in self.sampling.ranges} if self.sampling else set()
        return (bool(self.motions) or bool(sampled & set(CASE_PARAMETERS))
                or self.tree is not None or self.rolling is not None)

    @property
    def location(self) -> str:
        """Where the store is, as text (a path or URL), for messages and reports."""
        if isinstance(self.store, str | os.PathLike):
            return os.fspath(self.store)
        return describe(self.store)

    @property
    def group_name(self) -> str:
        """The group the study writes to: given, else one per model (kind + spec hash).

        A study with ``[models]`` writes one group per model of its design
        (:func:`jobs.design.model_design`); this is then its base model's group. Rolls
        risen without friction (``[loads.roll] friction_from = "roll"``) are a load
        history the store's parameters do not show: a group of their own (``-rise``), as
        are rolls led to their steady deflection (``lead_sigma_mm``, ``lead_sigma_x_mm``:
        ``-lead``)."""
        rise = self.rolling is not None and self.rolling.friction_from == "roll"
        lead = self.rolling is not None and self.rolling.leads
        return self.group or (f"{self.model.kind}-{self.model_hash()[:10]}"
                              + ("-rise" if rise else "") + ("-lead" if lead else ""))

    def model_hash(self) -> str:
        return model_hash(self.model)


def _sampling(data: Any, where: str) -> Sampling:
    t = scalars.table(data, where, {"method", "n", "seed", "deflection_mm", "pressure_kpa",
                                    *CASE_KEYS}, {"method", "n"})
    method = scalars.choice(t["method"], f"{where}.method", SAMPLING_METHODS)
    n = scalars.integer(t["n"], f"{where}.n", low=1)
    limits.EXPERIMENTS.check(n, f"{where}.n", f"a design of n = {n} points")
    seed = scalars.integer(t.get("seed", 0), f"{where}.seed", low=0, high=limits.MAX_SEED)
    ranges = []
    # the order of the design's dimensions: deflection, pressure as ever (a vertical
    # study draws the points it drew before), then the motion's fields
    for key, name, scale, bottom, top in (
            ("deflection_mm", "deflection", 1.0, 0, None),
            ("pressure_kpa", "pressure", 1e-3, 0, MAX_KPA),
            *((k, name, 1.0, *bounds) for k, (name, bounds) in CASE_KEYS.items())):
        if key in t:
            r = t[key]
            if not (isinstance(r, list) and len(r) == 2):
                raise fail(f"{where}.{key}", f"must be [low, high], got {shown(r)}")
            low, high = (scalars.number(x, f"{where}.{key}", low=bottom, high=top) for x in r)
            if not low < high:
                raise fail(f"{where}.{key}", f"needs low < high, got {shown(r)}")
            ranges.append((name, low * scale, high * scale))
    if not ranges:
        raise fail(where, "give a range for deflection_mm, pressure_kpa or a combined-load "
                   f"key ({', '.join(CASE_KEYS)})")
    return Sampling(method, n, seed, tuple(ranges))


def _tree(data: Any, model: ModelSpec) -> TreeDesign:
    """``[loads.tree]``, alone in ``[loads]`` (jobs/nested.py)."""
    t = scalars.table(data, "loads", LOAD_KEYS)
    other = sorted(k for k in t if k != "tree")
    if other:
        raise fail(f"loads.{other[0]}", "a study with [loads.tree] gives every load there "
                   "(its ranges); drop this key or the tree")
    if model.road != "contact" or not model.inflated:
        raise fail("loads.tree", "load-path trees need the inflated full model with the "
                   f"contact road, the model is {shown(model.kind)} with road = "
                   f"{shown(model.road)}")
    return parse_tree(t["tree"])


def _loads(data: Any, model: ModelSpec):
    t = scalars.table(data, "loads", LOAD_KEYS)
    sampling = _sampling(t["sample"], "loads.sample") if "sample" in t else None
    sampled = {name for name, _, _ in sampling.ranges} if sampling else set()
    names = {"pressure_kpa": "pressure", "deflection_mm": "deflection",
             **{k: name for k, (name, _) in CASE_KEYS.items()}}
    clash = sorted(k for k in names if k in t and names[k] in sampled)
    if clash:
        raise fail(f"loads.{clash[0]}", "is both sampled and listed; give it in one place")
    motions = tuple((name, lists.values(t[key], f"loads.{key}", low=bounds[0], high=bounds[1]))
                    for key, (name, bounds) in CASE_KEYS.items() if key in t)
    if (motions or sampled & set(CASE_PARAMETERS)) and model.road != "contact":
        key = next(k for k, (name, _) in CASE_KEYS.items()
                   if k in t or name in sampled)
        where = f"loads.{key}" if key in t else f"loads.sample.{key}"
        raise fail(where, f"combined loads need the contact road (model.road = "
                   f"\"contact\"), the model has road = {shown(model.road)}")
    # an inflated model needs a pressure > 0; the reduced one takes 0 (checked later)
    pressures = (tuple(p / 1000 for p in lists.values(t["pressure_kpa"], "loads.pressure_kpa",
                                                      low=0, high=MAX_KPA, strict=model.inflated))
                 if "pressure_kpa" in t else None)
    deflections = (lists.values(t["deflection_mm"], "loads.deflection_mm", low=0, strict=True)
                   if "deflection_mm" in t else ())
    if not deflections and "deflection" not in sampled:
        raise fail("loads.deflection_mm", "is required (a list, a {start, stop, step} range, "
                   "or a range in [loads.sample])")
    if pressures is None and "pressure" not in sampled:
        if model.inflated:
            raise fail("loads.pressure_kpa", "is required for the inflated full model")
        pressures = (0.0,)
    pressures = pressures or ()
    given = {name for name, _ in motions} | sampled
    rolling = (_rolling(t.get("roll", {}), given, model, sampled)
               if "roll" in t or given & set(ROLL_PARAMETERS) else None)
    _check_count(pressures, deflections, sampling, motions=motions,
                 states=rolling.states if rolling else 1,
                 branches=rolling.branches.n if rolling and rolling.branches else 1)
    return pressures, deflections, sampling, motions, _rise(t, "loads"), rolling


def _rolling(data: Any, given: set[str], model: ModelSpec,
             sampled: AbstractSet[str] = frozenset()) -> Rolling:
    """``[loads.roll]`` (optional where a slip key is given: its defaults)."""
    t = scalars.table(data, "loads.roll", {*ROLL_DEFAULTS, "branches"})
    shifts = sorted(given & {"shift_x", "shift_y"})
    if shifts:
        raise fail(f"loads.{shifts[0]}_mm", "a rolling study rolls the tyre instead of "
                   "sliding the road: drop the shift or the roll")
    if model.road != "contact" or not model.inflated:
        raise fail("loads.roll", "rolling needs the inflated full model with the contact "
                   f"road, the model is {shown(model.kind)} with road = {shown(model.road)}")
    low, high = ROLL_MM
    distance = scalars.number(t.get("distance_mm", ROLL_DEFAULTS["distance_mm"]),
                              "loads.roll.distance_mm", low=low, high=high)
    radius = t.get("rolling_radius_mm", "free")
    if isinstance(radius, str) and radius not in RADIUS_WORDS:
        raise fail("loads.roll.rolling_radius_mm", "must be a radius in mm, \"free\" (a "
                   "search) or \"estimate\" (from the inflated radius, no search), got "
                   f"{shown(radius)}")
    if radius not in RADIUS_WORDS:
        low, high = ROLLING_RADIUS_MM
        radius = scalars.number(radius, "loads.roll.rolling_radius_mm", low=low, high=high)
    states = scalars.integer(t.get("states", ROLL_DEFAULTS["states"]), "loads.roll.states",
                             low=1, high=MAX_ROLL_STATES)
    if distance / states < ROLL_MM[0]:
        raise fail("loads.roll.states", f"{states} states of a {distance:g} mm roll lie "
                   f"closer than {ROLL_MM[0]:g} mm: keep at most {int(distance // ROLL_MM[0])}")
    branch_from = _branch_from(t, distance)
    branches = (_branches(t["branches"], branch_from, given, sampled) if "branches" in t
                else None)
    friction_from = scalars.choice(t.get("friction_from", "touch"),
                                   "loads.roll.friction_from", FRICTION_FROM)
    return Rolling(float(distance), None if radius in RADIUS_WORDS else float(radius),
                   states, branch_from, branches, radius_estimate=radius == "estimate",
                   friction_from=friction_from,
                   lead_sigma=_lead_sigma(t, distance / states, branch_from, "lead_sigma_mm"),
                   lead_sigma_x=_lead_sigma(t, distance / states, branch_from,
                                            "lead_sigma_x_mm"))


def _lead_sigma(t: dict, first: float, branch_from: float, key: str) -> float:
    """``[loads.roll] lead_sigma_mm`` or ``lead_sigma_x_mm``: the relaxation length the
    rolls' lateral or longitudinal leads take. ``first``: the travel of a roll's first
    kept state (mm), which must lie past the lead's ramp: a state is the roll of its own
    travel, and a roll within the ramp has no whole lead (``RoadMotion`` refuses it)."""
    where = f"loads.roll.{key}"
    sigma = float(scalars.number(t.get(key, 0.0), where, low=0.0, high=MAX_LEAD_SIGMA_MM))
    if sigma and branch_from:
        raise fail(where, "leads rolls from rest, and branch_from_mm makes rolling trees "
                   "whose branches roll on from their trunk: drop one")
    if sigma and first <= LEAD_RAMP_MM:
        raise fail(where, f"a lead is eased in over a roll's first {LEAD_RAMP_MM:g} mm and "
                   f"the first kept state lies at {first:g} mm (distance_mm / states): roll "
                   "further or keep fewer states")
    return sigma


def _branches(data: Any, branch_from: float, given: set[str],
              sampled: AbstractSet[str]) -> RollBranches:
    """``[loads.roll.branches]``: the slips of each trunk's branches, sampled."""
    where = "loads.roll.branches"
    t = scalars.table(data, where, BRANCH_KEYS, {"n"})
    if not branch_from:
        raise fail(where, "needs [loads.roll] branch_from_mm > 0: branches leave a trunk")
    slips = sorted(given & set(ROLL_PARAMETERS))
    if slips:
        key = next(k for k, (name, _) in ROLL_KEYS.items() if name == slips[0])
        place = "loads.sample" if slips[0] in sampled else "loads"
        raise fail(f"{place}.{key}", f"comes from [{where}] in a study that has it: drop one")
    n = scalars.integer(t["n"], f"{where}.n", low=1, high=limits.EXPERIMENTS.value())
    method = scalars.choice(t.get("method", "lhs"), f"{where}.method", METHODS)
    seed = scalars.integer(t.get("seed", 0), f"{where}.seed", low=0, high=limits.MAX_SEED)
    ranges = []
    for key, (name, (bottom, top)) in ROLL_KEYS.items():
        if key not in t:
            continue
        ranges.append((name, *scalars.interval(t[key], f"{where}.{key}", low=bottom,
                                               high=top)))
    if not ranges:
        raise fail(where, "gives no slip_ratio or slip_angle_deg range: the branches "
                   "would all be the trunk's straight roll")
    return RollBranches(n, method, seed, tuple(ranges))


def _branch_from(t: dict, distance: float) -> float:
    """``[loads.roll] branch_from_mm``: where a rolling tree's branches leave its trunk."""
    where = "loads.roll.branch_from_mm"
    value = scalars.number(t.get("branch_from_mm", 0.0), where, low=0.0, high=distance)
    if value >= distance:
        raise fail(where, f"must lie below distance_mm = {distance:g}: the branches roll "
                   f"on from the trunk's end, got {value:g}")
    if value and distance - value > MAX_BRANCH_MM:
        raise fail(where, f"leaves branches of {distance - value:g} mm; a branch rolls at "
                   f"most {MAX_BRANCH_MM:g} mm: give at least {distance - MAX_BRANCH_MM:g}")
    return float(value)


def _rise(t: dict, where: str) -> str:
    """``rise`` (farm.specs.RoadMotion.rise): how a tilted road is pushed up."""
    return scalars.choice(t.get("rise", "vertical"), f"{where}.rise", RISES)


def _check_count(pressures: tuple, deflections: tuple, sampling: Sampling | None,
                 models: ModelsSpec | None = None, motions: tuple = (),
                 states: int = 1, branches: int = 1) -> None:
    """At most :data:`jobs.validate.limits.EXPERIMENTS` experiments, counted as
    :func:`jobs.expand.load_cases` will make them: the grid, or each design point with
    every listed value of the loads it does not sample; times the ``states`` each roll
    keeps."""
    sampled = {name for name, _, _ in sampling.ranges} if sampling else set()
    factors = [(f"a design of {sampling.n} points", sampling.n)] if sampling else []
    factors += [(f"{len(values)} {name}{'s' * (len(values) != 1)}", len(values))
                for name, values in (("pressure", pressures), ("deflection", deflections),
                                     *motions)
                if name not in sampled and values]
    if models is not None:
        factors.insert(0, (f"{models.rows} models ({models.method} design)", models.rows))
    if branches > 1:
        factors.append((f"{branches} branches per trunk", branches))
    if states > 1:
        factors.append((f"{states} states per roll", states))
    count = 1
    for _, n in factors:
        count *= n
    limits.EXPERIMENTS.check(count, "models" if models else "loads",
                             " x ".join(text for text, _ in factors))


def parse_study(text: str, source: str = "<study>") -> Study:
    """Validate the TOML text of a study (raises :class:`StudyError`)."""
    data = reading.parse_toml(text, source)
    with located(source):
        scalars.table(data, "study file", {"study", "model", "loads", "solver", "models"},
                      {"study", "model", "loads"})
        head = scalars.table(data["study"], "study",
                             {"name", "store", "group", "storage_options", "adaptive"},
                             {"store"})
        store = scalars.string(head["store"], "study.store", "a path or URL string", blank=False)
        locations.store_location(store, "study.store")  # checked here, resolved by load_study
        options = (locations.storage_options(head["storage_options"], "study.storage_options",
                                             store)
                   if "storage_options" in head else None)
        group = head.get("group")
        if group is not None:
            scalars.identifier(group, "study.group")
        name = scalars.string(head.get("name", Path(source).stem), "study.name")
        model = spec_tables.model(data["model"])
        tree = (_tree(data["loads"], model)
                if isinstance(data["loads"], dict) and "tree" in data["loads"] else None)
        pressures, deflections, sampling, motions, rise, rolling = (
            ((), (), None, (), tree.rise, None) if tree else _loads(data["loads"], model))
        solver = spec_tables.solver(data.get("solver", {}))
        models = None
        if "models" in data:
            if group is not None:
                raise fail("study.group", "a study with [models] writes one group per model "
                           "(<kind>-<model hash>): drop study.group")
            models = parse_models(data["models"], model)
            if tree is not None:
                limits.EXPERIMENTS.check(models.rows * tree.count, "models",
                                         f"{models.rows} models x {tree.count} tree "
                                         "experiments")
            else:
                _check_count(pressures, deflections, sampling, models, motions)
        if tree is not None and "adaptive" in head:
            raise fail("study.adaptive", "an adaptive study adds points to [loads.sample]; "
                       "a [loads.tree] design has none: drop one of them")
        adaptive = (_adaptive(head["adaptive"], pressures, deflections, sampling, motions,
                              models is not None) if "adaptive" in head else None)
        study = Study(name, store, group, model, pressures, deflections, sampling,
                      solver.settings, solver.max_path_length, solver.retry_smaller_increments,
                      source, options, models, motions, adaptive, tree, rise, rolling)
        _check_loads(study)
        if models is not None:
            _check_models(study)
        return with_storage_options(study) if options else study


def _adaptive(data: Any, pressures: tuple, deflections: tuple, sampling: Sampling | None,
              motions: tuple, models: bool) -> AdaptiveSpec:
    spec = parse_adaptive(data)
    listed = {"pressure_kpa": pressures, "deflection_mm": deflections,
              **{key: dict(motions).get(name, ()) for key, (name, _) in CASE_KEYS.items()}}
    sampled = tuple(name for name, _, _ in sampling.ranges) if sampling else ()
    check_loads(spec, sampled, listed, sampling.n if sampling else 0, models)
    return spec


def with_storage_options(study: Study) -> Study:
    """The study whose ``store`` is its URL opened with its storage options (no I/O)."""
    try:
        opened = storage.open_store(study.location, storage_options=study.storage_options)
    except storage.StoreError as e:
        raise fail("study.storage_options", str(e)) from e
    return replace(study, store=opened)


def _check_loads(study: Study) -> None:
    """Load cases the model cannot take are rejected before anything runs."""
    ranges = {name: (low, high) for name, low, high in (study.sampling.ranges
                                                          if study.sampling else ())}
    if study.tree is not None:
        ranges = {name: (low, high) for name, low, high in study.tree.ranges}
    sampled = ranges.get("deflection")
    top = max([*study.deflections, sampled[1] if sampled else 0])
    lows = [*study.deflections, *([sampled[0]] if sampled and sampled[0] > 0 else [])]
    low = min(lows, default=top)
    # the steepest tilt raises the road's edge most (LoadPath.check_against)
    tilts = [*dict(study.motions).get("tilt", ()), *ranges.get("tilt", ())]
    steepest = max((abs(t) for t in tilts), default=0.0)
    motion = RoadMotion(tilt=steepest) if steepest else None
    for p in [*study.pressures, *ranges.get("pressure", ())]:
        try:
            LoadPath(tuple(sorted({low, top})), p, motion).check_against(study.model)
            if study.rolling is not None:  # one deflection a roll; the highest, tilted
                roll = RoadMotion(tilt=steepest, roll=study.rolling.distance,
                                  rolling_radius=study.rolling.rolling_radius)
                LoadPath((top,), p, roll).check_against(study.model)
        except SpecError as e:
            raise StudyError(f"loads: {e}") from e


def _check_models(study: Study) -> None:
    """Make every model of the design (each checked by ``override_model``) and check the
    loads against each: a thinner tread or a lower section takes less deflection."""
    # load histories the store's parameters do not show have groups of their own
    # (Study.group_name), and [models] writes one group per model, which would mix them
    rolling = study.rolling
    for key, what, given in (("friction_from", "rolls risen without friction",
                              rolling is not None and rolling.friction_from == "roll"),
                             ("lead_sigma_mm", "led rolls",
                              rolling is not None and rolling.lead_sigma > 0),
                             ("lead_sigma_x_mm", "led rolls",
                              rolling is not None and rolling.lead_sigma_x > 0)):
        if given:
            raise fail(f"loads.roll.{key}", f"a study with [models] writes one group per "
                       f"model, which would mix {what} with others: give it a study of its "
                       "own without [models]")
    own = study.models is not None and study.models.loads == "own"
    if own and study.tree is None and study.sampling is None:
        raise fail("models.loads", "'own' gives each model its slice of a sampled load "
                   "design, and these loads are listed: give [loads.sample] or "
                   "[loads.tree], or drop models.loads")
    d = design(study.model, study.models)
    first: dict[ModelSpec, int] = {}  # each distinct model and its first row
    for k, model in enumerate(d.models):
        first.setdefault(model, k)
    for model, k in first.items():
        try:
            _check_loads(replace(study, model=model))
        except StudyError as e:
            row = ", ".join(f'"{name}" = {x:g}' for name, x in zip(d.names, d.matrix[k],
                                                                    strict=True))
            raise StudyError(f"models: row {k} of the {d.method} design ({row}) cannot "
                             f"take the loads: {e}") from e


def with_own_loads(study: Study, row: int, rows: int) -> Study:
    """``study`` for the ``row``-th of ``rows`` models of a ``loads = "own"`` design
    (issue 47): its slice of one sampled design of ``rows`` times the points (a tree's
    trunks, a sample's points), so that the population's tyres share no load case and
    together cover the ranges as one design does; a rolling tree's slips re-seeded by
    the row. Deterministic, so a resumed sweep plans the same experiments."""
    tree = replace(study.tree, part=row, parts=rows) if study.tree else None
    sampling = replace(study.sampling, part=row, parts=rows) if study.sampling else None
    rolling = study.rolling
    if rolling is not None and rolling.branches is not None:
        rolling = replace(rolling, branches=replace(
            rolling.branches, seed=sub_seed(rolling.branches.seed, 47, row)))
    return replace(study, tree=tree, sampling=sampling, rolling=rolling)


def load_study(path: str | Path) -> Study:
    """Read and validate a study file; a relative store path is taken from the current
    directory, like any path given on the command line."""
    path = Path(path)
    study = parse_study(reading.read_text(path), str(path))
    if not isinstance(study.store, str):  # a URL opened with its options: nothing to resolve
        return study
    with located(str(path)):
        return replace(study, store=locations.store_location(study.store, "study.store"))
