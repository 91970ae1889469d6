"""Small synthetic inner surfaces for the virtual-sensor tests (no store on disk).

- ``torus``: a full tyre-like revolve, 12 rows x 72 columns (5° apart), crown radius
  330 mm; column 0 sits at 100°, so both the index seam (column 71 -> 0, between 95° and
  100°) and the +-pi seam (between columns 15 and 16) lie away from the contact centre,
  and the store's node order is shuffled.
- ``cylinder``: the shape of ``tests.synthetic``'s groups: a 300 mm cylinder, y in
  [-100, 100] mm (so s = y), a ±60° sector (not periodic).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

ROWS, COLS, CROWN, STEP_DEG, FIRST_DEG = 12, 72, 330.0, 5.0, 100.0


def torus_nodes(rows=ROWS, cols=COLS, first_deg=FIRST_DEG, step_deg=STEP_DEG, seed=0):
    """(xyz (N, 3), row (N,), col (N,)) of a revolve, nodes in a shuffled store order."""
    phi = np.linspace(-1.2, 1.2, rows)
    r = CROWN - 40.0 * (1.0 - np.cos(phi))
    y = 130.0 * np.sin(phi)
    theta = np.radians(first_deg + step_deg * np.arange(cols))
    R, C = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    xyz = np.stack([r[R] * np.sin(theta[C]), y[R], -r[R] * np.cos(theta[C])], -1).reshape(-1, 3)
    order = np.random.default_rng(seed).permutation(rows * cols)
    return xyz[order], R.ravel()[order].astype(np.int32), C.ravel()[order].astype(np.int32)


def dataset(xyz, row, col) -> xr.Dataset:
    """A hand-made group with just the inner surface's variables."""
    return xr.Dataset(
        {"inner_xyz": (("inner_node", "component"), xyz, {"units": "mm"}),
         "inner_row": ("inner_node", row, {"units": "1"}),
         "inner_col": ("inner_node", col, {"units": "1"})},
        coords={"inner_node": np.arange(xyz.shape[0]) + 1001, "component": ["x", "y", "z"]},
        attrs={"group": "hand"})
