"""Fixtures of the virtual-sensor tests: the surfaces of :mod:`sensor_helpers`."""

from __future__ import annotations

import pytest
import xarray as xr

from analysis.camera.sensor import InnerSurface
from tests.analysis.camera.sensor.sensor_helpers import dataset, torus_nodes
from tests.synthetic import geometry


@pytest.fixture(scope="session")
def torus_ds() -> xr.Dataset:
    return dataset(*torus_nodes())


@pytest.fixture(scope="session")
def torus(torus_ds) -> InnerSurface:
    return InnerSurface.from_dataset(torus_ds)


@pytest.fixture(scope="session")
def cylinder_ds() -> xr.Dataset:
    geo = geometry(9, 24, 4, 8)
    return dataset(geo.inner_xyz, *geo.inner_rc)


@pytest.fixture(scope="session")
def cylinder(cylinder_ds) -> InnerSurface:
    return InnerSurface.from_dataset(cylinder_ds)
