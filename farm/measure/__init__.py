"""Measurements of a virtual experiment: inner-surface displacements and strains, tread forces."""

from farm.measure.measurement import Measurement, measure

__all__ = ["Measurement", "measure"]
