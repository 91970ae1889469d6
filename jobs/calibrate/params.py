"""The parameters a calibration fits and how they change the model spec.

Each parameter is fitted as theta = ln(value / start value), so that one finite-
difference step is the same relative change for every parameter and the values stay
positive. ``modulus`` scales all three regions' Young's moduli together (the reduced
model's single rubber, Table 3.1); ``tread``, ``sidewall``, ``bead`` each scale one
region's; ``*_thickness`` change a wall thickness of the geometry (a new mesh).
Poisson's ratios stay at their start values.
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
PARAMETERS = ("modulus", *MODULI, *THICKNESSES)
MODULUS_RANGE = 20.0  # a modulus may move by this factor either way
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

    def start(self) -> dict[str, float]:
        """Start values: MPa for moduli (the tread's for 'modulus'), mm for thicknesses."""
        mats, geo = self.base.materials.by_region(), self.base.geometry
        return {n: (mats["tread"].youngs_modulus if n == "modulus" else
                    mats[n].youngs_modulus if n in MODULI else getattr(geo, n))
                for n in self.names}

    def units(self) -> dict[str, str]:
        return {n: "mm" if n in THICKNESSES else "MPa" for n in self.names}

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
        return dataclasses.replace(self.base, materials=Materials(**regions), geometry=geometry)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds on theta."""
        start = self.start()
        low, high = [], []
        for n in self.names:
            if n in THICKNESSES:
                low.append(math.log(THICKNESS_MM[0] / start[n]))
                high.append(math.log(THICKNESS_MM[1] / start[n]))
            else:
                low.append(-math.log(MODULUS_RANGE))
                high.append(math.log(MODULUS_RANGE))
        return np.array(low), np.array(high)
