"""Cord reinforcement of the tyre wall: carcass plies and belts (issue 15, thesis §6.2).

The thesis' model is cordless rubber (Table 3.1); a real radial tyre carries its
inflation load in textile carcass cords running bead to bead and stiff belts running
nearly round the crown. Without them the model balloons under pressure (8 mm growth at
200 kPa in the thesis' model, at most 4 mm in the real tyre, §3.4).

Representation: truss elements (ccx ``T3D2``, a genuine two-node truss with an area
from ``*SOLID SECTION``) along the edges of the existing hexahedra, sharing their
nodes. The rubber stays Neo-Hookean: ccx gives one material per element, so a
homogenised orthotropic layer (``*ELASTIC, TYPE=ENGINEERING CONSTANTS`` with a
cylindrical ``*ORIENTATION``) would replace the hyperelastic rubber of a one-element
wall rather than add to it. This is the "rebar" idea of embedded reinforcement
(Helnwein, Liu, Meschke, Mang, "A new 3-D finite element model for cord-reinforced
rubber composites", Finite Elem. Anal. Des. 14 (1993) 1-16; Abaqus' ``*REBAR``).

A ply of cords of diameter ``d`` at centre spacing ``s`` carries ``A/w = pi d^2/4/s``
mm^2 of cord per mm of ply width. Cords at an angle ``theta`` to the circumferential
direction are mapped on the mesh's two edge directions by netting theory (rubber
carries no load, the cords only their axial force): a balanced +-theta ply pair adds
the membrane stiffness ``E_c A/w cos^4 theta`` round the tyre and ``E_c A/w sin^4
theta`` along the meridian (Clark (ed.), "Mechanics of Pneumatic Tires", NHTSA 1981,
ch. 7 on cord-rubber laminates; Gough's netting analysis). The pair's in-plane shear
stiffness (``sin^2 cos^2``) is not represented: edges carry axial force only. Radial
carcass cords (``theta = 90``) need none of this: they lie on the meridional edges.

Opt-in (issue 24, docs/reinforcement.md): ``belt_layout = "cords"`` lays each belt ply
along its own cord direction (:mod:`farm.ccx.belt_cords`), which restores the pair's
shear stiffness and puts the belts outboard of the cavity when the wall is layered;
``tension_only = True`` lets the cords go slack in compression; ``belt_depth`` (issue 44)
puts belts along their cords at a stated fraction of the wall from the cavity face,
with any number of elements through it. At their defaults the three fields are absent
from :meth:`Reinforcement.canonical`, so every existing id stays.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any, ClassVar

from farm.errors import SpecError

MODULUS_GPA = (1e-9, 500.0)  # up to steel wire; ~0 allowed for "no cords" checks
DIAMETER_MM = (0.05, 5.0)
MAX_PLIES = 8
BELT_LAYOUTS = ("edges", "cords")
"""``edges``: belts on the hexahedra's edges (issue 15, no in-plane shear stiffness);
``cords``: members along each ply's cord direction (issue 24, :mod:`farm.ccx.belt_cords`)."""


@dataclass(frozen=True)
class Cords:
    """One cord layer (``plies`` identical plies).

    ``modulus`` is the cord's effective tensile modulus in GPa (polyester ~4, nylon ~3,
    steel cord ~150: a twisted cord is softer than its wire), ``diameter`` and ``spacing``
    (centre to centre, >= diameter) in mm, ``angle`` in degrees from the circumferential
    direction (90 = radial carcass, ~20 = belts).
    """

    _prefix: ClassVar[str] = "cords"
    modulus: float
    diameter: float
    spacing: float
    angle: float
    plies: int = 1

    def __post_init__(self) -> None:
        checks = (("modulus", self.modulus, MODULUS_GPA, "GPa"),
                  ("diameter", self.diameter, DIAMETER_MM, "mm"),
                  ("angle", self.angle, (0.0, 90.0), "degrees"))
        for name, value, (low, high), unit in checks:
            if not (isinstance(value, int | float) and low <= value <= high):
                raise SpecError(f"cords.{name} must be in [{low:g}, {high:g}] {unit}, "
                                f"got {value!r}")
        if not (isinstance(self.spacing, int | float) and self.diameter <= self.spacing <= 50):
            raise SpecError(f"cords.spacing must be in [diameter = {self.diameter:g}, 50] mm "
                            f"(cords cannot overlap), got {self.spacing!r}")
        if not (isinstance(self.plies, int) and 1 <= self.plies <= MAX_PLIES):
            raise SpecError(f"cords.plies must be an integer in [1, {MAX_PLIES}], "
                            f"got {self.plies!r}")

    @property
    def area_per_width(self) -> float:
        """Cord cross-section per mm of ply width, all plies (mm^2/mm)."""
        return self.plies * math.pi * self.diameter**2 / 4.0 / self.spacing

    def membrane_stiffness(self) -> tuple[float, float]:
        """Netting-theory membrane stiffness (N/mm) ``(circumferential, meridional)``."""
        ea = self.modulus * 1e3 * self.area_per_width  # GPa -> MPa
        c, s = math.cos(math.radians(self.angle)), math.sin(math.radians(self.angle))
        return ea * c**4, ea * s**4


def _polyester_carcass() -> Cords:
    return Cords(modulus=4.0, diameter=0.8, spacing=1.2, angle=90.0, plies=2)


def _steel_belts() -> Cords:
    return Cords(modulus=150.0, diameter=0.8, spacing=1.5, angle=20.0, plies=2)


@dataclass(frozen=True)
class Reinforcement:
    """Carcass cords (bead to bead, every region) and belts (under the tread only).

    Defaults: two radial polyester carcass plies and two steel belts at +-20 degrees,
    typical of a radial tyre of this size (Clark 1981, ch. 1).

    ``belt_layout`` chooses the belt members (:data:`BELT_LAYOUTS`); ``tension_only``
    makes every cord member (carcass and belt) slack in compression (ccx ``*SPRING,
    NONLINEAR``, :mod:`farm.ccx.reinforcement`). Both are opt-in (issue 24).

    ``belt_depth`` (issue 44, ``cords`` layout only): where the belts lie through the
    wall, as a fraction of its thickness from the cavity face (0) outwards, between
    mesh nodes or on them (:func:`farm.ccx.belt_cords.belt_surface`). ``None`` keeps
    the placement of before the field: the cavity face on a one-element wall, half the
    wall on an even number of layers. So 0.5 on ONE element through the wall is the
    model of the two-layer wall with a third of its nodes (docs/mesh-convergence.md).
    """

    _prefix: ClassVar[str] = "reinforcement"
    carcass: Cords = field(default_factory=_polyester_carcass)
    belt: Cords = field(default_factory=_steel_belts)
    belt_layout: str = "edges"
    tension_only: bool = False
    belt_depth: float | None = None

    def __post_init__(self) -> None:
        for name in ("carcass", "belt"):
            if not isinstance(getattr(self, name), Cords):
                raise SpecError(f"reinforcement.{name} must be a cord layer, "
                                f"got {getattr(self, name)!r}")
        if self.belt_layout not in BELT_LAYOUTS:
            raise SpecError(f"reinforcement.belt_layout must be one of "
                            f"{', '.join(map(repr, BELT_LAYOUTS))}, got {self.belt_layout!r} "
                            f"(e.g. --set reinforcement.belt_layout=cords)")
        if not isinstance(self.tension_only, bool):
            raise SpecError(f"reinforcement.tension_only must be true or false, got "
                            f"{self.tension_only!r} (e.g. --set reinforcement.tension_only=true)")
        self._check_depth()

    def _check_depth(self) -> None:
        d = self.belt_depth
        if d is None:
            return
        if not (isinstance(d, int | float) and not isinstance(d, bool) and 0 <= d < 1):
            raise SpecError(f"reinforcement.belt_depth must be a fraction of the wall in "
                            f"[0, 1) from the cavity face (0.5: half the wall), got {d!r}")
        if self.belt_layout != "cords":
            raise SpecError("reinforcement.belt_depth places belts along their cords: set "
                            "reinforcement.belt_layout=cords with it, or drop belt_depth")
        object.__setattr__(self, "belt_depth", float(d))  # 0 and 0.0: one id

    def canonical(self) -> dict[str, Any]:
        """The layers as hashed in ids: the issue-24 options only when they are used, so
        the ids of every reinforced model from before them stay (as ``mesh.window``)."""
        data = asdict(self)
        if self.belt_layout == "edges":
            del data["belt_layout"]
        if not self.tension_only:
            del data["tension_only"]
        if self.belt_depth is None:
            del data["belt_depth"]
        return data

    def depth_on(self, through: int) -> float:
        """The belts' depth (fraction of the wall from the cavity face) on a wall of
        ``through`` elements: ``belt_depth``, or the placement before it existed (a spec
        refuses an odd layered wall without a stated depth: ModelSpec)."""
        depth = self.belt_depth if self.belt_depth is not None else implied_depth(through)
        assert depth is not None, "an odd layered wall needs a stated belt depth"
        return depth


def implied_depth(through: int) -> float | None:
    """Where belts along their cords lie with ``belt_depth = None``: the cavity face of
    a one-element wall, the node layer at half an even layered one; None for an odd
    layered wall, which has no node layer at half its depth."""
    if through == 1:
        return 0.0
    return 0.5 if through % 2 == 0 else None
