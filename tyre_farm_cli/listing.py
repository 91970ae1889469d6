"""``farm sweep list``: the experiments of a store, one record each, for tables and JSON.

Pressure is kPa here, as in study files and ``farm run``; the store keeps MPa (the
farm's internal unit, docs/architecture.md) and the conversion happens at this edge only.
"""

from __future__ import annotations

import numpy as np

#: store parameter -> (record key, factor from the store's unit)
UNITS = {"deflection": ("deflection_mm", 1.0), "pressure": ("pressure_kpa", 1000.0)}


def experiments(store: str, group: str | None, status: str | None = None) -> list[dict]:
    """Every experiment of ``group`` (every group if None) whose status is ``status`` (all
    if None): group, id, load case, status, error."""
    import storage

    groups = [group] if group else storage.list_groups(store)
    return [row for g in groups for row in _group_rows(store, g, status)]


def _group_rows(store: str, group: str, status: str | None) -> list[dict]:
    import storage
    from storage.schema import STATUS_NAMES

    ds = storage.open_dataset(store, group)
    names = storage.parameters(ds)
    small = ds[[*names, "status", *(["error"] if "error" in ds else [])]].load()
    codes = np.asarray(small["status"].values).astype(int)
    rows = []
    for k, exp in enumerate(np.asarray(small["experiment"].values).tolist()):
        name = STATUS_NAMES.get(int(codes[k]), str(codes[k]))
        if not exp or (status is not None and name != status):
            continue  # an unreserved slot past the ids has no experiment to list
        row = {"group": group, "experiment": str(exp)}
        for p in names:
            key, factor = UNITS.get(p, (p, 1.0))
            row[key] = _number(small[p].values[k], factor)
        error = str(small["error"].values[k]) if "error" in small else ""
        row.update(status=name, error=error)
        rows.append(row)
    return rows


def _number(value, factor: float) -> float | None:
    value = round(float(value) * factor, 9)  # 0.2 MPa is 200 kPa, not 200.00000000000003
    return value if np.isfinite(value) else None
