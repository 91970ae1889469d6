"""Plain, typed, immutable descriptions of a tyre model and of what to do with it.

Everything that changes a result lives in these frozen dataclasses, validated once when
constructed, so that a spec that exists is a spec that can be meshed and solved. Units
are N, mm, MPa and s throughout (docs/architecture.md); the CLI converts kPa at its boundary.

``to_dict``/``from_dict`` give the canonical form used for content hashes (jobs) and
for study files; ``from_dict`` rejects unknown keys so that a typo is never ignored.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import typing
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal, get_args, get_type_hints

from farm.errors import SpecError, shown
from farm.reinforcement import Reinforcement, implied_depth
from farm.spacing import half_steps

ModelKind = Literal["reduced", "full"]
RoadKind = Literal["iterative", "contact"]
CutFaces = Literal["fixed", "free"]

# Bounds of what a spec may hold (docs/limits.md has the table): generous for research,
# but no absurdities (E = 1e308 MPa, a 1e-9 s timeout, 2**63 threads) reach the solver.
GEOMETRY_MM = (0.1, 10_000.0)  # every length of the profile: up to a 10 m tyre
MODULUS_MPA = (1e-3, 1e6)  # Young's modulus: from a gel (1 kPa) to beyond steel (2e5 MPa)
CLEARANCE_MM = (1e-4, 10.0)  # contact c0
CONTACT_PRESSURE_MPA = (1e-4, 1e3)  # contact p0
MAX_PRESSURE_MPA = 1.0  # inflation: 1000 kPa, three times a truck tyre's
MIN_DEFLECTION_MM = 1e-6  # a nanometre: smaller is a rounding error, not a load
THREADS = (1, 256)  # ccx threads per run
TIMEOUT_S = (1.0, 7 * 86400.0)  # wall-clock seconds per ccx run: a second to a week
#: ccx's most iterations in one increment (IC of *CONTROLS, TIME INCREMENTATION, its
#: default): what ``grow_after`` may be at most
MAX_ITERATIONS = 16
MIN_INCREMENT = 1e-12  # smallest min_increment (a fraction of a load ramp)
MAX_INCREMENTS = 1_000_000
MAX_THROUGH = 4  # elements through the wall (issue 15 asks for 2+); 4 keeps the 10 mm
# sidewall's elements 2.5 mm thick, not slivers, on the coarse meshes



def _positive(name: str, value: float) -> None:
    if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
        raise SpecError(f"{name} must be a positive number, got {shown(value)}")


def _within(name: str, value: float, bounds: tuple[float, float], unit: str) -> None:
    low, high = bounds
    if not (isinstance(value, int | float) and not isinstance(value, bool)
            and math.isfinite(value) and low <= value <= high):
        raise SpecError(f"{name} must be a number in [{low:g}, {high:g}] {unit}, "
                        f"got {shown(value)}")


@dataclass(frozen=True)
class TyreGeometry:
    """Meridional profile of the Trelleborg TM700 280/70R16 slick (thesis §2.4, §3.2).

    The outer contour is a crowned tread arc, a shoulder/upper-sidewall curve to the
    point of maximum section width and a lower sidewall down to the bead seat; the inner
    contour is the outer one offset by a wall thickness that blends between regions.
    All lengths in mm.

    Parameters
    ----------
    rim_diameter : bead seat diameter (16 in).
    section_width : maximum section width (280 mm).
    section_height : section height, outer radius minus rim radius (0.70 x 280 mm).
    rim_width : lateral distance between the two bead seats (9 in rim).
    tread_width : lateral width of the crowned tread region.
    crown_drop : radial drop of the outer contour from the centre to the tread edge.
    bead_length : arc length of each bead region along the outer contour.
    tread_thickness, sidewall_thickness, bead_thickness : wall thickness per region.
    """

    _prefix: ClassVar[str] = "geometry"
    rim_diameter: float = 406.4
    section_width: float = 280.0
    section_height: float = 196.0
    rim_width: float = 228.6
    tread_width: float = 200.0
    crown_drop: float = 8.0
    bead_length: float = 40.0
    tread_thickness: float = 20.0
    sidewall_thickness: float = 10.0
    bead_thickness: float = 20.0

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            _within(f"geometry.{f.name}", getattr(self, f.name), GEOMETRY_MM, "mm")
        if not self.rim_width < self.section_width:
            raise SpecError(
                f"geometry.rim_width ({self.rim_width}) must be smaller than "
                f"geometry.section_width ({self.section_width})"
            )
        if not self.tread_width < self.section_width - 2 * self.sidewall_thickness:
            raise SpecError(
                f"geometry.tread_width ({self.tread_width}) leaves no room for the shoulders: "
                f"keep it below section_width - 2 x sidewall_thickness "
                f"({self.section_width - 2 * self.sidewall_thickness})"
            )
        walls = {n: getattr(self, n) for n in
                 ("tread_thickness", "sidewall_thickness", "bead_thickness")}
        thickest = max(walls, key=walls.__getitem__)
        if not walls[thickest] < self.section_height / 4:
            raise SpecError(
                f"geometry.{thickest} ({walls[thickest]} mm) is too large a wall thickness "
                f"for section_height {self.section_height} mm: keep every thickness below a "
                f"quarter of it ({self.section_height / 4:g} mm)"
            )
        if not self.crown_drop < self.section_height / 4:
            raise SpecError(
                f"geometry.crown_drop ({self.crown_drop}) must be below a quarter of "
                f"section_height ({self.section_height / 4})"
            )

    @property
    def rim_radius(self) -> float:
        return self.rim_diameter / 2

    @property
    def outer_radius(self) -> float:
        """Radius of the crown centre line, unloaded and uninflated."""
        return self.rim_radius + self.section_height


@dataclass(frozen=True)
class MeshDensity:
    """Element counts of the structured hexahedral mesh.

    ``tread``, ``sidewall`` and ``bead`` count elements along the meridian in each
    region (per side for sidewall and bead); ``circumferential`` counts elements around
    the revolved sector (90 degrees for the reduced model, 360 for the full one);
    ``through`` counts elements through the wall (1 to 4; the thesis' mesh has one,
    §3.2; more are issue 15's model-complexity option, :mod:`farm.mesh.layers`).
    ``through = 1`` is absent from :meth:`canonical`, so every id of a one-element
    wall predates the field.

    ``window`` (degrees) and ``window_elements`` refine the circumference about the
    contact centre (issue 24, :mod:`farm.spacing`): ``window_elements`` equal elements
    on each side within ``+-window`` degrees, graded geometrically outside;
    ``circumferential`` still counts all elements round the sector. ``window = 0`` (the
    default) is the uniform mesh, and both fields are then absent from :meth:`canonical`.
    """

    _prefix: ClassVar[str] = "mesh"
    tread: int = 8
    sidewall: int = 5
    bead: int = 2
    circumferential: int = 20
    through: int = 1
    window: float = 0.0
    window_elements: int = 0

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            if f.name in ("window", "window_elements"):
                continue
            v = getattr(self, f.name)
            if not (isinstance(v, int) and not isinstance(v, bool) and v >= 1):
                raise SpecError(f"mesh.{f.name} must be a positive integer, got "
                                f"{shown(v)}")
        if self.tread % 2:
            raise SpecError(
                f"mesh.tread must be even (a node row on the tyre's centre line), got {self.tread}"
            )
        if self.circumferential % 2 or self.circumferential < 4:
            raise SpecError(
                "mesh.circumferential must be even and at least 4 (a node row under the "
                f"wheel centre), got {self.circumferential}"
            )
        if self.through > MAX_THROUGH:
            raise SpecError(f"mesh.through must be in [1, {MAX_THROUGH}] (elements through "
                            f"the wall), got {self.through}")
        self._check_window()

    def _check_window(self) -> None:
        w, k = self.window, self.window_elements
        if not (isinstance(w, int | float) and not isinstance(w, bool) and 0 <= w < 180):
            raise SpecError(f"mesh.window must be a number of degrees in [0, 180) (0: a "
                            f"uniform mesh), got {shown(w)}")
        if not (isinstance(k, int) and not isinstance(k, bool) and k >= 0):
            raise SpecError(f"mesh.window_elements must be a whole number >= 0, got "
                            f"{shown(k)}")
        if (w == 0) != (k == 0):
            raise SpecError("mesh.window and mesh.window_elements go together: both 0 (a "
                            f"uniform mesh) or both positive, got window={w:g}, "
                            f"window_elements={k}")
        object.__setattr__(self, "window", float(w))  # 30 and 30.0: one id

    @property
    def windowed(self) -> bool:
        return self.window > 0

    @property
    def meridional(self) -> int:
        return self.tread + 2 * (self.sidewall + self.bead)

    def canonical(self) -> dict[str, int]:
        """The counts as hashed in ids: ``through`` only when the wall is layered."""
        data = dataclasses.asdict(self)
        if self.through == 1:  # the one-element wall's ids predate the field
            del data["through"]
        if not self.windowed:  # so do the uniform meshes'
            del data["window"], data["window_elements"]
        return data


@dataclass(frozen=True)
class Material:
    """Compressible Neo-Hookean rubber given by small-strain constants (thesis Table 3.1).

    CalculiX's ``*HYPERELASTIC, NEO HOOKE`` takes C10 = G/2 and D1 = 2/K, with the shear
    modulus G = E / (2 (1 + nu)) and bulk modulus K = E / (3 (1 - 2 nu)).
    """

    _prefix: ClassVar[str] = "material"
    youngs_modulus: float
    poisson_ratio: float

    def __post_init__(self) -> None:
        _within("material.youngs_modulus", self.youngs_modulus, MODULUS_MPA, "MPa")
        nu = self.poisson_ratio
        if not (isinstance(nu, int | float) and -1.0 < nu < 0.5):
            raise SpecError(f"material.poisson_ratio must lie in (-1, 0.5), got "
                            f"{shown(nu)}")

    @property
    def c10(self) -> float:
        return self.youngs_modulus / (4.0 * (1.0 + self.poisson_ratio))

    @property
    def d1(self) -> float:
        bulk = self.youngs_modulus / (3.0 * (1.0 - 2.0 * self.poisson_ratio))
        return 2.0 / bulk


@dataclass(frozen=True)
class Materials:
    """One material per region; the regions become CalculiX element sets."""

    tread: Material
    sidewall: Material
    bead: Material

    def by_region(self) -> dict[str, Material]:
        return {"tread": self.tread, "sidewall": self.sidewall, "bead": self.bead}


@dataclass(frozen=True)
class ContactLaw:
    """Exponential pressure-overclosure law of the tyre-road contact (thesis §3.2).

    ``clearance`` is CalculiX's c0, the distance from the road at which the contact
    pressure has dropped to 1 % of ``pressure`` (p0, MPa, the pressure at zero distance).
    ``stick_slope`` (N/mm^3) is the tangential penalty of frictional paths for this tyre;
    None derives it from the normal law (:func:`farm.ccx.deck.stick_slope`). A load's
    ``motion.stick_slope`` overrides either. Absent from ids while None.
    """

    # Measured on the full model at 200 kPa, 30 mm: c0 = 0.2/0.5/1.0 mm gave Fz within
    # +-1.5 % of each other, with the tread floating 0.03-0.25 mm above the road for
    # c0 = 0.5 mm, p0 = 0.5 MPa (peak pressure ~0.4 MPa) at 2/3 of the cost of c0 = 0.2.
    _prefix: ClassVar[str] = "contact"
    clearance: float = 0.5
    pressure: float = 0.5
    stick_slope: float | None = None

    def __post_init__(self) -> None:
        _within("contact.clearance", self.clearance, CLEARANCE_MM, "mm")
        _within("contact.pressure", self.pressure, CONTACT_PRESSURE_MPA, "MPa")
        if self.stick_slope is not None:
            _within("contact.stick_slope", self.stick_slope, STICK_SLOPE, "N/mm^3")

    def canonical(self) -> dict[str, float]:
        """The law as hashed in ids: ``stick_slope`` only when set (ids predate it)."""
        data = dataclasses.asdict(self)
        if self.stick_slope is None:
            del data["stick_slope"]
        return data


@dataclass(frozen=True)
class ModelSpec:
    """A complete finite element model: geometry, mesh, materials and boundary conditions.

    ``kind="reduced"`` is the uninflated bottom sector next to the road (thesis §3.3.1),
    ``kind="full"`` the inflated 360-degree tyre against a rigid road (§3.3.2).
    ``road`` chooses the road boundary condition: the thesis' iterative prescribed
    displacements (reduced only) or frictionless exponential contact with a rigid plane.
    ``cut_faces`` says whether the sector's cut faces are clamped (reduced only). The
    thesis names only the clamped beads (§3.2), so they are free by default; with free
    faces the reduced model at 30 mm touches the road mostly along the two tread edges
    (16 nodes on the default mesh; the thesis reports 14, §3.3.1, §4.2).
    """

    kind: ModelKind
    geometry: TyreGeometry = field(default_factory=TyreGeometry)
    mesh: MeshDensity = field(default_factory=MeshDensity)
    materials: Materials = field(
        default_factory=lambda: Materials(*(Material(10.0, 0.499),) * 3)
    )
    road: RoadKind = "iterative"
    sector_angle: float = 90.0
    cut_faces: CutFaces = "free"
    contact: ContactLaw = field(default_factory=ContactLaw)
    # None = the thesis' cordless wall; absent from to_dict then, so ids stay stable
    reinforcement: Reinforcement | None = None

    def __post_init__(self) -> None:
        _check_literal("kind", self.kind, ModelKind)
        _check_literal("road", self.road, RoadKind)
        _check_literal("cut_faces", self.cut_faces, CutFaces)
        if self.kind == "full":
            if self.sector_angle != 360.0:
                raise SpecError(
                    f"sector_angle must be 360 for the full model, got {self.sector_angle}"
                )
            if self.road != "contact":
                raise SpecError(
                    "road must be 'contact' for the full model (the iterative procedure is "
                    f"the reduced model's), got {self.road!r}"
                )
            if self.mesh.circumferential % 4 and not self.mesh.windowed:
                raise SpecError(
                    "mesh.circumferential of the full model must be a multiple of 4 (it is "
                    f"revolved in quarters), got {self.mesh.circumferential}"
                )
        elif not (isinstance(self.sector_angle, int | float) and 20 <= self.sector_angle < 180):
            raise SpecError(
                "sector_angle of the reduced model must be in [20, 180) degrees, "
                f"got {self.sector_angle!r}"
            )
        if self.mesh.windowed:  # the window must fit and grade smoothly: refuse here
            half_steps(self.sector_angle / 2, self.mesh.circumferential // 2,
                       self.mesh.window, self.mesh.window_elements)
        r = self.reinforcement
        if r is not None and r.belt_layout == "cords" and r.belt_depth is None \
                and implied_depth(self.mesh.through) is None:
            # belts at depth lie at half the wall (farm.ccx.belt_cords): a node layer there
            raise SpecError(f"mesh.through must be 1 or even with belts along their cords "
                            f"(they lie at half the wall), got {self.mesh.through}; or "
                            f"state their depth: --set reinforcement.belt_depth=0.5")

    @property
    def is_full(self) -> bool:
        return self.kind == "full"

    @property
    def node_estimate(self) -> int:
        """Nodes of the structured mesh: ``through + 1`` layers of
        (meridional + 1) x (circumferential + 1) nodes, the full tyre's seam shared.
        Arithmetic only: the bound of :mod:`jobs.validate.spec_tables` needs no mesh."""
        rings = self.mesh.circumferential + (0 if self.is_full else 1)
        return (self.mesh.through + 1) * (self.mesh.meridional + 1) * rings

    @property
    def inflated(self) -> bool:
        return self.is_full

    def to_dict(self) -> dict[str, Any]:
        data = dataclasses.asdict(self)
        if self.reinforcement is None:  # the cordless model's ids predate the field
            del data["reinforcement"]
        else:  # so do the issue-24 belt options at their defaults
            data["reinforcement"] = self.reinforcement.canonical()
            if data["reinforcement"].get("belt_depth") == implied_depth(self.mesh.through):
                # a stated depth the wall gave anyway: the same model, one id (a spec
                # from this dict has belt_depth None: equal ids, unequal objects)
                data["reinforcement"].pop("belt_depth", None)
        data["mesh"] = self.mesh.canonical()
        data["contact"] = self.contact.canonical()
        return data

    def editable_dict(self) -> dict[str, Any]:
        """:meth:`to_dict` with every field a study or ``--set`` may change, including
        those ids omit at their default (``mesh.through = 1``): the table that
        ``--set`` overrides and study designs merge into and look swept paths up in
        (``farm.overrides``, ``jobs.design``)."""
        data = {**self.to_dict(), "mesh": dataclasses.asdict(self.mesh),
                "contact": dataclasses.asdict(self.contact)}
        if self.reinforcement is not None:
            data["reinforcement"] = dataclasses.asdict(self.reinforcement)
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ModelSpec:
        return _from_dict(cls, data, "model")

    def mesh_key(self) -> str:
        """Content hash of what the mesh depends on (geometry, density, sector)."""
        return content_hash(
            {
                "kind": self.kind,
                "sector_angle": self.sector_angle,
                "geometry": dataclasses.asdict(self.geometry),
                "mesh": self.mesh.canonical(),
            }
        )


# Combined loads (issue 13): bounds of the road's motion after the vertical deflection.
FRICTION = (0.0, 2.0)  # Coulomb mu: rubber on dry asphalt ~1, on ice ~0.1; 2 is generous
SHIFT_MM = (-50.0, 50.0)  # road translation: the default slab reaches 168 mm beyond the
# wheel plane and the contact patch ~100 mm, so 50 mm keeps the patch on the road
TILT_DEG = (-10.0, 10.0)  # road rotation about x: camber of a road-going tyre is < 10 deg
RISES = ("vertical", "normal")  # RoadMotion.rise: how a tilted road is pushed up
STICK_SLOPE = (1e-3, 1e4)  # N/mm^3


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

    def __post_init__(self) -> None:
        self._check_roll()
        _within("motion.friction", self.friction, FRICTION, "(Coulomb coefficient)")
        _within("motion.shift_x", self.shift_x, SHIFT_MM, "mm")
        _within("motion.shift_y", self.shift_y, SHIFT_MM, "mm")
        _within("motion.tilt", self.tilt, TILT_DEG, "degrees")
        if self.stick_slope is not None:
            _within("motion.stick_slope", self.stick_slope, STICK_SLOPE, "N/mm^3")
        if self.rise not in RISES:
            raise SpecError(f"motion.rise = {self.rise!r}: give one of {', '.join(RISES)}")
        for f in dataclasses.fields(self):  # canonical floats: 1 and 1.0 hash alike
            v = getattr(self, f.name)
            if v is not None and f.name != "rise":
                object.__setattr__(self, f.name, float(v) + 0.0)
        if self.tilt == 0.0:  # an untilted road rises along its normal either way
            object.__setattr__(self, "rise", "vertical")
        elif self.rolls:  # a rolling tyre is pressed along the road's normal, as on a rig
            object.__setattr__(self, "rise", "normal")

    def _check_roll(self) -> None:
        if self.roll == 0.0:
            if (self.slip_ratio or self.slip_angle or self.rolling_radius is not None
                    or self.roll_from):
                raise SpecError("motion.slip_ratio, slip_angle, rolling_radius and roll_from "
                                "belong to a roll: give motion.roll, the road travel in mm")
            return
        if not 0.0 <= self.roll_from < self.roll:
            raise SpecError(f"motion.roll_from = {self.roll_from!r}: the straight part of a "
                            f"roll lies in [0, roll = {self.roll!r}) mm")
        if not (self.slip_ratio or self.slip_angle):  # the same roll, straight throughout
            object.__setattr__(self, "roll_from", 0.0)
        _within("motion.roll", self.roll, ROLL_MM, "mm")
        _within("motion.slip_ratio", self.slip_ratio, SLIP_RATIO, "")
        _within("motion.slip_angle", self.slip_angle, SLIP_ANGLE_DEG, "degrees")
        if self.rolling_radius is not None:
            _within("motion.rolling_radius", self.rolling_radius, ROLLING_RADIUS_MM, "mm")
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
                    rolling_radius=radius)

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
            for name in ("roll", "slip_ratio", "slip_angle", "rolling_radius", "roll_from"):
                del data[name]
            return data
        if self.rolling_radius is None:  # free: found by the worker
            del data["rolling_radius"]
        if not self.roll_from:  # rolls from rest keep the ids they had before trees
            del data["roll_from"]
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> RoadMotion:
        return _from_dict(cls, data, "motion")


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
    """

    friction: float
    slip_ratio: float = 0.0
    slip_angle: float = 0.0
    tilt: float = 0.0
    distance: float = 150.0
    rolling_radius: float = 390.0

    def __post_init__(self) -> None:
        _within("roll.friction", self.friction, FRICTION, "(Coulomb coefficient)")
        _within("roll.slip_ratio", self.slip_ratio, SLIP_RATIO, "")
        _within("roll.slip_angle", self.slip_angle, SLIP_ANGLE_DEG, "degrees")
        _within("roll.tilt", self.tilt, TILT_DEG, "degrees")
        _within("roll.distance", self.distance, ROLL_MM, "mm")
        _within("roll.rolling_radius", self.rolling_radius, ROLLING_RADIUS_MM, "mm")

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


@dataclass(frozen=True)
class SolverSettings:
    """How to run ``ccx``; none of these change a converged result.

    ``initial_increment``, ``min_increment`` and ``max_increment`` are fractions of a
    load ramp (one unit of step time);
    ``timeout`` is wall-clock seconds per ccx run; ``threads`` is passed explicitly
    because a Dask nanny sets ``OMP_NUM_THREADS=1`` for its children.
    """

    threads: int = 1
    timeout: float = 1800.0
    # Fractions of one load ramp. Measured on the full model (200 kPa, 10-30 mm path):
    # 0.1/0.25 took 22 increments, 0.5/0.5 took 15 and 40 % less time, same forces
    # to 0.01 %; the time points cap the road ramp's increments anyway.
    initial_increment: float = 0.25
    min_increment: float = 1e-5
    max_increment: float = 0.5
    max_increments: int = 500
    keep_scratch: bool = False
    # Combined loads: the rise begins a second step (the road still clear of the tyre,
    # held for that step's first increment), so that ccx's increments start small again
    # before contact (farm.ccx.deck.Split; docs/combined-loads.md, "First touch").
    split_rise: bool = False
    # Frictional paths (issue 45): ccx grows an increment only after two in a row that
    # converged within this many iterations (IG of *CONTROLS, TIME INCREMENTATION; ccx's
    # default 4). Contact under friction takes 5-9 iterations an increment, so at 4 its
    # increments never grow after a cutback (docs/rolling.md, "Increments that grow").
    grow_after: int = 4

    def __post_init__(self) -> None:
        low, high = THREADS
        if not (isinstance(self.threads, int) and not isinstance(self.threads, bool)
                and low <= self.threads <= high):
            raise SpecError(f"solver.threads must be an integer in [{low}, {high}], "
                            f"got {self.threads!r}")
        _within("solver.timeout", self.timeout, TIMEOUT_S, "s")
        if not 0 < self.min_increment <= self.initial_increment <= self.max_increment <= 1:
            raise SpecError(
                "solver increments must satisfy 0 < min_increment <= initial_increment <= "
                f"max_increment <= 1, got {self.min_increment}, {self.initial_increment}, "
                f"{self.max_increment}"
            )
        if self.min_increment < MIN_INCREMENT:  # ccx would cut back for ever
            raise SpecError(f"solver.min_increment must be >= {MIN_INCREMENT:g}, got "
                            f"{self.min_increment!r}")
        if not (isinstance(self.max_increments, int) and not isinstance(self.max_increments, bool)
                and 1 <= self.max_increments <= MAX_INCREMENTS):
            raise SpecError(f"solver.max_increments must be an integer in [1, {MAX_INCREMENTS}], "
                            f"got {self.max_increments!r}")
        if not (isinstance(self.grow_after, int) and not isinstance(self.grow_after, bool)
                and 1 <= self.grow_after <= MAX_ITERATIONS):
            raise SpecError(f"solver.grow_after must be an integer in [1, {MAX_ITERATIONS}] "
                            f"(iterations; ccx's default 4), got {shown(self.grow_after)}")
        if not isinstance(self.split_rise, bool):
            raise SpecError("solver.split_rise must be true or false, got "
                            f"{shown(self.split_rise)}")


def content_hash(data: Any) -> str:
    """SHA-256 of the canonical (sorted-key, compact) JSON form of ``data``."""
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def _check_literal(name: str, value: Any, literal: Any) -> None:
    allowed = get_args(literal)
    if value not in allowed:
        raise SpecError(f"{name} must be one of {', '.join(map(repr, allowed))}, "
                    f"got {shown(value)}")


def _from_dict(cls: type, data: Any, where: str) -> Any:
    """Build a (nested) frozen dataclass from plain data, rejecting unknown keys."""
    if not isinstance(data, dict):
        raise SpecError(f"{where} must be a table of keys, got {type(data).__name__} "
                        f"{shown(data)}")
    hints = get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - names)
    if unknown:
        raise SpecError(
            f"unknown key {where}.{unknown[0]}; allowed keys: {', '.join(sorted(names))}"
        )
    kwargs = {}
    for name, value in data.items():
        hint = _optional_dataclass(hints[name]) if value is not None else hints[name]
        if isinstance(hint, type) and dataclasses.is_dataclass(hint):
            value = _from_dict(hint, value, f"{where}.{name}")
        elif typing.get_origin(hint) is tuple:
            if not isinstance(value, list | tuple):
                raise SpecError(f"{where}.{name} must be a list, got {shown(value)}")
            value = tuple(value)
        elif hint is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        elif hint in (float, int) and not _is_number(value, hint):
            raise SpecError(f"{where}.{name} must be a {hint.__name__}, "
                            f"got {shown(value)}")
        kwargs[name] = value
    try:
        return cls(**kwargs)
    except TypeError as e:  # a required key is missing
        raise SpecError(f"{where}: {e}") from e
    except SpecError as e:  # name the key where it is: model.materials.tread.youngs_modulus
        prefix = getattr(cls, "_prefix", None)
        if prefix is None or not str(e).startswith(f"{prefix}."):
            raise
        raise SpecError(where + str(e).removeprefix(prefix)) from e


def _optional_dataclass(hint: Any) -> Any:
    """``X`` for a hint ``X | None`` with ``X`` a dataclass, else ``hint``."""
    args = [a for a in get_args(hint) if a is not type(None)]
    return args[0] if len(args) == 1 and dataclasses.is_dataclass(args[0]) else hint


def _is_number(value: Any, hint: type) -> bool:
    if isinstance(value, bool):
        return False
    if hint is int:
        return isinstance(value, int)
    return isinstance(value, int | float)

