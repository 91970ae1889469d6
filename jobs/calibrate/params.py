"""The parameters a calibration fits and how they change the model spec.

Each parameter is fitted as theta = ln(value / start value), so that one finite-
difference step is the same relative change for every parameter and the values stay
positive. ``modulus`` scales all three regions' Young's moduli together (the reduced
model's single rubber, Table 3.1); ``tread``, ``sidewall``, ``bead`` each scale one
region's; ``*_thickness`` change a wall thickness of the geometry (a new mesh);
``carcass_modulus`` and ``belt_modulus`` scale a cord layer's modulus (reinforced models).
Poisson's ratios stay at their start values.

Bounds (issue 24): a cordless model's moduli are effective moduli of rubber and cords
together (thesis §3.2 varies them "to recreate the macroscopic behaviour"), so they may
move by :data:`MODULUS_RANGE` either way. A reinforced model's cords carry the structure
and its rubber must stay rubber: :data:`RUBBER_MPA` bounds each region, and a cord
layer stays within its material's range (:data:`CORD_GPA`, textile or steel by its
start value).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from farm.specs import Material, Materials, ModelSpec
from jobs.errors import StudyError

MODULI = ("tread", "sidewall", "bead")
THICKNESSES = ("tread_thickness", "sidewall_thickness", "bead_thickness")
CORDS = ("carcass_modulus", "belt_modulus")
PARAMETERS = ("modulus", *MODULI, *THICKNESSES, *CORDS)
MODULUS_RANGE = 20.0  # a cordless model's modulus may move by this factor either way
RUBBER_MPA = (1.0, 20.0)  # tyre rubber compounds (issue 24's bound)
CORD_GPA = {"textile": (1.0, 10.0), "steel": (150.0, 210.0)}  # issue 24's cord ranges
STEEL_FROM_GPA = 100.0  # a cord layer starting at or above this is steel
THICKNESS_MM = (4.0, 38.0)  # below the geometry's limits (a quarter of the section height,
# and room for the shoulders: tread_width < section_width - 2 x sidewall_thickness)


def default_parameters(kind: str, thickness: bool = False) -> tuple[str, ...]:
    """Reduced: one modulus (Table 3.1 has one rubber); full: the three regions."""
    names = ("modulus",) if kind == "reduced" else MODULI
    return names + (THICKNESSES if thickness else ())


@dataclass(frozen=True)
class Parameters:
    """The fitted parameters over a start model (``base``)."""

    names: tuple[str, ...]
    base: ModelSpec

    def __post_init__(self) -> None:
        unknown = [n for n in self.names if n not in PARAMETERS]
        if unknown:
            raise StudyError(f"unknown parameter {unknown[0]!r}; choose from "
                             f"{', '.join(PARAMETERS)}")
        if not self.names or len(set(self.names)) != len(self.names):
            raise StudyError("give at least one parameter, each once")
        if "modulus" in self.names and set(MODULI) & set(self.names):
            raise StudyError("'modulus' scales every region: do not combine it with "
                             "tread/sidewall/bead")
        if set(CORDS) & set(self.names) and self.base.reinforcement is None:
            raise StudyError("carcass_modulus/belt_modulus need a reinforced model: start "
                             "from --materials cord-reinforced or reinforced-calibrated")

        for name, value in self.start().items():
            lo, hi = self.range(name)
            if not lo <= value <= hi:
                raise StudyError(f"{name} starts at {value:g} {self.units()[name]}, outside "
                                 f"its range [{lo:g}, {hi:g}]: start from a preset (or --set) "
                                 "inside it")

    @property
    def reinforced(self) -> bool:
        return self.base.reinforcement is not None

    def start(self) -> dict[str, float]:
        """Start values: MPa for moduli (the tread's for 'modulus'), mm for thicknesses,
        GPa for cords."""
        mats, geo = self.base.materials.by_region(), self.base.geometry
        return {n: (mats["tread"].youngs_modulus if n == "modulus" else
                    mats[n].youngs_modulus if n in MODULI else
                    self._layer(n).modulus if n in CORDS else getattr(geo, n))
                for n in self.names}

    def units(self) -> dict[str, str]:
        return {n: "mm" if n in THICKNESSES else "GPa" if n in CORDS else "MPa"
                for n in self.names}

    def _layer(self, name: str):
        assert self.base.reinforcement is not None  # checked in __post_init__
        return getattr(self.base.reinforcement, name.removesuffix("_modulus"))

    def values(self, theta: np.ndarray) -> dict[str, float]:
        return {n: v * math.exp(float(t)) for (n, v), t in
                zip(self.start().items(), theta, strict=True)}

    def spec(self, theta: np.ndarray) -> ModelSpec:
        """The model with parameters ``theta`` (raises SpecError for an impossible one)."""
        factors = dict(zip(self.names, np.exp(np.asarray(theta, float)), strict=True))
        regions = {}
        for region, m in self.base.materials.by_region().items():
            f = factors.get("modulus", factors.get(region, 1.0))
            regions[region] = Material(m.youngs_modulus * float(f), m.poisson_ratio)
        geometry = dataclasses.replace(self.base.geometry, **{
            n: getattr(self.base.geometry, n) * float(factors[n])
            for n in THICKNESSES if n in factors})
        spec = dataclasses.replace(self.base, materials=Materials(**regions), geometry=geometry)
        cords = {n.removesuffix("_modulus"): dataclasses.replace(
            self._layer(n), modulus=self._layer(n).modulus * float(factors[n]))
            for n in CORDS if n in factors}
        if cords:
            assert spec.reinforcement is not None
            spec = dataclasses.replace(
                spec, reinforcement=dataclasses.replace(spec.reinforcement, **cords))
        return spec

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds on theta."""
        start = self.start()
        low, high = [], []
        for n in self.names:
            lo, hi = self.range(n)
            low.append(math.log(lo / start[n]))
            high.append(math.log(hi / start[n]))
        return np.array(low), np.array(high)

    def range(self, name: str) -> tuple[float, float]:
        """The values ``name`` may take, in its unit (see the module's docstring)."""
        start = self.start()[name]
        if name in THICKNESSES:
            return THICKNESS_MM
        if name in CORDS:
            return CORD_GPA["steel" if start >= STEEL_FROM_GPA else "textile"]
        if self.reinforced:
            return RUBBER_MPA
        return start / MODULUS_RANGE, start * MODULUS_RANGE
