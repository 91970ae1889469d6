"""`farm analyse pca`: cross-covariance PCA per direction (thesis §5.3, Figs. 5.1-5.4)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import xarray as xr

from analysis import data
from analysis.crosscov import CrossCovariancePCA, direction_importance
from analysis.render import markdown, plots, tables
from analysis.studies.common import Report, Selection


def default_directions(ds: xr.Dataset) -> tuple[str, ...]:
    """Every direction whose store variable the group has."""
    return tuple(d for d, (var, _, _) in data.DIRECTIONS.items() if var in ds)


def run(
    ds: xr.Dataset, out: Path, *, inputs: str | None = None, n_modes: int = 3, component: str = "z"
) -> Report:
    """Fit one :class:`CrossCovariancePCA` per direction and write tables, maps, summary."""
    sel = Selection.of(ds, component, study="Cross-covariance PCA (thesis §5.3)")
    directions = data.expand_inputs(inputs) if inputs else default_directions(ds)
    fits = {d: CrossCovariancePCA().fit_moments(sel.moments(d)) for d in directions}
    importance = direction_importance({d: f.singular_values_[0] for d, f in fits.items()})
    report = Report(Path(out))
    report.csv("singular_values", tables.singular_values(fits))
    report.csv("importance", importance)
    inner = data.input_index(ds, directions[0]).drop(columns="direction")
    report.csv("eigen_vectors", tables.components(fits, inner, n_modes, "x"))
    report.csv("eigen_forces", tables.components(fits, sel.tread, n_modes, "y"))
    figures = _figures(report, fits, importance, inner)
    _summary(report, sel, importance, figures)
    return report


def _figures(report: Report, fits, importance: pd.DataFrame, inner: pd.DataFrame) -> list:
    """Per unit family: singular values (Fig. 5.1/5.3) and W maps (Fig. 5.2/5.4)."""
    out = []
    sv = report.tables["singular_values"]
    weight = dict(zip(importance["direction"], importance["importance"], strict=True))
    for fam, part in sv.groupby("family", sort=False):
        names = list(dict.fromkeys(part["direction"]))
        p1 = plots.singular_values(
            part,
            report.out / f"singular_values_{fam}.png",
            f"Cross-covariance singular values: {fam}",
        )
        vectors = {d: fits[d].x_components_[:, 0] for d in names}
        p2 = plots.eigen_maps(
            vectors,
            weight,
            inner,
            report.out / f"eigen_maps_{fam}.png",
            f"First eigen-{'deformation' if fam == 'displacement' else 'strain'}",
        )
        report.files += [p1, p2]
        out += [(f"Singular values ({fam})", p1), (f"First mode maps ({fam})", p2)]
    return out


def _summary(report: Report, sel: Selection, importance: pd.DataFrame, figures) -> None:
    sv = report.tables["singular_values"]
    dominance = sv[sv["mode"] == 2][["direction", "ratio_to_first"]].rename(
        columns={"ratio_to_first": "sigma2_over_sigma1"}
    )
    links = "\n\n".join(markdown.figure(p, report.out, c) for c, p in figures)
    path = markdown.write(
        report.out / "summary.md",
        "Cross-covariance PCA (thesis §5.3)",
        [
            ("Selection", sel.describe()),
            (
                "Importance of each direction (σ₁ over the family's strongest σ₁)",
                importance.sort_values(["family", "rank"]),
            ),
            ("Dominance of the first mode", dominance),
            ("Figures", links),
        ],
    )
    report.files.append(path)
