"""The model family: a tyre's geometry, mesh density, materials, contact law and
:class:`ModelSpec`, with their bounds and checks.

Frozen dataclasses validated once when constructed, so that a model spec that exists is
one that can be meshed and solved; units mm and MPa (docs/architecture.md).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal, get_args

from farm.errors import SpecError, shown
from farm.reinforcement import Reinforcement, implied_depth
from farm.spacing import half_steps
from farm.specs.bounds import STICK_SLOPE, Limit, within
from farm.specs.serial import content_hash, spec_from_dict

ModelKind = Literal["reduced", "full"]
RoadKind = Literal["iterative", "contact"]
CutFaces = Literal["fixed", "free"]

# Bounds of a model (docs/limits.md has the table)
GEOMETRY_MM = (0.1, 10_000.0)  # every length of the profile: up to a 10 m tyre
MODULUS_MPA = (1e-3, 1e6)  # Young's modulus: from a gel (1 kPa) to beyond steel (2e5 MPa)
CLEARANCE_MM = (1e-4, 10.0)  # contact c0
CONTACT_PRESSURE_MPA = (1e-4, 1e3)  # contact p0
MAX_THROUGH = 4  # elements through the wall (issue 15 asks for 2+); 4 keeps the 10 mm
# sidewall's elements 2.5 mm thick, not slivers, on the coarse meshes
#: Mesh nodes of a model read from a study or ``--set`` (:meth:`ModelSpec.check_mesh_nodes`),
#: a practical limit: the default full model has 1760; 200 000 nodes is a day of ccx per
#: load path on one core (ccx's time grows faster than linearly in the node count).
MESH_NODES = Limit("mesh nodes", "FARM_MAX_MESH_NODES", 200_000)


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
            within(f"geometry.{f.name}", getattr(self, f.name), GEOMETRY_MM, "mm")
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
        within("material.youngs_modulus", self.youngs_modulus, MODULUS_MPA, "MPa")
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
        within("contact.clearance", self.clearance, CLEARANCE_MM, "mm")
        within("contact.pressure", self.pressure, CONTACT_PRESSURE_MPA, "MPa")
        if self.stick_slope is not None:
            within("contact.stick_slope", self.stick_slope, STICK_SLOPE, "N/mm^3")

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
        Arithmetic only: :meth:`check_mesh_nodes` needs no mesh."""
        rings = self.mesh.circumferential + (0 if self.is_full else 1)
        return (self.mesh.through + 1) * (self.mesh.meridional + 1) * rings

    def check_mesh_nodes(self, where: str = "model") -> None:
        """Reject a mesh of more than :data:`MESH_NODES` nodes (raises :class:`SpecError`
        naming ``where.mesh``). Not part of construction: a model in a store or a
        convergence level stays a model; what a study or ``--set`` asks for is held to it
        (:func:`farm.overrides.override_model`)."""
        m = self.mesh
        MESH_NODES.check(self.node_estimate, f"{where}.mesh",
                         f"{m.meridional} x {m.circumferential} elements (tread={m.tread}, "
                         f"sidewall={m.sidewall}, bead={m.bead}, circumferential="
                         f"{m.circumferential})")

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
        return spec_from_dict(cls, data, "model")

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


def _check_literal(name: str, value: Any, literal: Any) -> None:
    allowed = get_args(literal)
    if value not in allowed:
        raise SpecError(f"{name} must be one of {', '.join(map(repr, allowed))}, "
                    f"got {shown(value)}")
