"""Strains on the inner surface in its local frame, as the in-tyre camera reports them.

The local frame at each inner node (docs/architecture.md, "Units and axes"): ``e1`` circumferential
(the rolling direction, +x under the wheel centre), ``e2`` along the meridian (lateral,
+y on the crown), ``e3 = e1 x e2`` the surface normal pointing into the cavity.

Two strain measurements are derived:

* the solver's strain, integration points extrapolated to the nodes by ccx (thesis
  §4.2), rotated into the local frame;
* the surface strain of T2Cam (thesis §2.2, Feldesi et al. 2020): a constant-strain
  triangle (CST) from a node and two grid neighbours, four such triangles around each
  node, their strains averaged. We use the Green-Lagrange measure, which - unlike the
  small-strain one - is exactly zero for any rigid-body motion, and matches the
  Lagrange strain ccx reports under NLGEOM.

Shear components are tensor components (eps_xy = gamma_xy / 2), as ccx writes them.
"""

from __future__ import annotations

import numpy as np

VOIGT = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0))
"""ccx's order of strain components: xx, yy, zz, xy, yz, zx."""


def surface_frames(grid_xyz: np.ndarray) -> np.ndarray:
    """Local frames of a structured surface grid.

    Parameters
    ----------
    grid_xyz : ndarray, shape (rows, cols, 3)
        Node positions; rows run along the meridian, columns around the axis (y).

    Returns
    -------
    ndarray, shape (rows, cols, 3, 3)
        Row ``k`` of each 3x3 matrix is ``e_{k+1}`` (so ``Q @ v`` gives local components).
    """
    phi = np.arctan2(grid_xyz[..., 0], -grid_xyz[..., 2])
    e1 = np.stack([np.cos(phi), np.zeros_like(phi), np.sin(phi)], axis=-1)
    meridian = np.gradient(grid_xyz, axis=0)
    e2 = meridian - np.sum(meridian * e1, axis=-1, keepdims=True) * e1
    e2 /= np.linalg.norm(e2, axis=-1, keepdims=True)
    e3 = np.cross(e1, e2)
    return np.stack([e1, e2, e3], axis=-2)


def tensor_from_voigt(v: np.ndarray) -> np.ndarray:
    """(..., 6) ccx components -> symmetric (..., 3, 3) tensors."""
    t = np.empty((*v.shape[:-1], 3, 3))
    for k, (i, j) in enumerate(VOIGT):
        t[..., i, j] = t[..., j, i] = v[..., k]
    return t


def rotate_to_surface(strain: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """Global strains (n, 6) -> local (n, 3) components xx, yy, xy; ``frames`` (n, 3, 3)."""
    local = frames @ tensor_from_voigt(strain) @ np.swapaxes(frames, -1, -2)
    return np.stack([local[:, 0, 0], local[:, 1, 1], local[:, 0, 1]], axis=-1)


def _neighbours(a: np.ndarray, periodic: bool) -> dict[str, np.ndarray]:
    """Grid-shifted copies of ``a`` (rows, cols, 3): NaN beyond a non-periodic edge."""
    nan_row = np.full_like(a[:1], np.nan)
    nan_col = np.full_like(a[:, :1], np.nan)
    out = {
        "N": np.concatenate([a[1:], nan_row]),  # next row (meridian)
        "S": np.concatenate([nan_row, a[:-1]]),
    }
    if periodic:
        out["E"], out["W"] = np.roll(a, -1, axis=1), np.roll(a, 1, axis=1)
    else:
        out["E"] = np.concatenate([a[:, 1:], nan_col], axis=1)
        out["W"] = np.concatenate([nan_col, a[:, :-1]], axis=1)
    return out


def _triangle_strain(dX1, dX2, dx1, dx2, e1):
    """Green-Lagrange strain (xx, yy, xy) of triangles in the frame of ``e1``.

    ``dX*`` are reference and ``dx*`` deformed edge vectors from the centre node,
    all (..., 3); ``e1`` is the centre node's circumferential axis.
    """
    m = np.cross(dX1, dX2)
    m /= np.linalg.norm(m, axis=-1, keepdims=True)
    a1 = e1 - np.sum(e1 * m, axis=-1, keepdims=True) * m
    a1 /= np.linalg.norm(a1, axis=-1, keepdims=True)
    a2 = np.cross(m, a1)
    ref = np.stack([np.stack([np.sum(dX1 * a1, -1), np.sum(dX2 * a1, -1)], -1),
                    np.stack([np.sum(dX1 * a2, -1), np.sum(dX2 * a2, -1)], -1)], -2)
    gram = np.stack([np.stack([np.sum(dx1 * dx1, -1), np.sum(dx1 * dx2, -1)], -1),
                     np.stack([np.sum(dx2 * dx1, -1), np.sum(dx2 * dx2, -1)], -1)], -2)
    valid = np.isfinite(ref).all(axis=(-1, -2)) & np.isfinite(gram).all(axis=(-1, -2))
    inv = np.linalg.inv(np.where(valid[..., None, None], ref, np.eye(2)))  # missing: dummy
    c = np.swapaxes(inv, -1, -2) @ gram @ inv
    e = 0.5 * (c - np.eye(2))
    out = np.stack([e[..., 0, 0], e[..., 1, 1], e[..., 0, 1]], axis=-1)
    return np.where(valid[..., None], out, np.nan)


def cst_surface_strain(ref_xyz: np.ndarray, cur_xyz: np.ndarray, periodic: bool) -> np.ndarray:
    """T2Cam surface strain at every grid node, (rows, cols, 3): xx, yy, xy.

    Parameters
    ----------
    ref_xyz, cur_xyz : ndarray, shape (rows, cols, 3)
        Reference and current positions of the inner-surface grid.
    periodic : bool
        Whether columns wrap around (full tyre).
    """
    e1 = surface_frames(ref_xyz)[..., 0, :]
    nb_ref, nb_cur = _neighbours(ref_xyz, periodic), _neighbours(cur_xyz, periodic)
    # Four triangles around the node, each spanned counter-clockwise (E, N), (N, W),
    # (W, S), (S, E) seen from the cavity, so their normals agree.
    strains = [
        _triangle_strain(nb_ref[a] - ref_xyz, nb_ref[b] - ref_xyz,
                         nb_cur[a] - cur_xyz, nb_cur[b] - cur_xyz, e1)
        for a, b in (("E", "N"), ("N", "W"), ("W", "S"), ("S", "E"))
    ]
    return np.nanmean(np.stack(strains), axis=0)
