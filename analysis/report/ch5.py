"""Chapter 5 of the reproduction: PCA, PCR, PLSR and Monte Carlo noise on the 200 kPa,
10-40 mm dataset of the full model (thesis §5.3-5.6, Table 5.1, Figs. 5.1-5.12).

The dataset's experiments are the validation's 200 kPa ones (same model and load cases,
hence the same ids): nothing is solved for this stage, it only reads the store.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from analysis.report.stage import StageResult

PRESSURE_MPA = 0.2
DEFLECTIONS_MM = (10.0, 40.0)  # the thesis' dataset: 7 deflections of 10-40 mm (§5.3)
REFERENCE_MM = 30.0  # the experiment the thesis' predictions and Table 5.1 show


def dataset(store, group: str, out: Path, quick: bool = True) -> StageResult:
    """Run the four chapter-5 studies on ``group`` into ``out/ch5``; collect their results.

    ``quick`` draws 100 noise samples per level, else 1000. Tables are keyed
    ``<study>/<table>`` and figures ``<study>/<file stem>``, as the report expects.
    """
    from analysis import data
    from analysis.studies import crosscov, noise, pcr, plsr

    start, stage = time.perf_counter(), StageResult("dataset")
    ds = data.load(store, group, pressure=PRESSURE_MPA)
    d = ds["deflection"].values
    lo, hi = DEFLECTIONS_MM
    ds = ds.isel(experiment=np.flatnonzero((d >= lo - 1e-9) & (d <= hi + 1e-9)))
    folder = out / "ch5"
    reports = {
        "pca": crosscov.run(ds, folder / "pca"),
        "pcr": pcr.run(ds, folder / "pcr", reference_deflection=REFERENCE_MM),
        "plsr": plsr.run(ds, folder / "plsr", reference_deflection=REFERENCE_MM),
        "noise": noise.run(ds, folder / "noise", reference_deflection=REFERENCE_MM,
                           draws=100 if quick else 1000),
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
