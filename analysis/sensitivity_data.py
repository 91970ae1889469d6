"""Outputs of a sensitivity design, read from the store: y (rows, k) and its labels.

A design over model choices (``jobs.design``) has one row per model; the models live
in the store's groups (one group per model, rows with equal models share one), and each
group holds the experiments (load cases) of its model. For each row and each asked load
case (deflection, pressure) this module reads that one experiment and derives:

- ``Fz``: the vertical road force summed over the tread, ``total_force`` z (N);
- ``contact_nodes``: tread nodes carrying road force, as the farm counts them;
- ``contact_area``: the reference-configuration area (mm²) of the tread grid cells
  around those nodes, see :func:`tread_areas`;
- field outputs: the first m principal-component scores, across the design's rows, of
  the inner-surface ``displacement``, ``strain`` or ``surface_strain`` field at that
  load case (the field of one row flattened to N x 3 values, centred over the rows, as
  thesis §5.3 centres its X): which model choices change what T2Cam would see. Groups
  whose meshes differ only round the tyre (``mesh.circumferential``) are compared at the
  coarsest group's nodes, each meridional row interpolated along the angle.

Reads through :mod:`storage` only (``open_dataset``, ``select``, ``verify_done``).
A Sobol' or Morris design cannot drop rows: any row without a done experiment is one
:class:`~analysis.errors.IncompleteDesignError` naming how many rows and which groups.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

import storage
from analysis.errors import (
    CommonMeshError,
    ComponentsError,
    IncompleteDesignError,
    MissingVariableError,
    ParameterError,
)
from storage.schema import DONE, FAILED

SCALARS = ("Fz", "contact_nodes", "contact_area")
FIELDS = ("displacement", "strain", "surface_strain")
UNITS = {"Fz": "N", "contact_nodes": "1", "contact_area": "mm2"}
#: groups named in full in an error message; the rest are counted
SHOWN_GROUPS = 5


@dataclass(frozen=True)
class OutputRequest:
    """Which outputs to read for every row of a design.

    Parameters
    ----------
    deflections : tuple of float
        Deflections (mm) of the load cases.
    pressures : tuple of float or None
        Inflation pressures (MPa; 0: the uninflated reduced model); every (deflection,
        pressure) pair is one load case.
        ``None``: at each deflection, the one pressure the groups hold there (several
        are an error that asks for pressures).
    scalars : tuple of str
        Scalar outputs, a subset of :data:`SCALARS`.
    field : str or None
        A field of :data:`FIELDS` whose PCA scores are outputs too, or None.
    components : int
        Number m of PCA scores per field and load case.
    """

    deflections: tuple[float, ...]
    pressures: tuple[float, ...] | None = None
    scalars: tuple[str, ...] = SCALARS
    field: str | None = None
    components: int = 3

    def __post_init__(self) -> None:
        for name in ("deflections", "pressures"):
            values = getattr(self, name)
            if values is None and name == "pressures":
                continue
            values = tuple(float(v) for v in values)
            low = 0.0 if name == "pressures" else np.nextafter(0.0, 1.0)  # 0: not inflated
            if not values or not all(np.isfinite(v) and v >= low for v in values):
                what = "numbers >= 0" if name == "pressures" else "positive numbers"
                raise ParameterError(f"{name} must be {what}, got {values!r}")
            object.__setattr__(self, name, values)
        unknown = [s for s in self.scalars if s not in SCALARS]
        if unknown:
            raise ParameterError(
                f"unknown scalar output(s) {', '.join(map(repr, unknown))}; known: "
                f"{', '.join(SCALARS)}"
            )
        if self.field is not None and self.field not in FIELDS:
            raise ParameterError(
                f"field must be one of {', '.join(FIELDS)} or None, got {self.field!r}"
            )
        m = self.components
        if isinstance(m, bool) or not isinstance(m, int | np.integer) or m < 1:
            raise ParameterError(f"components must be a positive integer, got {m!r}")
        if not self.scalars and self.field is None:
            raise ParameterError("no output asked: give scalars or a field")


@dataclass(frozen=True)
class DesignOutputs:
    """What :func:`read_outputs` returns.

    Attributes
    ----------
    y : ndarray of shape (rows, k)
        Outputs, one row per design row, one column per output.
    labels : tuple of str, length k
        Name of each column, e.g. ``"Fz d=30mm p=200kPa"``.
    table : pandas.DataFrame
        One row per output: output, quantity, deflection_mm, pressure_kpa, unit,
        explained_variance (the fraction of the field's variance over the rows that a
        PCA score carries; NaN for scalars).
    """

    y: np.ndarray
    labels: tuple[str, ...]
    table: pd.DataFrame


def _case_columns(chosen: dict, unique: list[str], row_of: np.ndarray, case: tuple[float, float],
                  request: OutputRequest, columns: list[np.ndarray], meta: list[dict]) -> None:
    """Append one load case's output columns (its scalars, then its field's scores) and
    their descriptions: ``chosen`` holds each group's experiment at the case."""
    for name in request.scalars:
        per_group = np.array([_scalar(chosen[g], name) for g in unique])
        columns.append(per_group[row_of])
        meta.append(_meta(name, case, UNITS[name], np.nan))
    if request.field is not None:
        scores, explained = _field_scores(chosen, unique, row_of, request)
        unit = "mm" if request.field == "displacement" else "1"
        for i in range(scores.shape[1]):
            columns.append(scores[:, i])
            meta.append(_meta(f"{request.field} PC{i + 1}", case, unit, explained[i]))


def read_outputs(store: Any, groups: Sequence[str], request: OutputRequest) -> DesignOutputs:
    """Outputs y (rows, k) of a design whose row i lives in store group ``groups[i]``.

    Parameters
    ----------
    store : str, path or zarr store
        The study's store.
    groups : sequence of str, length rows
        Store group of each design row (rows with equal models may share a group).
    request : OutputRequest

    Returns
    -------
    DesignOutputs

    Raises
    ------
    IncompleteDesignError
        Some rows have no done experiment at an asked load case (missing, pending or
        failed): the message counts them and names the groups.
    CommonMeshError
        A field output over groups whose inner surfaces differ in their meridional rows
        (groups that differ only in the circumferential count are resampled onto the
        coarsest one's nodes, see the module's section on fields across meshes), or a
        sector that would have to be extrapolated.
    ParameterError
        Several pressures at a deflection and none asked; several experiments of one
        group at one load case (other load parameters differ).
    storage.StoreError
        The store or a group cannot be read (passed through unchanged).
    """
    groups = [str(g) for g in groups]
    if len(groups) < 2:
        raise ParameterError(f"a design needs at least 2 rows, got {len(groups)}")
    unique = list(dict.fromkeys(groups))
    datasets = {g: storage.open_dataset(store, g) for g in unique}
    cases = _load_cases(datasets, request)
    picks = _pick(datasets, cases, groups)
    row_of = np.array([unique.index(g) for g in groups])
    columns: list[np.ndarray] = []
    meta: list[dict] = []
    for case in cases:
        chosen = {g: storage.verify_done(datasets[g].isel(experiment=[picks[g, case]]))
                  for g in unique}
        _case_columns(chosen, unique, row_of, case, request, columns, meta)
    table = pd.DataFrame(meta)
    return DesignOutputs(np.column_stack(columns), tuple(table["output"]), table)


def _meta(quantity: str, case: tuple[float, float], unit: str, explained: float) -> dict:
    d, p = case
    return {
        "output": f"{quantity} d={d:g}mm p={p * 1000:g}kPa",
        "quantity": quantity,
        "deflection_mm": d,
        "pressure_kpa": p * 1000,
        "unit": unit,
        "explained_variance": explained,
    }


def _load_cases(datasets: dict, request: OutputRequest) -> list[tuple[float, float]]:
    """The (deflection, pressure MPa) pairs asked; pressure from the store when not given."""
    if request.pressures is not None:
        return [(d, p) for d in request.deflections for p in request.pressures]
    cases = []
    for d in request.deflections:
        found: set[float] = set()
        for ds in datasets.values():
            sel = storage.select(ds, deflection=d)
            found.update(np.round(np.asarray(sel["pressure"].values, dtype=float), 12))
        if len(found) > 1:
            shown = ", ".join(f"{p * 1000:g}" for p in sorted(found))
            raise ParameterError(
                f"the groups hold several pressures at deflection {d:g} mm ({shown} kPa): "
                "say which (--pressure-kpa)"
            )
        if not found:  # nothing at all: let _pick report every row as missing
            found = {np.nan}
        cases.append((d, found.pop()))
    return cases


def _pick(datasets: dict, cases, groups: list[str]) -> dict:
    """Position of the done experiment of each (group, load case); one error for all gaps."""
    picks: dict = {}
    gaps: dict[str, list[str]] = {}  # group -> what is wrong, per load case
    for g, ds in datasets.items():
        status = np.asarray(ds["status"].values)
        for case in cases:
            d, p = case
            keep = _matching(ds, d, p)
            if len(keep) > 1:
                raise ParameterError(
                    f"group {g!r} holds {len(keep)} experiments at deflection {d:g} mm, "
                    f"pressure {p * 1000:g} kPa (other load parameters differ): a design "
                    "output needs one experiment per model and load case"
                )
            if len(keep) == 0:
                gaps.setdefault(g, []).append("missing")
            elif status[keep[0]] != DONE:
                gaps.setdefault(g, []).append("failed" if status[keep[0]] == FAILED else "pending")
            else:
                picks[g, case] = int(keep[0])
    if gaps:
        raise IncompleteDesignError(_gap_message(gaps, cases, groups))
    return picks


def _matching(ds, d: float, p: float) -> np.ndarray:
    if not np.isfinite(p):
        return np.array([], dtype=int)
    n = ds.sizes["experiment"]
    sel = storage.select(ds.assign_coords(_pos=("experiment", np.arange(n))),
                         deflection=d, pressure=p)
    return np.asarray(sel["_pos"].values, dtype=int)


def _gap_message(gaps: dict[str, list[str]], cases, groups: list[str]) -> str:
    rows = sum(1 for g in groups if g in gaps)
    counts: dict[str, int] = {}
    for states in gaps.values():
        for s in states:
            counts[s] = counts.get(s, 0) + 1
    names = list(gaps)
    shown = ", ".join(names[:SHOWN_GROUPS]) + (
        f" and {len(names) - SHOWN_GROUPS} more" if len(names) > SHOWN_GROUPS else "")
    where = "; ".join(f"{d:g} mm at {p * 1000:g} kPa" if np.isfinite(p) else f"{d:g} mm"
                      for d, p in cases)
    what = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
    return (
        f"{rows} of {len(groups)} design rows ({len(names)} groups: {shown}) lack a done "
        f"experiment at the asked load cases ({where}): {what}; a Sobol/Morris design "
        "cannot drop rows: finish the study (farm sweep resume) or ask for load cases "
        "every model has"
    )


def _scalar(ds, name: str) -> float:
    if name == "Fz":
        return float(_var(ds, "total_force").sel(component="z").values[0])
    if name == "contact_nodes":
        return float(_var(ds, "contact_nodes").values[0])
    forces = np.asarray(_var(ds, "reaction_force").transpose(
        "experiment", "tread_node", "component").values[0], dtype=float)
    in_contact = np.any(forces != 0, axis=1)  # the farm's contact_nodes criterion
    return float(tread_areas_of(ds)[in_contact].sum())


def _var(ds, name: str):
    if name not in ds:
        raise MissingVariableError(
            f"group {ds.encoding.get('farm_group', '?')!r} has no variable {name!r}")
    return ds[name]


def tread_areas_of(ds) -> np.ndarray:
    """:func:`tread_areas` of a group's tread grid (``tread_xyz``, ``tread_row``/``col``)."""
    for name in ("tread_xyz", "tread_row", "tread_col"):
        _var(ds, name)
    row = np.asarray(ds["tread_row"].values, dtype=int)
    col = np.asarray(ds["tread_col"].values, dtype=int)
    if row.min(initial=0) < 0 or col.min(initial=0) < 0:
        raise MissingVariableError(
            f"group {ds.encoding.get('farm_group', '?')!r} has no tread grid positions: "
            "contact_area needs them (drop it from the outputs)")
    xyz = np.asarray(ds["tread_xyz"].transpose("tread_node", "component").values, dtype=float)
    return tread_areas(xyz, row, col)


def tread_areas(xyz: np.ndarray, row: np.ndarray, col: np.ndarray) -> np.ndarray:
    """Tributary area of each node of a structured surface grid, shape (M,), mm².

    Every grid cell (r, c)-(r+1, c+1) whose four corners exist gives a quarter of its
    area to each corner; the area of a (possibly warped) quadrilateral is half the norm
    of the cross product of its diagonals (exact when it is planar). The columns wrap
    around (full tyre) when the last and first column of every row are no farther
    apart than 1.5 times the widest column spacing of that row. The sum of the areas of
    the nodes in contact is then the contact area at the grid's resolution, measured on
    the reference (undeformed) tread.

    Parameters
    ----------
    xyz : ndarray of shape (M, 3)
    row, col : ndarray of shape (M,)
        Grid position of each node.
    """
    xyz = np.asarray(xyz, dtype=float)
    R, C = int(row.max()) + 1, int(col.max()) + 1
    index = np.full((R, C), -1)
    index[row, col] = np.arange(len(xyz))
    areas = np.zeros(len(xyz))
    if R < 2 or C < 2:
        return areas
    cols = list(range(C - 1)) + ([C - 1] if _wraps(xyz, index) else [])
    for c in cols:
        c1 = (c + 1) % C
        corners = np.stack([index[:-1, c], index[:-1, c1], index[1:, c1], index[1:, c]], 1)
        ok = np.all(corners >= 0, axis=1)
        p = xyz[corners[ok]]  # (cells, 4, 3)
        cell = 0.5 * np.linalg.norm(np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1]), axis=1)
        np.add.at(areas, corners[ok].ravel(), np.repeat(cell / 4.0, 4))
    return areas


def _wraps(xyz: np.ndarray, index: np.ndarray) -> bool:
    C = index.shape[1]
    if C < 3:
        return False
    for r in range(index.shape[0]):
        ids = index[r]
        if np.any(ids < 0):
            return False
        spacing = np.linalg.norm(np.diff(xyz[ids], axis=0), axis=1).max()
        if np.linalg.norm(xyz[ids[-1]] - xyz[ids[0]]) > 1.5 * spacing:
            return False
    return True


def _field_scores(chosen: dict, unique: list[str], row_of: np.ndarray,
                  request: OutputRequest) -> tuple[np.ndarray, np.ndarray]:
    """First m PCA scores (rows, m) of the field across the rows, and their variance
    fractions (m,). Signs: the largest loading of each mode is positive."""
    name = request.field
    assert name is not None  # the caller scores a field only when the request names one
    shapes = {g: _var(chosen[g], name).shape[1:] for g in unique}
    grids = {g: _grid(chosen[g]) for g in unique}
    first = unique[0]
    odd = [g for g in unique
           if shapes[g] != shapes[first] or not _same_grid(grids[g], grids[first])]
    if odd:  # only the circumferential count may differ: resample onto the coarsest
        per_group = _resampled(chosen, unique, name, shapes, grids, odd)
    else:  # a common mesh: the fields as stored, nothing interpolated
        per_group = np.stack([
            np.asarray(chosen[g][name].values[0], dtype=float).ravel() for g in unique])
    F = per_group[row_of]
    # numerical rank: variation below 1e-10 of the field's own size is round-off (rows
    # that are the same field up to the last digits must not make a PCA score)
    tol = 1e-10 * float(np.linalg.norm(F))
    F = F - F.mean(axis=0)
    U, S, Vt = np.linalg.svd(F, full_matrices=False)
    rank = int(np.count_nonzero(np.greater(S, tol)))
    m = request.components
    if m > rank:
        raise ComponentsError(
            f"{m} PCA scores of the {name} field asked, but its variation over the "
            f"{F.shape[0]} design rows has rank {rank}: ask for --components {max(rank, 1)} "
            "or fewer"
        )
    signs = np.sign(Vt[np.arange(m), np.argmax(np.abs(Vt[:m]), axis=1)])
    scores = U[:, :m] * S[:m] * signs
    return scores, (S[:m] ** 2) / np.sum(S**2)


def _grid(ds):
    if "inner_row" not in ds or "inner_col" not in ds:
        return None
    return np.asarray(ds["inner_row"].values), np.asarray(ds["inner_col"].values)


def _same_grid(a, b) -> bool:
    if a is None or b is None:
        return a is b
    return all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


# ------------------------------------------------------------- fields across meshes
# A design with a mesh-density parameter (mesh.circumferential: elements round the tyre)
# gives groups whose inner surfaces have the same meridional rows (inner_row) but more
# or fewer columns (inner_col). Their fields are compared at the coarsest group's nodes:
# each meridional row is interpolated linearly along the angle round the spin axis (y,
# TYDEX C, docs/schema.md), periodically for a full tyre (360 degrees) and within the
# sector's own angles for a reduced model (which is not periodic). Linear interpolation
# of a smooth field has an error of at most h^2 / 8 max|f''| for a column spacing h (the
# finer groups' spacing, as every target node lies between two of their columns).
# Displacements are vectors in x, y, z: interpolating them as such would shorten a
# radial displacement between two columns by cos(h / 2) (2 % at 16 columns), so they are
# interpolated as radial, axial and tangential components and turned back at the target
# node's angle. Strains are already in the local surface frame (docs/schema.md) and are
# interpolated component by component. Different meridional counts (tread, sidewall or
# bead densities) stay a CommonMeshError: rows of different meshes are not one curve.


def _angles(xyz: np.ndarray) -> np.ndarray:
    """Angle round the spin axis y, 0 at the contact centre (-z), increasing towards +x."""
    return np.arctan2(xyz[:, 0], -xyz[:, 2])


def _periodic(theta_by_col: np.ndarray) -> bool:
    """A row of column angles (sorted) closes round the tyre: the gap from its last column
    back to its first is no wider than 1.5 times its widest column spacing."""
    if len(theta_by_col) < 3:
        return False
    gaps = np.diff(theta_by_col)
    return bool(2 * np.pi - (theta_by_col[-1] - theta_by_col[0]) <= 1.5 * gaps.max())


def _resampled(chosen: dict, unique: list[str], name: str, shapes: dict, grids: dict,
               odd: list[str]) -> np.ndarray:
    """Each group's field at the coarsest group's inner nodes, shape (groups, N * c)."""
    first = unique[0]
    missing = [g for g in unique if grids[g] is None or "inner_xyz" not in chosen[g]]
    rows = {g: np.unique(grids[g][0]) for g in unique if g not in missing}
    differ = missing or [g for g in unique if not np.array_equal(rows[g], rows[first])]
    if differ:
        g = differ[0]
        raise CommonMeshError(
            f"field outputs need a common mesh: group {first!r} has {shapes[first][0]} inner "
            f"nodes but {g!r} has {shapes[g][0]}"
            + (" (no inner grid to resample)" if missing else
               f" ({len(rows[first])} vs {len(rows[g])} meridional rows: only the "
               "circumferential count may differ, and is resampled)")
            + f"; {len(odd)} of {len(unique)} groups differ. Drop tread/sidewall/bead mesh "
            "parameters from the design's [models] table, or analyse scalar outputs only"
        )
    target = min(unique, key=lambda g: (shapes[g][0], unique.index(g)))
    t_row, _ = grids[target]
    t_theta = _angles(_xyz(chosen[target]))
    out = []
    for g in unique:
        values = np.asarray(chosen[g][name].values[0], dtype=float)  # (N_g, c)
        if g == target:
            out.append(values.ravel())
            continue
        row = grids[g][0]
        theta = _angles(_xyz(chosen[g]))
        local = _to_cylindrical(values, theta) if name == "displacement" else values
        at = np.empty((len(t_row), values.shape[1]))
        for r in np.unique(t_row):
            src = np.flatnonzero(row == r)
            src = src[np.argsort(theta[src])]
            dst = np.flatnonzero(t_row == r)
            at[dst] = _interp_row(theta[src], local[src], t_theta[dst], g, int(r))
        if name == "displacement":
            at = _from_cylindrical(at, t_theta)
        out.append(at.ravel())
    return np.stack(out)


def _xyz(ds) -> np.ndarray:
    return np.asarray(ds["inner_xyz"].transpose("inner_node", "component").values, dtype=float)


def _interp_row(theta: np.ndarray, values: np.ndarray, at: np.ndarray, group: str,
                row: int) -> np.ndarray:
    """Linear interpolation of one meridional row (columns sorted by angle) at ``at``."""
    if _periodic(theta):
        return np.column_stack([np.interp(at, theta, v, period=2 * np.pi) for v in values.T])
    tol = 1e-9 * max(1.0, float(np.ptp(theta)))
    if at.min() < theta[0] - tol or at.max() > theta[-1] + tol:
        raise CommonMeshError(
            f"field outputs: row {row} of group {group!r} spans the angles "
            f"{np.degrees(theta[0]):.4g} to {np.degrees(theta[-1]):.4g} deg, the coarsest "
            f"group's nodes {np.degrees(at.min()):.4g} to {np.degrees(at.max()):.4g} deg: a "
            "sector cannot be extrapolated (the groups are not one sector)"
        )
    return np.column_stack([np.interp(at, theta, v) for v in values.T])


def _to_cylindrical(u: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """x, y, z components -> (radial, axial y, tangential) at angle theta, shape (N, 3)."""
    s, c = np.sin(theta), np.cos(theta)  # position (R sin t, y, -R cos t): e_r = (s, 0, -c)
    return np.column_stack([u[:, 0] * s - u[:, 2] * c, u[:, 1], u[:, 0] * c + u[:, 2] * s])


def _from_cylindrical(w: np.ndarray, theta: np.ndarray) -> np.ndarray:
    s, c = np.sin(theta), np.cos(theta)
    return np.column_stack([w[:, 0] * s + w[:, 2] * c, w[:, 1], -w[:, 0] * c + w[:, 2] * s])
