"""A selection's forces and moments in the road's axes (issue 45: camber as the literature
reads it).

The store keeps forces in the wheel's axes; on a tilted road (``tilt``, the camber) the
road's normal force then shows up in Fy. :func:`in_road_axes` gives the same selection
with every force and moment turned into the road's axes (x, y in the road plane, z its
normal: TYDEX W, ISO 8855; :mod:`farm.measure.axes`), experiment by experiment, so that
every analysis learns and reports them there (``farm analyse combined|sensor --axes
road``). The inner surface's fields stay as the camera, fixed to the wheel, sees them.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from analysis.errors import ParameterError
from farm.measure.axes import in_road_axes as turned_vectors

AXES = ("wheel", "road")
#: experiment-wise vectors (component last) that are forces or moments about the
#: contact centre
VECTORS = ("total_force", "moment", "road_reaction", "road_moment", "reaction_force")


def in_axes(ds: xr.Dataset, axes: str) -> xr.Dataset:
    """``ds`` in ``axes``: "wheel" (the store's, unchanged) or "road"."""
    if axes not in AXES:
        raise ParameterError(f"axes must be one of {', '.join(AXES)}, got {axes!r}")
    return ds if axes == "wheel" else in_road_axes(ds)


def in_road_axes(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` with :data:`VECTORS` in the road's axes of each experiment's ``tilt`` (0 or
    absent: the wheel's, unchanged); ``attrs["axes"] = "road"``."""
    tilt = (np.nan_to_num(np.asarray(ds["tilt"].values, dtype=float))
            if "tilt" in ds.variables else np.zeros(ds.sizes["experiment"]))
    out = ds.copy()
    for name in VECTORS:
        if name not in ds:
            continue
        v = ds[name].sel(component=["x", "y", "z"])
        dims = [d for d in v.dims if d != "component"] + ["component"]
        turned = turned_vectors(np.asarray(v.transpose(*dims).values, dtype=float), tilt)
        out[name] = (v.transpose(*dims).copy(data=turned).transpose(*ds[name].dims)
                     .assign_attrs(ds[name].attrs))
    return out.assign_attrs(axes="road")
