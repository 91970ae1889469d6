"""The load family: what is done to a model, with its bounds and checks.

:class:`LoadPath` (deflections, inflation, and optionally a :class:`RoadMotion`: friction,
tilt, a shift or a roll) and :class:`Roll`; units mm, MPa and degrees. A load is checked
against the model it loads by :meth:`LoadPath.check_against`.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from farm.errors import SpecError, shown
from farm.specs.bounds import STICK_SLOPE, within
from farm.specs.serial import spec_from_dict

if TYPE_CHECKING:
    from farm.specs.model import ModelSpec

# Bounds of a load path (docs/limits.md has the table)
MAX_PRESSURE_MPA = 1.0  # inflation: 1000 kPa, three times a truck tyre's
MIN_DEFLECTION_MM = 1e-6  # a nanometre: smaller is a rounding error, not a load

# Combined loads (issue 13): bounds of the road's motion after the vertical deflection.
FRICTION = (0.0, 2.0)  # Coulomb mu: rubber on dry asphalt ~1, on ice ~0.1; 2 is generous
SHIFT_MM = (-50.0, 50.0)  # road translation: the default slab reaches 168 mm beyond the
# wheel plane and the contact patch ~100 mm, so 50 mm keeps the patch on the road
TILT_DEG = (-10.0, 10.0)  # road rotation about x: camber of a road-going tyre is < 10 deg
RISES = ("vertical", "normal")  # RoadMotion.rise: how a tilted road is pushed up
#: RoadMotion.friction_from / Roll.friction_from: where a roll's friction begins
FRICTION_FROM = ("touch", "roll")
#: Roll.lead / RoadMotion.lead: the road travel (mm) over which a roll's lateral lead is
#: eased in (farm.ccx.deck.road_motion_lines). Measured on the thesis wall at 32 round
#: (docs/rolling.md, "A steady roll"): a lead eased in over 96 mm left Fy flat within
#: 0.24 % from the first pitch after it; a lead taken in 6.4 mm stopped the roll where
#: the lateral slide ended, and one taken with the rise stopped the rise at first touch.
LEAD_RAMP_MM = 96.0


@dataclass(frozen=True)
class RoadMotion:
    """Combined load case: Coulomb friction, a tilted road, and a shift after the deflection.

    The road is tilted by ``tilt`` degrees about the x axis through the contact centre
    (the point of the road plane under the wheel centre, TYDEX C, thesis §2.5) while it
    is still clear of the tyre, then pushed up to the path's deflections (with
    friction), then, in the same ccx run, slid in its own plane by ``shift_x`` mm along
    x and ``shift_y`` mm along its (tilted) lateral axis (0, cos tilt, sin tilt).
    The tilt comes first because ccx keeps a sticking node's tangential spring in the
    frame it was built in: rotating the road under sticking nodes gives that spring a
    normal part the contact output does not report (measured: tread moments 2 % off the
    road's at 3 degrees, docs/combined-loads.md). A camber test rig loads an inclined
    wheel the same way. Axes: x forward, y lateral, z up; a positive tilt lifts the
    road on the +y side, i.e. the wheel leans by ``-tilt`` relative to the road.

    Parameters
    ----------
    friction : Coulomb coefficient mu >= 0 between tread and road; 0 is frictionless.
    shift_x, shift_y : road translation along x (longitudinal) and its lateral axis, mm.
    tilt : road rotation about +x (right hand), degrees.
    stick_slope : tangential penalty stiffness lambda of ccx's ``*FRICTION``, N/mm^3
        (shear stress per mm of elastic slip); None derives it from the contact law
        (:func:`farm.ccx.deck.stick_slope`, docs/combined-loads.md says why).
    rise : how a tilted road is pushed up to the deflection: ``"vertical"`` along the
        wheel's z axis (the farm's rise since issue 13: the road also slides in its own
        plane by d sin(tilt) while the patch forms), or ``"normal"`` along the road's
        normal, as a camber rig loads an inclined wheel (the same final plane, no slide;
        :func:`farm.ccx.deck._rise`, docs/combined-loads.md "Rise direction"). Ignored
        (and stored as ``"vertical"``) for an untilted road; always ``"normal"`` for a
        tilted roll.
    roll : road travel of a roll, mm (0: no roll; issue 30, :mod:`farm.solve.rolling`):
        the deflected tyre rolls while the road travels ``roll`` mm under it, and the
        experiment is the state at the roll's end, seen by a camera fixed to the contact
        centre. A roll and a shift exclude each other.
    slip_ratio, slip_angle : longitudinal slip kappa (SAE) and slip angle (degrees) of
        the roll (:class:`Roll`).
    rolling_radius : the free-rolling radius r_e (mm) that turns the road's travel into
        the rim's spin; None: found for each experiment (Fx = 0 at kappa = 0).
    roll_from : mm of the roll rolled straight at kappa = 0 before ``slip_ratio`` and
        ``slip_angle`` apply (issue 45, :mod:`farm.solve.rolling_tree`: a branch of a
        rolling tree, continued from its trunk's end); 0: the slips from the start. A
        roll without slips is the same roll whatever this says, and is stored as 0.
    radius_estimate : with ``rolling_radius`` None, roll at the free-rolling radius's
        estimate from the inflated radius and the deflection
        (:func:`farm.solve.rolling.estimated_radius`) instead of searching for it (issue
        46: a search costs about three rolls per pressure, deflection, friction and
        camber); the slip ratio is then relative to that radius.
    friction_from : where a roll's friction begins: ``"touch"`` (the tread meets the
        road with friction, as everything before 2026-11-30 did) or ``"roll"`` (the rise
        frictionless, the friction switched on as the roll starts, ccx's ``*CHANGE
        FRICTION``: no tread node is left sticking on the edge of slip when the roll
        starts, which stopped rolls of the 16-element polygon; docs/rolling.md, "A
        frictionless rise"). Rolls only; stored as ``"touch"`` without friction.
    lead : the road's lateral offset (mm, along its lateral axis as ``shift_y``) that a
        roll takes on top of its slip angle's travel, eased in over its first
        :data:`LEAD_RAMP_MM` (:class:`Roll`): a roll that starts near its steady lateral
        deflection, for steady Fy and Mz within the refined window (docs/rolling.md, "A
        steady roll"). Rolls from rest only; stored as 0 without friction.
    lead_x : the same along the road's x (mm; > 0 with a driving slip): a roll that starts
        near its steady longitudinal deflection, for a steady Fx within a short roll
        (docs/rolling.md, "A longitudinal lead"). Rolls from rest only; 0 without friction.

    All at their defaults the motion is no motion at all: :class:`LoadPath` then holds
    None, so decks, results and ids are those of a vertical experiment.
    """

    _prefix: ClassVar[str] = "motion"
    friction: float = 0.0
    shift_x: float = 0.0
    shift_y: float = 0.0
    tilt: float = 0.0
    stick_slope: float | None = None
    rise: str = "vertical"
    # rolling (issue 30, farm.solve.rolling): a roll of ``roll`` mm instead of a shift
    roll: float = 0.0
    slip_ratio: float = 0.0
    slip_angle: float = 0.0
    rolling_radius: float | None = None
    roll_from: float = 0.0
    radius_estimate: bool = False
    friction_from: str = "touch"
    lead: float = 0.0
    lead_x: float = 0.0

    def __post_init__(self) -> None:
        self._check_roll()
        within("motion.friction", self.friction, FRICTION, "(Coulomb coefficient)")
        within("motion.shift_x", self.shift_x, SHIFT_MM, "mm")
        within("motion.shift_y", self.shift_y, SHIFT_MM, "mm")
        within("motion.tilt", self.tilt, TILT_DEG, "degrees")
        if self.stick_slope is not None:
            within("motion.stick_slope", self.stick_slope, STICK_SLOPE, "N/mm^3")
        if self.rise not in RISES:
            raise SpecError(f"motion.rise = {self.rise!r}: give one of {', '.join(RISES)}")
        for f in dataclasses.fields(self):  # canonical floats: 1 and 1.0 hash alike
            v = getattr(self, f.name)
            if v is not None and f.name not in ("rise", "radius_estimate", "friction_from"):
                object.__setattr__(self, f.name, float(v) + 0.0)
        if self.tilt == 0.0:  # an untilted road rises along its normal either way
            object.__setattr__(self, "rise", "vertical")
        elif self.rolls:  # a rolling tyre is pressed along the road's normal, as on a rig
            object.__setattr__(self, "rise", "normal")

    def _check_roll(self) -> None:
        _friction_from(self, "motion")
        if self.roll == 0.0:
            if (self.slip_ratio or self.slip_angle or self.rolling_radius is not None
                    or self.roll_from or self.radius_estimate
                    or self.friction_from != "touch" or self.lead or self.lead_x):
                raise SpecError("motion.slip_ratio, slip_angle, rolling_radius, roll_from, "
                                "radius_estimate, friction_from, lead and lead_x belong to a "
                                "roll: give motion.roll, the road travel in mm")
            return
        for name in ("lead", "lead_x"):
            if getattr(self, name) and self.roll_from:
                raise SpecError(f"motion.{name} = {getattr(self, name)!r} with roll_from = "
                                f"{self.roll_from!r}: a branch rolls on from its trunk's "
                                "state; a lead belongs to a roll from rest (drop one of them)")
        if self.radius_estimate and self.rolling_radius is not None:
            raise SpecError(f"motion.radius_estimate estimates a radius, and rolling_radius "
                            f"= {self.rolling_radius!r} gives one: drop one of them")
        if not 0.0 <= self.roll_from < self.roll:
            raise SpecError(f"motion.roll_from = {self.roll_from!r}: the straight part of a "
                            f"roll lies in [0, roll = {self.roll!r}) mm")
        if not (self.slip_ratio or self.slip_angle):  # the same roll, straight throughout
            object.__setattr__(self, "roll_from", 0.0)
        within("motion.roll", self.roll, ROLL_MM, "mm")
        _lead(self, "motion")
        within("motion.slip_ratio", self.slip_ratio, SLIP_RATIO, "")
        within("motion.slip_angle", self.slip_angle, SLIP_ANGLE_DEG, "degrees")
        if self.rolling_radius is not None:
            within("motion.rolling_radius", self.rolling_radius, ROLLING_RADIUS_MM, "mm")
        if self.shift_x or self.shift_y:
            raise SpecError("a motion either slides the road (shift_x, shift_y) or rolls the "
                            "tyre (roll), not both")

    @property
    def rolls(self) -> bool:
        """Whether the tyre rolls (:attr:`roll` mm of road travel, issue 30)."""
        return self.roll > 0.0

    def as_roll(self, rolling_radius: float | None = None) -> Roll:
        """The :class:`Roll` of a rolling motion; ``rolling_radius`` stands in for a free
        one (None here: the radius that :func:`farm.solve.rolling.free_rolling_radius`
        finds)."""
        radius = self.rolling_radius if self.rolling_radius is not None else rolling_radius
        if not self.rolls or radius is None:
            raise SpecError("not a roll, or a free-rolling radius still to be found")
        if self.roll_from:
            raise SpecError(f"a roll that turns to its slips after {self.roll_from:g} mm is "
                            "a rolling tree's branch: it is solved from its trunk "
                            "([loads.roll] branch_from_mm, farm.solve.rolling_tree)")
        return Roll(friction=self.friction, slip_ratio=self.slip_ratio,
                    slip_angle=self.slip_angle, tilt=self.tilt, distance=self.roll,
                    rolling_radius=radius, friction_from=self.friction_from, lead=self.lead,
                    lead_x=self.lead_x)

    @property
    def searches_radius(self) -> bool:
        """Whether the roll's radius is searched for (neither given nor estimated)."""
        return self.rolls and self.rolling_radius is None and not self.radius_estimate

    @property
    def moves(self) -> bool:
        """Whether the road moves after the deflection (a shift)."""
        return bool(self.shift_x or self.shift_y)

    @property
    def normal(self) -> tuple[float, float, float]:
        """The tilted road's upward unit normal (0, -sin tilt, cos tilt), TYDEX C."""
        a = math.radians(self.tilt)
        return (0.0, -math.sin(a), math.cos(a))

    @property
    def is_identity(self) -> bool:
        """No friction, tilt or shift: the vertical experiment itself."""
        return not (self.friction or self.moves or self.tilt or self.stick_slope is not None
                    or self.rolls)

    def scaled(self, fraction: float) -> RoadMotion:
        """The shift ``fraction`` of the way along its ramp (same friction and tilt)."""
        return dataclasses.replace(self, shift_x=fraction * self.shift_x,
                                   shift_y=fraction * self.shift_y)

    def to_dict(self) -> dict[str, Any]:
        data = dataclasses.asdict(self)
        if self.stick_slope is None:  # derived from the contact law
            del data["stick_slope"]
        if self.rise == "vertical":  # the rise of before: ids and decks as they were
            del data["rise"]
        if not self.rolls:  # ids of slides and standing tyres as before rolling existed
            for name in ("roll", "slip_ratio", "slip_angle", "rolling_radius", "roll_from",
                         "radius_estimate", "friction_from", "lead", "lead_x"):
                del data[name]
            return data
        if not self.radius_estimate:  # ids of rolls as before the estimate existed
            del data["radius_estimate"]
        if self.rolling_radius is None:  # free: found by the worker
            del data["rolling_radius"]
        if not self.roll_from:  # rolls from rest keep the ids they had before trees
            del data["roll_from"]
        if self.friction_from == "touch":  # rolls keep the ids they had before it existed
            del data["friction_from"]
        for name in ("lead", "lead_x"):  # rolls keep the ids they had before leads
            if not data[name]:
                del data[name]
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> RoadMotion:
        return spec_from_dict(cls, data, "motion")


def _friction_from(spec: RoadMotion | Roll, where: str) -> None:
    """Check ``spec.friction_from`` (one of :data:`FRICTION_FROM`), stored as "touch"
    without friction: there is nothing to switch on (one id for the frictionless roll)."""
    if spec.friction_from not in FRICTION_FROM:
        raise SpecError(f"{where}.friction_from = {shown(spec.friction_from)}: give one of "
                        f"{', '.join(FRICTION_FROM)}")
    if not spec.friction:
        object.__setattr__(spec, "friction_from", "touch")


def _lead(spec: RoadMotion | Roll, where: str) -> None:
    """Check a roll's ``spec.lead`` and ``spec.lead_x`` (mm): within :data:`SHIFT_MM`, on a
    roll longer than their ramp (:data:`LEAD_RAMP_MM`); stored as 0 without friction (a
    frictionless road carries no shear: one id for the same roll)."""
    distance = spec.roll if isinstance(spec, RoadMotion) else spec.distance
    for name in ("lead", "lead_x"):
        value = getattr(spec, name)
        within(f"{where}.{name}", value, SHIFT_MM, "mm")
        if value and distance <= LEAD_RAMP_MM:
            raise SpecError(f"{where}.{name} = {value!r} on a roll of {distance!r} mm: the "
                            f"lead is eased in over the first {LEAD_RAMP_MM:g} mm, so roll "
                            "further (or drop the lead)")
        if not spec.friction:
            object.__setattr__(spec, name, 0.0)


# Rolling (issue 30, farm.solve.rolling): bounds of a roll
SLIP_RATIO = (-1.0, 1.0)  # kappa: full lock to twice the free-rolling spin
SLIP_ANGLE_DEG = (-20.0, 20.0)
ROLL_MM = (1.0, 2000.0)  # road travel of one roll (under a revolution: about 2540 mm)
#: The longest branch of a rolling tree, mm (:mod:`farm.solve.rolling_tree`): a branch
#: lasts one unit of step time, its increments capped at 5 mm of travel as a roll's are
MAX_BRANCH_MM = 320.0
ROLLING_RADIUS_MM = (100.0, 1000.0)


@dataclass(frozen=True)
class Roll:
    """A rolling experiment's motion (issue 30).

    Parameters
    ----------
    friction : Coulomb coefficient mu >= 0 (0: frictionless, the road carries no shear).
    slip_ratio : longitudinal slip kappa (SAE): > 0 drives, < 0 brakes, 0 rolls freely.
    slip_angle : angle between the wheel plane and the travel direction, degrees.
    tilt : road tilt about +x, degrees (camber; :class:`farm.specs.RoadMotion`).
    distance : road travel of the roll, mm (long enough for a steady patch).
    rolling_radius : the free-rolling radius r_e, mm, that turns distance into spin.
    friction_from : ``"touch"`` or ``"roll"``: where the friction begins
        (:attr:`RoadMotion.friction_from`).
    lead : the road's lateral offset, mm, eased in over the roll's first
        :data:`LEAD_RAMP_MM` on top of ``travel`` (:attr:`RoadMotion.lead`).
    lead_x : the same along the road's x, mm (:attr:`RoadMotion.lead_x`).
    """

    friction: float
    slip_ratio: float = 0.0
    slip_angle: float = 0.0
    tilt: float = 0.0
    distance: float = 150.0
    rolling_radius: float = 390.0
    friction_from: str = "touch"
    lead: float = 0.0
    lead_x: float = 0.0

    def __post_init__(self) -> None:
        _friction_from(self, "roll")
        within("roll.friction", self.friction, FRICTION, "(Coulomb coefficient)")
        within("roll.slip_ratio", self.slip_ratio, SLIP_RATIO, "")
        within("roll.slip_angle", self.slip_angle, SLIP_ANGLE_DEG, "degrees")
        within("roll.tilt", self.tilt, TILT_DEG, "degrees")
        within("roll.distance", self.distance, ROLL_MM, "mm")
        within("roll.rolling_radius", self.rolling_radius, ROLLING_RADIUS_MM, "mm")
        _lead(self, "roll")

    @property
    def travel(self) -> tuple[float, float]:
        """The road's displacement in its own plane over the roll, (x, lateral) mm."""
        a = math.radians(self.slip_angle)
        return (-self.distance * math.cos(a), -self.distance * math.sin(a))

    @property
    def spin(self) -> float:
        """The rim's turn about +y over the roll, radians."""
        a = math.radians(self.slip_angle)
        return (1.0 + self.slip_ratio) * self.distance * math.cos(a) / self.rolling_radius


@dataclass(frozen=True)
class LoadPath:
    """Quasi-static loading solved in one go: inflate, then push the road up.

    ``deflections`` (mm, strictly increasing) are the road's travel towards the wheel
    axis measured from first touch of the unloaded (inflated) tyre; results are
    produced at each of them. ``pressure`` is the inflation pressure in MPa.

    ``motion`` (combined loads, contact road only) adds Coulomb friction and the road's
    tilt to the whole path and, after the last deflection, ramps the road's shift;
    results are produced at each of ``motion_fractions`` (strictly increasing in (0, 1],
    ending at 1) of that ramp, after those of the deflections. A rolling motion
    (issue 45) rolls to its end and keeps its states at ``motion_fractions`` of the
    roll (any increasing fractions in (0, 1]) instead of the deflection's. A motion
    that is no motion (:attr:`RoadMotion.is_identity`) is stored as None: the vertical
    path itself.
    """

    deflections: tuple[float, ...]
    pressure: float = 0.0
    motion: RoadMotion | None = None
    motion_fractions: tuple[float, ...] = (1.0,)

    def __post_init__(self) -> None:
        self._check_motion()
        d = tuple(float(v) for v in self.deflections)
        object.__setattr__(self, "deflections", d)
        if not d:
            raise SpecError("a load path needs at least one deflection")
        for v in d:
            if not (math.isfinite(v) and v >= MIN_DEFLECTION_MM):
                raise SpecError(f"deflection must be a positive number of mm (at least "
                                f"{MIN_DEFLECTION_MM:g}), got {v!r}")
        if any(b <= a for a, b in itertools.pairwise(d)):
            raise SpecError(f"deflections must be strictly increasing, got {list(d)}")
        if not (math.isfinite(self.pressure) and 0 <= self.pressure <= MAX_PRESSURE_MPA):
            raise SpecError(
                f"pressure must be a number of MPa in [0, {MAX_PRESSURE_MPA:g}] (at most "
                f"{1000 * MAX_PRESSURE_MPA:g} kPa), got {self.pressure!r}")

    def _check_motion(self) -> None:
        if self.motion is not None and not isinstance(self.motion, RoadMotion):
            raise SpecError(f"motion must be a RoadMotion or None, got "
                            f"{shown(self.motion)}")
        if self.motion is not None and self.motion.is_identity:
            object.__setattr__(self, "motion", None)  # the vertical path, same ids
        try:
            f = tuple(float(v) for v in self.motion_fractions)
        except (TypeError, ValueError):
            raise SpecError(f"motion_fractions must be a list of numbers, got "
                            f"{shown(self.motion_fractions)}") from None
        object.__setattr__(self, "motion_fractions", f)
        if f == (1.0,):
            return
        if self.motion is None or not (self.motion.moves or self.motion.rolls):
            raise SpecError(f"motion_fractions {list(f)} need a road shift or a roll to "
                            "divide; leave them at [1.0]")
        # a roll is always solved to its end; its states may be any of its fractions
        # (issue 45: those a resumed roll still needs), a shift's end at 1
        ends = self.motion.rolls or f[-1] == 1.0
        if not (f and all(math.isfinite(v) and 0 < v <= 1 for v in f) and ends
                and all(b > a for a, b in itertools.pairwise(f))):
            raise SpecError("motion_fractions must be strictly increasing in (0, 1] and, for "
                            f"a shift, end at 1, got {list(f)}")

    def check_against(self, model: ModelSpec) -> None:
        """Reject loads the model cannot take (raises :class:`SpecError`)."""
        limit = model.geometry.section_height - model.geometry.tread_thickness
        if self.motion is not None:
            if model.road != "contact":
                raise SpecError("friction and road motion need the contact road "
                                f"(road = 'contact'), the model has road = {model.road!r}")
            # a tilted road rises under the tread edge: keep that edge off the rim too
            lift = 0.5 * model.geometry.tread_width * math.sin(math.radians(abs(
                self.motion.tilt)))
            if self.motion.rolls and (not model.inflated or len(self.deflections) != 1):
                raise SpecError("a roll needs the inflated full model and one deflection, "
                                f"got model kind {model.kind!r} and deflections "
                                f"{list(self.deflections)}")
            if self.deflections[-1] + lift >= limit:
                raise SpecError(
                    f"deflection {self.deflections[-1]} mm plus the tilted road's rise at the "
                    f"tread edge ({lift:.3g} mm) reaches through the tyre: keep the sum below "
                    f"{limit:g} mm")
        if self.deflections[-1] >= limit:
            raise SpecError(
                f"deflection {self.deflections[-1]} mm reaches through the tyre: keep it below "
                f"the section height minus the tread ({limit:g} mm)"
            )
        if model.inflated and self.pressure <= 0:
            raise SpecError("the full model is inflated: give a pressure > 0 (e.g. 0.2 MPa)")
        if not model.inflated and self.pressure > 0:
            raise SpecError(
                f"the reduced model is not inflated (thesis Table 3.1): pressure must be 0, "
                f"got {self.pressure} MPa"
            )
