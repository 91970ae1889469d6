"""analysis.axes: a selection's forces in the road's axes (issue 45)."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from analysis import data
from analysis.axes import in_axes
from analysis.errors import ParameterError
from farm.measure.axes import road_axes


def _selection() -> xr.Dataset:
    rng = np.random.default_rng(0)
    force = rng.normal(scale=100.0, size=(3, 3))
    nodal = rng.normal(size=(3, 4, 3))
    return xr.Dataset(
        {"total_force": (("experiment", "component"), force),
         "moment": (("experiment", "component"), 10 * force),
         "reaction_force": (("experiment", "tread_node", "component"), nodal),
         "displacement": (("experiment", "inner_node", "component"), nodal)},
        coords={"component": ["x", "y", "z"], "tilt": ("experiment", [0.0, 2.0, -3.0]),
                "experiment": ["a", "b", "c"]},
        attrs={"store": "s", "group": "g"})


def test_road_axes_turn_each_experiment_by_its_tilt_and_keep_the_fields():
    ds = _selection()
    road = in_axes(ds, "road")
    for k, tilt in enumerate([0.0, 2.0, -3.0]):
        want = road_axes(tilt) @ ds["total_force"].values[k]
        np.testing.assert_allclose(road["total_force"].values[k], want, atol=1e-12)
        np.testing.assert_allclose(road["reaction_force"].values[k],
                                   ds["reaction_force"].values[k] @ road_axes(tilt).T)
    np.testing.assert_array_equal(road["total_force"].values[0], ds["total_force"].values[0])
    np.testing.assert_array_equal(road["displacement"].values, ds["displacement"].values)
    assert road["total_force"].dims == ds["total_force"].dims
    assert "road's axes" in data.selection_text(road)
    assert in_axes(ds, "wheel") is ds
    with pytest.raises(ParameterError, match="wheel, road"):
        in_axes(ds, "tyre")
