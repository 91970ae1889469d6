"""Chapter 3 of the reproduction, from the store: force-deflection beside the thesis.

Reads the done experiments of the full and the reduced model's groups (their model
specs from the groups' ``model_spec`` attribute) and returns the tables of the report -
the reduced model at 30 mm (§3.3.1), the full model's nodal forces at 30 mm / 80 kPa
(§3.3.2), the force-deflection curves (Fig. 3.3), the thesis' reference points (§3.3,
§3.4), Table 3.1, the contact patch and inflation growth of each experiment (groups
created since issue 24 store them) - and the force-deflection figure.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import storage
from analysis.report import thesis
from analysis.report.stage import StageResult

REGIONS = ("tread", "sidewall", "bead")  # Table 3.1's order (the spec's JSON sorts keys)
# the stage's table names (the report's findings read the first three)
REFERENCE_POINTS = "thesis reference points (§3.3, §3.4)"
FULL_NODAL = "full model at 30 mm, 80 kPa: nodal forces (thesis §3.3.2)"
REDUCED_30 = "reduced model at 30 mm (thesis §3.3.1)"
FORCE_DEFLECTION = "force-deflection (thesis Fig. 3.3)"
MODELS = "models (thesis Table 3.1)"
CONTACT_PATCH = "contact patch and inflation growth"
#: stored variable -> column of the contact-patch table, factor from the store's unit
PATCH_COLUMNS = {
    "patch_area": ("patch area mm2", 1.0), "patch_length": ("length mm", 1.0),
    "patch_width": ("width mm", 1.0), "mean_pressure": ("mean pressure kPa", 1000.0),
    "peak_pressure": ("peak nodal pressure kPa (mesh-dependent)", 1000.0),
    "inflation_growth": ("inflation growth mm", 1.0),
}


def validation(store, full: str, reduced: str, figures: Path) -> StageResult:
    """Tables and figure of the ``validation`` stage from groups ``full`` and ``reduced``."""
    stage = StageResult("validation")
    curves: dict[str, dict[float, float]] = {}  # label -> {deflection: Fz}
    points: list[dict] = []
    specs: list[dict] = []
    nodal: dict[str, pd.DataFrame] = {}
    patches: list[dict] = []
    for group in (full, reduced):
        ds = load(store, group)
        spec = model_spec(ds)
        specs.append(spec)
        for name, column in force_curves(ds, spec).items():
            curves.setdefault(name, {}).update(column)
        points += reference_points(ds, spec)
        patches += patch_rows(ds, spec)
        if spec["kind"] != "full":
            nodal[REDUCED_30] = reduced_30(ds)
        elif len(table := full_30_80(ds)):
            nodal[FULL_NODAL] = table
            stage.notes.append("Nodal mean and std are per contact node: they scale with the "
                               "node spacing and compare with the thesis' (§3.3.2) only on a "
                               "mesh of its spacing.")
    table = pd.DataFrame(curves).sort_index().rename_axis("deflection mm").reset_index()
    stage.tables |= {k: nodal[k] for k in (REDUCED_30, FULL_NODAL) if k in nodal}  # § order
    stage.tables[FORCE_DEFLECTION] = table
    stage.tables[REFERENCE_POINTS] = pd.DataFrame(points)
    stage.tables[MODELS] = table_3_1(*specs)
    if patches:  # groups created before issue 24 hold no patches
        stage.tables[CONTACT_PATCH] = pd.DataFrame(patches)
    stage.figures["force-deflection"] = force_plot(table, figures)
    return stage


def load(store, group: str) -> xr.Dataset:
    """The group's done experiments, in memory (a few dozen rows)."""
    return storage.done(storage.open_dataset(store, group)).load()


def model_spec(ds: xr.Dataset) -> dict:
    """The model spec the group's experiments were solved with (``ModelSpec.to_dict()``)."""
    return json.loads(ds.attrs["model_spec"])


def _label(spec: dict, pressure_mpa: float) -> str:
    return f"full {1000 * pressure_mpa:g} kPa" if spec["kind"] == "full" else "reduced"


def force_curves(ds: xr.Dataset, spec: dict) -> dict[str, dict[float, float]]:
    """Fz [N] by deflection [mm], one curve per model and pressure ("<label>: Fz N")."""
    curves: dict[str, dict[float, float]] = {}
    fz = ds["total_force"].sel(component="z").values
    for d, p, f in zip(ds["deflection"].values, ds["pressure"].values, fz, strict=True):
        curves.setdefault(f"{_label(spec, p)}: Fz N", {})[float(d)] = float(f)
    return curves


def reference_points(ds: xr.Dataset, spec: dict) -> list[dict]:
    """Measured Fz beside the thesis' at its reference points, difference in % of it."""
    rows = []
    fz = ds["total_force"].sel(component="z").values
    for d, p, f in zip(ds["deflection"].values, ds["pressure"].values, fz, strict=True):
        ref = thesis.FORCE_POINTS.get((spec["kind"], round(1000 * p, 6), float(d)))
        if ref is not None:
            rows.append({"case": f"{_label(spec, p)}, {d:g} mm", "measured Fz N": float(f),
                         "thesis Fz N": ref, "difference %": 100 * (f - ref) / ref})
    return rows


def patch_rows(ds: xr.Dataset, spec: dict) -> list[dict]:
    """One row per experiment with a recorded contact patch: case, Fz and the patch
    (``farm.measure.patch``: area, extents, pressures in kPa) and the inflation growth
    (NaN for a model without inflation); none for a group that stores no patches."""
    if "patch_area" not in ds:
        return []
    fz = ds["total_force"].sel(component="z").values
    rows = []
    for k, (d, p) in enumerate(zip(ds["deflection"].values, ds["pressure"].values,
                                   strict=True)):
        if not np.isfinite(ds["patch_area"].values[k]):
            continue
        row = {"case": f"{_label(spec, p)}, {d:g} mm", "Fz N": float(fz[k])}
        row |= {column: factor * float(ds[name].values[k])
                for name, (column, factor) in PATCH_COLUMNS.items() if name in ds}
        rows.append((float(p), float(d), row))
    return [row for *_, row in sorted(rows, key=lambda r: r[:2])]


def nodal_forces(ds: xr.Dataset, deflection: float,
                 pressure_mpa: float | None = None) -> dict[str, float] | None:
    """Fz, contact nodes, mean and std of their forces at one experiment (None: not held).

    Contact nodes are the tread nodes the road pushes (positive nodal Fz).
    """
    hit = np.isclose(ds["deflection"].values, deflection)
    if pressure_mpa is not None:
        hit &= np.isclose(ds["pressure"].values, pressure_mpa)
    at = np.flatnonzero(hit)
    if not at.size:
        return None
    f = ds["reaction_force"].sel(component="z").values[at[0]]
    loaded = f[f > 0]
    return {"Fz N": f.sum(), "contact nodes": loaded.size, "mean nodal force N": loaded.mean(),
            "std nodal force N": loaded.std()}


def _beside_thesis(ours: dict[str, float] | None, theirs: dict[str, float]) -> pd.DataFrame:
    if ours is None:
        return pd.DataFrame()
    return pd.DataFrame([{"quantity": k, "measured": ours[k], "thesis": v}
                         for k, v in theirs.items()])


def reduced_30(ds: xr.Dataset) -> pd.DataFrame:
    """The reduced model at 30 mm: Fz, contact nodes, mean and std of their forces (§3.3.1)."""
    return _beside_thesis(nodal_forces(ds, 30.0), thesis.REDUCED_30)


def full_30_80(ds: xr.Dataset) -> pd.DataFrame:
    """The full model at 30 mm / 80 kPa: mean and std of the contact nodes' forces beside
    the thesis' (§3.3.2); empty if the group holds no such experiment. Per node, these
    scale with the node spacing: they compare only on a mesh of the thesis' spacing."""
    return _beside_thesis(nodal_forces(ds, 30.0, 0.08), thesis.FULL_30_80_NODAL)


def table_3_1(full: dict, reduced: dict) -> pd.DataFrame:
    """Thesis Table 3.1 beside the two models' specs (dicts of ``ModelSpec.to_dict()``)."""

    def moduli(m: dict) -> str:
        return " / ".join(f"{m['materials'][r]['youngs_modulus']:g}" for r in REGIONS)

    def elements(m: dict) -> str:
        mesh = m["mesh"]
        meridional = mesh["tread"] + 2 * (mesh["sidewall"] + mesh["bead"])
        return str(meridional * mesh["circumferential"])

    def poisson(m: dict) -> str:
        return f"{m['materials']['tread']['poisson_ratio']:g}"

    ours = {"Young's modulus tread / sidewall / bead (MPa)": (moduli(reduced), moduli(full)),
            "Poisson's ratio": (poisson(reduced), poisson(full)),
            "number of elements": (elements(reduced), elements(full)),
            "road boundary condition": (reduced["road"], "frictionless contact, exponential"),
            "internal pressure": ("no", "yes")}
    return pd.DataFrame([{"property": name, "thesis reduced": r, "thesis full": f,
                          "here reduced": ours[name][0], "here full": ours[name][1]}
                         for name, r, f in thesis.TABLE_3_1])


def force_plot(table: pd.DataFrame, folder: Path) -> Path:
    """``folder/force_deflection.png``: the measured curves, the thesis' points as stars."""
    folder.mkdir(parents=True, exist_ok=True)
    fig = Figure(figsize=(7, 4.5))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    for column in table.columns[1:]:
        ax.plot(table["deflection mm"], table[column], "o-", label=column[:-6] + ": this farm")
    for (kind, kpa, d), fz in thesis.FORCE_POINTS.items():
        label = f"{kind} {kpa:g} kPa" if kind == "full" else "reduced"
        ax.plot([d], [fz], "k*", ms=12)
        ax.annotate(f"thesis {label}", (d, fz), textcoords="offset points", xytext=(6, -12))
    ax.set(xlabel="deflection [mm]", ylabel="vertical force Fz [N]",
           title="Force-deflection (thesis reference points as stars)")
    ax.grid(alpha=0.3)
    ax.legend()
    path = folder / "force_deflection.png"
    fig.savefig(path, dpi=120, bbox_inches="tight")
    return path
