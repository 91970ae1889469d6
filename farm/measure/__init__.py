"""Measurements of a virtual experiment: inner-surface displacements and strains, tread forces.

- :mod:`farm.measure.measurement`: a solved state -> the stored measurement;
- :mod:`farm.measure.surface`: pure-numpy geometry of the inner surface (local frames,
  T2Cam's four-CST surface strain). It imports nothing of the farm, so the virtual
  sensor of :mod:`analysis.camera.sensor` uses the same definition of the CST method as the
  stored ``surface_strain`` (the one arrow from ``analysis`` into ``farm``,
  tests/test_layering.py). This ``__init__`` therefore imports nothing.
"""
