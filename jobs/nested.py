"""Nested designs that follow load-path trees (issue 29): ``[loads.tree]``.

A combined-load design whose experiments share a ccx run where physics lets them
(:mod:`farm.solve.tree`): trunk parameters (pressure, friction, tilt) are sampled once per
trunk; each trunk rises through its own deflection levels; at each level the road slides
along a few sampled lines, with an experiment at several fractions of each slide::

    [loads.tree]
    method = "lhs"              # or "sobol": each level of the design is such a sample
    seed = 0
    trunks = 8                  # points over the trunk ranges
    pressure_kpa = [80, 200]    # trunk ranges, [low, high] ([x, x] fixes a value)
    friction = [0.3, 1.0]
    tilt_deg = [-4, 4]
    levels = 4                  # deflections per trunk, sampled in deflection_mm
    deflection_mm = [5, 40]
    slides = 4                  # slides per level, their ends sampled in shift_*_mm
    shift_x_mm = [-8, 8]
    shift_y_mm = [-8, 8]
    fractions = [0.25, 0.5, 0.75, 1.0]   # experiments along each slide
    solve = "tree"              # or "rest": the same cases, each from rest (a check)

Experiments: trunks x levels x (1 + slides x fractions): the trunk's own state at each
level (friction and tilt, no slide) and every fraction of every slide. Ids are those of
the same load cases solved from rest (:mod:`jobs.identity`), so a tree and a plain
design share results. Each level is sampled on its own (trunk points by the design
over the trunk ranges; a trunk's levels by a 1-D design seeded by the trunk; a level's
slide ends by a 2-D design seeded by trunk and level): a nested, sliced design.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.stats import qmc

from farm.specs import FRICTION, MAX_PRESSURE_MPA, RISES, SHIFT_MM, TILT_DEG, RoadMotion
from jobs.validate import limits, scalars
from jobs.validate.messages import fail, shown

METHODS = ("lhs", "sobol")
#: key -> (name, scale to internal units, bounds in the file's units)
TRUNK_KEYS = {"pressure_kpa": ("pressure", 1e-3, (0.0, 1000 * MAX_PRESSURE_MPA)),
              "friction": ("friction", 1.0, FRICTION),
              "tilt_deg": ("tilt", 1.0, TILT_DEG)}
BRANCH_KEYS = {"deflection_mm": ("deflection", 1.0, (0.0, None)),
               "shift_x_mm": ("shift_x", 1.0, SHIFT_MM),
               "shift_y_mm": ("shift_y", 1.0, SHIFT_MM)}
KEYS = {"method", "seed", "trunks", "levels", "slides", "fractions", "solve", "rise",
        *TRUNK_KEYS, *BRANCH_KEYS}
#: how a sweep solves the design: as trees, or every case from rest as the plain sweep
#: plans it (one run per slide; to check a tree against, benchmarks/bench_throughput.py)
SOLVE = ("tree", "rest")


@dataclass(frozen=True)
class TreeDesign:
    """A validated ``[loads.tree]``: ranges in internal units (MPa, mm, degrees)."""

    method: str
    seed: int
    trunks: int
    levels: int
    slides: int
    fractions: tuple[float, ...]
    ranges: tuple[tuple[str, float, float], ...]  # (name, low, high), TRUNK/BRANCH names
    solve: str = "tree"  # or "rest" (SOLVE)
    rise: str = "vertical"  # how tilted roads rise (farm.specs.RoadMotion.rise)
    #: slice ``part`` of ``parts`` of a design of trunks x parts trunks: a population's
    #: tyre (``[models] loads = "own"``, :func:`jobs.study.with_own_loads`)
    part: int = 0
    parts: int = 1

    def range(self, name: str) -> tuple[float, float]:
        """(low, high) of ``name``; (0, 0) for an optional trunk key not given."""
        return next(((lo, hi) for n, lo, hi in self.ranges if n == name), (0.0, 0.0))

    @property
    def count(self) -> int:
        """Experiments of the design."""
        return self.trunks * self.levels * (1 + self.slides * len(self.fractions))


@dataclass(frozen=True)
class Slide:
    """One slide of a level: the road's shift at its end, mm."""

    shift_x: float
    shift_y: float


@dataclass(frozen=True)
class TrunkPoint:
    """One trunk of the design: its pressure (MPa), friction, tilt, deflection levels (mm,
    increasing) and each level's slides."""

    pressure: float
    friction: float
    tilt: float
    deflections: tuple[float, ...]
    slides: tuple[tuple[Slide, ...], ...]
    rise: str = "vertical"

    def motion(self, shift: tuple[float, float] = (0.0, 0.0), fraction: float = 1.0
               ) -> RoadMotion | None:
        """The motion of an experiment of this trunk; None for a vertical one."""
        m = RoadMotion(friction=self.friction, tilt=self.tilt,
                       shift_x=_r(shift[0] * fraction), shift_y=_r(shift[1] * fraction),
                       rise=self.rise)
        return None if m.is_identity else m


def _r(x: float) -> float:
    """Rounded as :func:`jobs.expand.cases` rounds a design's values (ids are stable)."""
    return round(float(x), 9) + 0.0


def parse_tree(data: Any, where: str = "loads.tree") -> TreeDesign:
    """Validate a ``[loads.tree]`` table (raises :class:`~jobs.errors.StudyError`)."""
    t = scalars.table(data, where, KEYS, {"trunks", "levels", "slides", "pressure_kpa",
                                          "deflection_mm", "shift_x_mm", "shift_y_mm"})
    method = scalars.choice(t.get("method", "lhs"), f"{where}.method", METHODS)
    seed = scalars.integer(t.get("seed", 0), f"{where}.seed", low=0, high=limits.MAX_SEED)
    trunks, levels, slides = (scalars.integer(t[k], f"{where}.{k}", low=1)
                              for k in ("trunks", "levels", "slides"))
    fractions = _fractions(t.get("fractions", [1.0]), f"{where}.fractions")
    solve = scalars.choice(t.get("solve", "tree"), f"{where}.solve", SOLVE)
    rise = scalars.choice(t.get("rise", "vertical"), f"{where}.rise", RISES)
    ranges = []
    for key, (name, scale, (bottom, top)) in {**TRUNK_KEYS, **BRANCH_KEYS}.items():
        if key not in t:
            continue
        low, high = scalars.interval(t[key], f"{where}.{key}", low=bottom, high=top)
        ranges.append((name, low * scale, high * scale))
    design = TreeDesign(method, seed, trunks, levels, slides, fractions, tuple(ranges), solve,
                        rise)
    if design.range("shift_x") == design.range("shift_y") == (0.0, 0.0):
        raise fail(f"{where}.shift_x_mm", "and shift_y_mm are both fixed at 0: the slides "
                   "would be the trunk's own states; give a range to one of them")
    low, _ = design.range("deflection")
    if low <= 0:
        raise fail(f"{where}.deflection_mm", f"must be > 0 mm, got {shown(t['deflection_mm'])}")
    if design.range("pressure")[0] <= 0:
        raise fail(f"{where}.pressure_kpa", "must be > 0 kPa: a tree's trunk inflates the "
                   f"tyre, got {shown(t['pressure_kpa'])}")
    limits.EXPERIMENTS.check(design.count, where, f"{trunks} trunks x {levels} levels x "
                             f"(1 + {slides} slides x {len(fractions)} fractions)")
    return design


def _fractions(value: Any, where: str) -> tuple[float, ...]:
    if not isinstance(value, list) or not value:
        raise fail(where, f"must be a list of fractions in (0, 1], got {shown(value)}")
    out = tuple(scalars.number(x, where, low=0, high=1, strict=True) for x in value)
    if any(b <= a for a, b in itertools.pairwise(out)) or out[-1] != 1:
        raise fail(where, f"must increase strictly and end at 1, got {shown(value)}")
    return out


def sample(method: str, n: int, lows: list[float], highs: list[float],
            seed: int) -> np.ndarray:
    """n points of a design over [lows, highs], (n, d); a fixed dimension stays fixed."""
    d = len(lows)
    engine = (qmc.LatinHypercube(d=d, seed=seed) if method == "lhs"
              else qmc.Sobol(d=d, scramble=True, seed=seed))
    unit = engine.random(n)
    return np.asarray(lows) + unit * (np.asarray(highs) - np.asarray(lows))


def trunk_points(design: TreeDesign) -> list[TrunkPoint]:
    """The trunks of the design, each with its levels and slides (deterministic)."""
    names = ("pressure", "friction", "tilt")
    box = [design.range(n) for n in names]
    first = design.part * design.trunks  # a population's tyre: its slice of the trunks
    trunks = sample(design.method, design.trunks * design.parts, [b[0] for b in box],
                    [b[1] for b in box], design.seed)[first:first + design.trunks]
    d_low, d_high = design.range("deflection")
    (x_low, x_high), (y_low, y_high) = design.range("shift_x"), design.range("shift_y")
    out = []
    for k, (p, mu, tilt) in enumerate(trunks, start=first):
        # a trunk's levels: a 1-D design of its own, seeded by the study seed and the trunk
        levels = sample(design.method, design.levels, [d_low], [d_high],
                        sub_seed(design.seed, k))[:, 0]
        levels = np.unique(np.round(levels, 9))  # a ramp needs increasing deflections
        slides = tuple(
            tuple(Slide(_r(sx), _r(sy)) for sx, sy in sample(
                design.method, design.slides, [x_low, y_low], [x_high, y_high],
                sub_seed(design.seed, k, j + 1)))
            for j in range(len(levels)))
        out.append(TrunkPoint(round(float(p), 12) + 0.0, _r(mu), _r(tilt),
                              tuple(float(x) + 0.0 for x in levels), slides, design.rise))
    return out


def sub_seed(*parts: int) -> int:
    """A seed for a sub-design: different for each (study seed, trunk, level)."""
    return int(np.random.SeedSequence(list(parts)).generate_state(1)[0])


def cases(design: TreeDesign) -> list[tuple[float, float, RoadMotion | None]]:
    """(deflection mm, pressure MPa, motion or None) of every experiment, trunk by trunk:
    each level's trunk state, then its slides' fractions."""
    out: list[tuple[float, float, RoadMotion | None]] = []
    for t in trunk_points(design):
        for d, slides in zip(t.deflections, t.slides, strict=True):
            out.append((d, t.pressure, t.motion()))
            for s in slides:
                out += [(d, t.pressure, t.motion((s.shift_x, s.shift_y), f))
                        for f in design.fractions]
    return out
