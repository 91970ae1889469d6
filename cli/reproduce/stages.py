"""The stages of ``farm reproduce``: each runs on the farm and returns what the report shows.

Every stage is idempotent: sweeps skip what the store holds as done, so a second run of
the whole reproduction re-solves nothing and only redraws tables and figures.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from cli.reproduce import thesis

COARSE_MESH = {"full": "tread = 4\nsidewall = 2\nbead = 1\ncircumferential = 16",
               "reduced": "tread = 4\nsidewall = 2\nbead = 1\ncircumferential = 8"}


@dataclass(frozen=True)
class Options:
    """What to reproduce, where, on which cluster."""

    out: Path
    store: str
    quick: bool = True
    coarse: bool = False
    materials: str = "table-3.1"
    scheduler: str | None = None
    workers: int | None = None

    def mesh_tag(self) -> str:
        return "coarse" if self.coarse else "default"


@dataclass
class StageResult:
    """Tables, figures and notes of one stage, with what it cost."""

    name: str
    tables: dict[str, pd.DataFrame] = field(default_factory=dict)
    figures: dict[str, Path] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    wall_seconds: float = 0.0
    ccx_runs: int = 0
    solver_seconds: float = 0.0
    studies: dict[str, str] = field(default_factory=dict)


def study_text(opts: Options, name: str, kind: str, loads: str) -> str:
    """The TOML of one study of the reproduction (also written next to the report)."""
    mesh = f"[model.mesh]\n{COARSE_MESH[kind]}\n" if opts.coarse else ""
    return (f'[study]\nname = "{name}"\nstore = "{opts.store}"\n'
            f'group = "{kind}-{opts.materials}-{opts.mesh_tag()}"\n\n'
            f'[model]\nkind = "{kind}"\nmaterials = "{opts.materials}"\n{mesh}\n'
            f"[loads]\n{loads}\n")


def _sweep(opts: Options, stage: StageResult, name: str, text: str):
    from jobs.study import parse_study
    from jobs.sweep import run_sweep

    study = parse_study(text, f"{name}.toml")
    stage.studies[name] = text
    report = run_sweep(study, scheduler=opts.scheduler, workers=opts.workers)
    print(f"{name}: {report.total} experiments ({report.skipped} already done), "
          f"{report.ccx_runs} ccx runs, {report.wall_seconds:.1f} s")
    stage.ccx_runs += report.ccx_runs
    stage.solver_seconds += report.solve_seconds
    if not report.ok:
        stage.notes.append(f"{name}: {len(report.failed)} experiments failed: "
                           + "; ".join(sorted(set(report.failed.values())))[:400])
    return study


def validation(opts: Options) -> StageResult:
    """Chapter 3: force-deflection of the full model at 80/200 kPa and the reduced model."""
    import storage

    start, stage = time.perf_counter(), StageResult("validation")
    steps = "deflection_mm = { start = 5, stop = 40, step = 5 }"
    full = _sweep(opts, stage, "ch3-full", study_text(
        opts, "ch3-full", "full", f"pressure_kpa = [80, 200]\n{steps}"))
    reduced = _sweep(opts, stage, "ch3-reduced", study_text(opts, "ch3-reduced", "reduced",
                                                            steps))
    curves, points = {}, []
    for study in (full, reduced):
        ds = storage.done(storage.open_dataset(study.store, study.group_name)).load()
        fz = ds["total_force"].sel(component="z").values
        for d, p, f in zip(ds["deflection"].values, ds["pressure"].values, fz, strict=True):
            name = (f"full {1000 * p:g} kPa" if study.model.inflated else "reduced") + ": Fz N"
            curves.setdefault(name, {})[float(d)] = float(f)
            ref = thesis.FORCE_POINTS.get((study.model.kind, round(1000 * p, 6), float(d)))
            if ref is not None:
                points.append({"case": f"{name[:-6]}, {d:g} mm", "measured Fz N": float(f),
                               "thesis Fz N": ref, "difference %": 100 * (f - ref) / ref})
        if not study.model.inflated:
            stage.tables["reduced model at 30 mm (thesis §3.3.1)"] = _reduced_30(ds)
    table = pd.DataFrame(curves).sort_index().rename_axis("deflection mm").reset_index()
    stage.tables["force-deflection (thesis Fig. 3.3)"] = table
    stage.tables["thesis reference points (§3.3, §3.4)"] = pd.DataFrame(points)
    stage.tables["models (thesis Table 3.1)"] = _table_3_1(full.model, reduced.model)
    stage.figures["force-deflection"] = _force_plot(table, opts.out / "figures")
    stage.wall_seconds = time.perf_counter() - start
    return stage


def _reduced_30(ds) -> pd.DataFrame:
    at = np.flatnonzero(np.isclose(ds["deflection"].values, 30.0))
    if not at.size:
        return pd.DataFrame()
    f = ds["reaction_force"].sel(component="z").values[at[0]]
    loaded = f[f > 0]
    ours = {"Fz N": f.sum(), "contact nodes": loaded.size, "mean nodal force N": loaded.mean(),
            "std nodal force N": loaded.std()}
    return pd.DataFrame([{"quantity": k, "measured": ours[k], "thesis": v}
                         for k, v in thesis.REDUCED_30.items()])


def _table_3_1(full, reduced) -> pd.DataFrame:
    def moduli(m):
        return " / ".join(f"{x.youngs_modulus:g}" for x in m.materials.by_region().values())

    ours = {"Young's modulus tread / sidewall / bead (MPa)": (moduli(reduced), moduli(full)),
            "Poisson's ratio": (f"{reduced.materials.tread.poisson_ratio:g}",
                                f"{full.materials.tread.poisson_ratio:g}"),
            "number of elements": (str(reduced.mesh.meridional * reduced.mesh.circumferential),
                                   str(full.mesh.meridional * full.mesh.circumferential)),
            "road boundary condition": (reduced.road, "frictionless contact, exponential"),
            "internal pressure": ("no", "yes")}
    return pd.DataFrame([{"property": name, "thesis reduced": r, "thesis full": f,
                          "here reduced": ours[name][0], "here full": ours[name][1]}
                         for name, r, f in thesis.TABLE_3_1])


def _force_plot(table: pd.DataFrame, folder: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(7, 4.5))
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
    plt.close(fig)
    return path


def dataset(opts: Options) -> StageResult:
    """Chapter 5: PCA, PCR, PLSR and Monte Carlo noise on the 200 kPa, 10-40 mm dataset.

    The dataset's experiments are the validation's 200 kPa ones (same model and load
    cases, hence the same ids): nothing is solved again.
    """
    from analysis import data
    from analysis.studies import crosscov, noise, pcr, plsr

    start, stage = time.perf_counter(), StageResult("dataset")
    group = f"full-{opts.materials}-{opts.mesh_tag()}"
    ds = data.load(opts.store, group, pressure=0.2)
    d = ds["deflection"].values
    ds = ds.isel(experiment=np.flatnonzero((d >= 10 - 1e-9) & (d <= 40 + 1e-9)))
    folder = opts.out / "ch5"
    reports = {
        "pca": crosscov.run(ds, folder / "pca"),
        "pcr": pcr.run(ds, folder / "pcr", reference_deflection=30.0),
        "plsr": plsr.run(ds, folder / "plsr", reference_deflection=30.0),
        "noise": noise.run(ds, folder / "noise", reference_deflection=30.0,
                           draws=100 if opts.quick else 1000),
    }
    for name, report in reports.items():
        for key, frame in report.tables.items():
            stage.tables[f"{name}/{key}"] = frame
        for path in sorted(report.out.glob("*.png")):
            stage.figures[f"{name}/{path.stem}"] = path
    stage.notes.append(f"{ds.sizes['experiment']} experiments at 200 kPa, deflections "
                       f"{', '.join(f'{x:g}' for x in sorted(ds['deflection'].values))} mm")
    stage.wall_seconds = time.perf_counter() - start
    return stage
