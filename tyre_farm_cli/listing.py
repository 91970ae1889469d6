"""``farm sweep list``: the experiments of a store, one record each, for tables and JSON.

Pressure is kPa here, as in study files and ``farm run``; the store keeps MPa (the
farm's internal unit, docs/architecture.md) and the conversion happens at this edge only.
Each done experiment also shows its resultant road force (``total_force``, N): Fz in
every group, Fx and Fy in combined-load groups, where the road slides and tilts (in a
vertical group they are solver noise about zero). A failed or pending experiment has
no forces (None: ``-`` in the table, ``null`` in JSON): its slot holds NaN or the
partial chunks of a writer that died. Groups created since issue 24 also show each done
experiment's contact patch area (``patch_area``, mm2); older groups have none.
"""

from __future__ import annotations

import numpy as np

from storage.paths import StoreLike

#: store parameter -> (record key, factor from the store's unit)
UNITS = {"deflection": ("deflection_mm", 1.0), "pressure": ("pressure_kpa", 1000.0)}
#: record key -> component of ``total_force``, in column order
FORCES = {"fx_n": "x", "fy_n": "y", "fz_n": "z"}
#: record key suffix -> unit, for table headers
SUFFIXES = {"_mm": " mm", "_mm2": " mm2", "_kpa": " kPa", "_n": " N"}
#: record key -> stored per-experiment variable shown for done experiments (issue 24;
#: groups created before it lack them, and list without the column)
SCALARS = {"patch_area_mm2": "patch_area"}


def experiments(store: StoreLike, group: str | None, status: str | None = None
                ) -> list[dict]:
    """Every experiment of ``group`` (every group if None) whose status is ``status`` (all
    if None): group, id, load case, status, error, and the forces of done ones."""
    import storage

    groups = [group] if group else storage.list_groups(store)
    return [row for g in groups for row in _group_rows(store, g, status)]


def header(key: str) -> str:
    """A record key as a table header: ``deflection_mm`` -> ``deflection mm``."""
    for suffix, unit in SUFFIXES.items():
        if key.endswith(suffix):
            return key[: -len(suffix)] + unit
    return key


def _group_rows(store: StoreLike, group: str, status: str | None) -> list[dict]:
    import storage
    from storage.schema import DONE, STATUS_NAMES

    ds = storage.open_dataset(store, group)
    names = storage.parameters(ds)
    forces = _force_keys(ds, names)
    scalars = {key: name for key, name in SCALARS.items() if name in ds}
    extra = [*(["error"] if "error" in ds else []), *(["total_force"] if forces else []),
             *scalars.values()]
    small = ds[["status", *extra]].load()  # the parameters are coordinates, in memory
    codes = np.asarray(small["status"].values).astype(int)
    force = {key: small["total_force"].sel(component=FORCES[key]).values for key in forces}
    rows = []
    for k, exp in enumerate(np.asarray(small["experiment"].values).tolist()):
        name = STATUS_NAMES.get(int(codes[k]), str(codes[k]))
        if not exp or (status is not None and name != status):
            continue  # an unreserved slot past the ids has no experiment to list
        row: dict[str, str | float | None] = {"group": group, "experiment": str(exp)}
        for p in names:
            key, factor = UNITS.get(p, (p, 1.0))
            row[key] = _number(small[p].values[k], factor)
        for key in forces:
            row[key] = _number(force[key][k], 1.0) if codes[k] == DONE else None
        for key, var in scalars.items():
            row[key] = _number(small[var].values[k], 1.0) if codes[k] == DONE else None
        error = str(small["error"].values[k]) if "error" in small else ""
        row.update(status=name, error=error)
        rows.append(row)
    return rows


def _force_keys(ds, names: list[str]) -> list[str]:
    """The force columns of a group: Fz, with Fx and Fy in a combined-load group."""
    from storage.schema import COMBINED_PARAMETERS

    if "total_force" not in ds or "component" not in ds["total_force"].dims:
        return []  # a group written without it: nothing to show, the rest still lists
    combined = any(n in COMBINED_PARAMETERS for n in names)
    return list(FORCES) if combined else ["fz_n"]


def _number(value, factor: float) -> float | None:
    value = round(float(value) * factor, 9)  # 0.2 MPa is 200 kPa, not 200.00000000000003
    return value if np.isfinite(value) else None
