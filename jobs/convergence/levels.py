"""Refinement levels and load cases of the mesh-convergence study (issue 24).

The levels refine the full model where the answers come from: the circumference in a
``+-32`` degree window about the road (the contact patch, ~20 degrees long at 40 mm, and
T2Cam's 40 degree field of view, thesis §2.2) and the tread across its width. Each level
halves both the window's element angle (4, 2, 1 degrees) and the tread's meridional
elements' size (6, 12, 24 elements), so the refinement ratio is 2 and three levels give a
Richardson estimate of the remaining error; the sidewall and bead keep the thesis'
counts (5 and 2 per side). ``uniform-40`` is today's default full mesh (Table 3.1's 880
elements), solved beside them for comparison, not part of the extrapolation.

Cases: vertical 10-40 mm at 80 and 200 kPa (the thesis' pressures, §3.4), a lateral
slide with friction (mu 0.8, 3 mm at 20 mm, 200 kPa) and a tilted road (camber 3
degrees, mu 0.5, 20 mm, 200 kPa). ``QUICK`` levels and cases are a test-sized version.

*Directions* (issue 44): the levels above refine the window and the tread together and
keep the thesis' wall (5 sidewall and 2 bead elements per side, one through the wall).
:func:`direction_levels` refines a base mesh (``patch`` by default) in ONE direction at
a time - ``circumferential`` (the window's elements), ``tread``, ``sidewall``, ``bead``,
``through`` (the wall's layers, which also puts the belt cords at their depth,
:mod:`farm.ccx.belt_cords`) - or in all of them ``together``, by factors of 2, so that
each direction gets its own change, observed order and Richardson estimate. Their cases
(:data:`POINT_CASES`) are the vertical points the calibration is judged at (thesis
§3.4, Fig. 3.3).

``ROLL_CASES`` (issue 30, solved on request: ``farm converge --case roll-150mm``) ask
whether the criterion still holds once the tyre rolls: a windowed mesh's roll starts
with its window ahead of the road and ends with it centred under the contact
(:func:`farm.solve.rolling.start_spin`). The rim's spin is prescribed with one nominal
radius on every level, so every level gets the same motion and Fx is a response, not
a search's residual.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

from farm.errors import SpecError
from farm.spacing import half_steps
from farm.specs import MAX_THROUGH, LoadPath, MeshDensity, RoadMotion


@dataclass(frozen=True)
class Level:
    """A named mesh; ``ratio`` is its refinement relative to the previous level of the
    extrapolated sequence (0: not in the sequence)."""

    name: str
    mesh: MeshDensity
    ratio: float = 2.0


@dataclass(frozen=True)
class Case:
    """A named load path of the full model; ``deflections`` in mm, ``pressure_kpa``."""

    name: str
    pressure_kpa: float
    deflections: tuple[float, ...]
    motion: RoadMotion | None = None

    def path(self) -> LoadPath:
        return LoadPath(self.deflections, self.pressure_kpa / 1000.0, self.motion)

    @property
    def combined(self) -> bool:
        return self.motion is not None


def _window(fine: float, tread: int, circumferential: int) -> MeshDensity:
    return MeshDensity(tread=tread, sidewall=5, bead=2, circumferential=circumferential,
                       window=32.0, window_elements=round(32 / fine))


LEVELS = (
    Level("uniform-40", MeshDensity(tread=8, sidewall=5, bead=2, circumferential=40), 0.0),
    Level("window-4deg", _window(4.0, 6, 42)),
    Level("window-2deg", _window(2.0, 12, 66)),
    Level("window-1deg", _window(1.0, 24, 108)),
)

CASES = (
    Case("vertical-80kPa", 80.0, (10.0, 20.0, 30.0, 40.0)),
    Case("vertical-200kPa", 200.0, (10.0, 20.0, 30.0, 40.0)),
    Case("slide-y-3mm", 200.0, (20.0,), RoadMotion(friction=0.8, shift_y=3.0)),
    Case("tilt-3deg", 200.0, (20.0,), RoadMotion(friction=0.5, tilt=3.0)),
)

ROLL_CASES = (
    # 200 kPa, 20 mm, mu 0.8 as the slide; 150 mm (Fx within 1 % after 135 mm on 32
    # round, docs/rolling.md), kappa 2 % and alpha 1 degree: Fx and Fy both well above
    # the table's 50 N floor; r_e 404 mm is about R - deflection / 3 of the inflated tyre
    Case("roll-150mm", 200.0, (20.0,),
         RoadMotion(friction=0.8, roll=150.0, slip_ratio=0.02, slip_angle=1.0,
                    rolling_radius=404.0)),
)

# Test-sized: minutes on two cores, for the pipeline, not for conclusions
QUICK_LEVELS = (
    Level("window-8deg", MeshDensity(tread=2, sidewall=2, bead=1, circumferential=24,
                                     window=32.0, window_elements=4)),
    Level("window-4deg", MeshDensity(tread=4, sidewall=2, bead=1, circumferential=38,
                                     window=32.0, window_elements=8)),
    Level("window-2deg", MeshDensity(tread=8, sidewall=2, bead=1, circumferential=60,
                                     window=32.0, window_elements=16)),
)
QUICK_CASES = (
    Case("vertical-200kPa", 200.0, (10.0, 20.0)),
    Case("slide-y-3mm", 200.0, (15.0,), RoadMotion(friction=0.8, shift_y=3.0)),
)


def chosen_cases(names: Sequence[str], quick: bool = False,
                 default: tuple[Case, ...] | None = None) -> tuple[Case, ...]:
    """The cases named (the study's - ``QUICK_CASES`` when ``quick`` - the
    :data:`POINT_CASES` and :data:`ROLL_CASES`), in the order given; none named:
    ``default``, else the study's own."""
    study = QUICK_CASES if quick else CASES
    if not names:
        return default or study
    known = {c.name: c for c in (*study, *POINT_CASES, *ROLL_CASES)}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise SpecError(f"--case {unknown[0]!r} is not a load case of the convergence study: "
                        f"choose from {', '.join(known)}")
    return tuple(known[n] for n in dict.fromkeys(names))


# --- one direction at a time (issue 44) ------------------------------------------------

DIRECTIONS = ("circumferential", "tread", "sidewall", "bead", "through", "together")
"""The ways :func:`refined` refines a mesh; ``together`` is every other one at once."""

_COUNTS = {"tread": "tread", "sidewall": "sidewall", "bead": "bead", "through": "through"}

POINT_CASES = (
    # the thesis model's two force-deflection points the calibration is judged at:
    # 3933 N at 25 mm / 80 kPa (§3.4) and 4476 N at 30 mm / 200 kPa (Fig. 3.3)
    Case("point-80kPa", 80.0, (25.0,)),
    Case("point-200kPa", 200.0, (30.0,)),
)


def refined(base: MeshDensity, direction: str, factor: int) -> MeshDensity:
    """``base`` with ``direction``'s elements multiplied by ``factor`` (1: ``base``).

    ``circumferential`` multiplies the window's elements (a windowed ``base`` only) and
    adds the fewest elements outside it that keep the grading within
    :data:`farm.spacing.MAX_GROWTH`; ``through`` is capped by the mesher at
    :data:`farm.specs.MAX_THROUGH`.
    """
    _known(direction)
    if factor == 1:
        return base
    if direction == "together":
        mesh = base
        for name in DIRECTIONS[:-1]:  # every direction but "together" itself
            mesh = refined(mesh, name, factor)
        return mesh
    if direction == "circumferential":
        return _finer_window(base, factor)
    count = getattr(base, _COUNTS[direction]) * factor
    if direction == "through" and count > MAX_THROUGH:
        raise SpecError(f"refining the wall {factor} x gives {count} elements through it; "
                        f"the mesher allows at most {MAX_THROUGH}: use a smaller factor")
    return dataclasses.replace(base, **{_COUNTS[direction]: count})


def _finer_window(base: MeshDensity, factor: int) -> MeshDensity:
    if not base.windowed:
        raise SpecError("the circumferential direction refines a window: the base mesh "
                        "has none (use a windowed mesh such as the preset 'patch')")
    inside = base.window_elements * factor
    n_half = base.circumferential // 2 + inside - base.window_elements
    while True:  # the outside keeps its elements, plus what the grading limit needs
        try:
            half_steps(180.0, n_half, base.window, inside)
        except SpecError:
            n_half += 1
            continue
        return dataclasses.replace(base, window_elements=inside, circumferential=2 * n_half)


def direction_levels(direction: str, base: MeshDensity, factors: Sequence[int] = (2, 4),
                     base_name: str = "patch") -> tuple[Level, ...]:
    """``base`` (named ``base_name``) then ``base`` refined ``factor`` x in
    ``direction``, each level twice the previous one when ``factors`` are (2, 4)."""
    levels = [Level(base_name, base)]
    last = 1
    for factor in factors:
        levels.append(Level(f"{direction}-x{factor}", refined(base, direction, factor),
                            factor / last))
        last = factor
    return tuple(levels)


def chosen_directions(names: Sequence[str]) -> tuple[str, ...]:
    """The directions named, ``all`` for every one, in the order given."""
    out: list[str] = []
    for name in names:
        out += DIRECTIONS if name == "all" else (_known(name),)
    return tuple(dict.fromkeys(out))


def _known(direction: str) -> str:
    if direction not in DIRECTIONS:
        raise SpecError(f"--direction {direction!r} is not a direction of the mesh: choose "
                        f"from {', '.join(DIRECTIONS)} (or all)")
    return direction


DIRECTION_FACTORS = {"together": (2,)}
"""Refinement factors per direction, (2, 4) where not named: ``together`` 4 x is about
87,000 nodes on ``patch``, beyond a study on two cores."""


def direction_study(directions: Sequence[str], mesh: str = "patch", quick: bool = False,
                    factors: Sequence[int] = ()) -> tuple[tuple[Level, ...],
                                                          dict[str, list[str]]]:
    """The levels to solve (the base once) and each direction's sequence of level names.

    ``mesh`` names the full model's base mesh preset; ``quick``: the test-sized
    ``QUICK_LEVELS[0]`` refined 2 x, for the pipeline, not for conclusions. ``factors``
    (powers of 2) replace :data:`DIRECTION_FACTORS`; a factor the mesher cannot build in
    a direction (``through`` beyond :data:`farm.specs.MAX_THROUGH`) is left out of it.
    """
    if any(f < 2 or f & (f - 1) for f in factors):
        raise SpecError(f"--factors must be powers of 2 from 2 (each level twice the last), "
                        f"got {', '.join(map(str, factors))}")
    from farm.presets import MESH_PRESETS, mesh_presets

    if quick:
        base, name = QUICK_LEVELS[0].mesh, QUICK_LEVELS[0].name
    elif mesh not in mesh_presets("full"):
        raise SpecError(f"unknown mesh preset {mesh!r} for the full model: choose one of "
                        f"{', '.join(mesh_presets('full'))}")
    else:
        base, name = MESH_PRESETS[mesh]["full"], mesh
    levels: dict[str, Level] = {}
    sequences = {}
    for d in directions:
        chosen = sorted(set((2,) if quick else tuple(factors)
                            or DIRECTION_FACTORS.get(d, (2, 4))))
        buildable = [f for f in chosen if _buildable(base, d, f)]
        if not buildable:  # not one level: the first factor's refusal says why
            refined(base, d, chosen[0])
        seq = direction_levels(d, base, buildable, name)
        levels.update((lv.name, lv) for lv in seq)
        sequences[d] = [lv.name for lv in seq]
    return tuple(levels.values()), sequences


def _buildable(base: MeshDensity, direction: str, factor: int) -> bool:
    try:
        refined(base, direction, factor)
    except SpecError:
        return False
    return True
