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

``ROLL_CASES`` (issue 30, solved on request: ``farm converge --case roll-150mm``) ask
whether the criterion still holds once the tyre rolls: a windowed mesh's roll starts
with its window ahead of the road and ends with it centred under the contact
(:func:`farm.solve.rolling.start_spin`). The rim's spin is prescribed with one nominal
radius on every level, so every level gets the same motion and Fx is a response, not
a search's residual.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from farm.errors import SpecError
from farm.specs import LoadPath, MeshDensity, RoadMotion


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


def chosen_cases(names: Sequence[str], quick: bool = False) -> tuple[Case, ...]:
    """The cases named (the study's - ``QUICK_CASES`` when ``quick`` - and
    :data:`ROLL_CASES`), in the order given; none named: the study's own."""
    study = QUICK_CASES if quick else CASES
    if not names:
        return study
    known = {c.name: c for c in (*study, *ROLL_CASES)}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise SpecError(f"--case {unknown[0]!r} is not a load case of the convergence study: "
                        f"choose from {', '.join(known)}")
    return tuple(known[n] for n in dict.fromkeys(names))
