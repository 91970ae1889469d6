"""`farm analyse plsr`: PLS regression, SIMPLS beside NIPALS (thesis §5.5, Figs. 5.8-5.10)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr
from sklearn.cross_decomposition import PLSRegression

from analysis.pcr import PCRegression
from analysis.pls import SIMPLSRegression, pctvar_from_scores
from analysis.render import markdown, plots, tables
from analysis.selection import select_n_components
from analysis.studies.common import Report, Selection, fit_simpls, model_inputs


def _prediction_figure(report: Report, sel: Selection, by_count: dict, name: str
                       ) -> tuple[str, Path]:
    """(caption, file) of the tread forces predicted from ``name`` by each count."""
    return (f"Tread forces predicted from {name}",
            plots.predictions(sel.tread, sel.y_ref, by_count,
                              report.out / f"predictions_{name}.png",
                              f"PLSR (SIMPLS) from {name}"))


def run(
    ds: xr.Dataset,
    out: Path,
    *,
    inputs: str | None = None,
    max_modes: int = 5,
    cv: int | None = None,
    nipals: bool = True,
    reference_deflection: float | None = None,
    component: str = "z",
    seed: int | None = None,
) -> Report:
    """SIMPLS with 1..max_modes components per input set, NIPALS beside it, optional CV."""
    sel = Selection.of(ds, component, reference_deflection, study="PLSR (thesis §5.5)")
    report = Report(Path(out))
    pv, preds, agree, cvs, figures = {}, [], [], [], []
    pcr_ratio = None
    for name in model_inputs(ds, inputs):
        moments = sel.moments(name)
        model = fit_simpls(moments, None, cap=max_modes)
        A = model.n_components
        pv[(name, "simpls")] = model.pctvar_
        x_ref = sel.x_ref(name)[None, :]
        by_count = {
            a: SIMPLSRegression(a).fit_moments(moments).predict(x_ref)[0] for a in range(1, A + 1)
        }
        preds.append(tables.predictions(sel.tread, sel.y_ref, by_count, name))
        figures.append(_prediction_figure(report, sel, by_count, name))
        if pcr_ratio is None:
            pcr_ratio = PCRegression().fit_moments(moments).y_explained_variance_ratio_
        if nipals or cv:
            X, Y = np.asarray(sel.X(name).compute()), np.asarray(sel.Y.compute())
        if nipals:
            pv[(name, "nipals")], table = _nipals(name, moments, X, Y, A)
            agree.append(table)
        if cv:
            best, table = select_n_components(
                SIMPLSRegression(), X, Y, cv=cv, seed=seed, max_components=A
            )
            cvs.append(table.assign(inputs=name, chosen=best))
    _tables(report, pv, preds, agree, cvs, pcr_ratio)
    figures.append(("Y variance explained per component", _variance_figure(report, pv, pcr_ratio)))
    _summary(report, sel, figures)
    return report


def _nipals(name, moments, X, Y, A):
    """scikit-learn's NIPALS (scale=False, like plsregress) and its distance to SIMPLS."""
    rows, fit = [], None
    y_norm = np.linalg.norm(Y - Y.mean(0))
    for a in range(1, A + 1):
        fit = PLSRegression(a, scale=False).fit(X, Y)
        ours = SIMPLSRegression(a).fit_moments(moments)
        diff = np.linalg.norm(fit.predict(X).reshape(Y.shape) - ours.predict(X).reshape(Y.shape))
        scale = max(float(np.linalg.norm(ours.coef_)), 1e-300)
        coef = np.linalg.norm(fit.coef_ - ours.coef_) / scale
        rows.append((name, a, diff / y_norm, coef))
    cols = ["inputs", "n_components", "fitted_rel_diff", "coef_rel_diff"]
    assert fit is not None  # A >= 1 (a fitted SIMPLS model's count): the loop ran
    return pctvar_from_scores(fit.x_scores_, X, Y), pd.DataFrame(rows, columns=cols)


def _tables(report, pv, preds, agree, cvs, pcr_ratio) -> None:
    report.csv("pctvar", tables.pctvar(pv))
    report.csv("predictions", pd.concat(preds, ignore_index=True))
    measured = {("plsr", n): v[1] for (n, m), v in pv.items() if m == "simpls"}
    measured[("pcr", "output")] = pcr_ratio
    report.csv("thesis_comparison", tables.thesis_comparison(measured))
    if agree:
        report.csv("simpls_vs_nipals", pd.concat(agree, ignore_index=True))
    if cvs:
        report.csv("cross_validation", pd.concat(cvs, ignore_index=True))


def _variance_figure(report, pv, pcr_ratio) -> Path:
    """Fig. 5.10: % of Y variance per component, PLSR (SIMPLS) per input set and PCR."""
    ratios = {f"PLSR {n}": v[1] for (n, m), v in pv.items() if m == "simpls"}
    n = max(len(v) for v in ratios.values())
    ratios["PCR"] = pcr_ratio[:n]
    path = plots.variance_bars(
        tables.variance_explained(ratios),
        report.out / "variance.png",
        "Variance in Y explained per component (Fig. 5.10)",
    )
    return path


def _summary(report: Report, sel: Selection, figures) -> None:
    sections = [
        ("Selection", sel.describe()),
        ("Percent variance explained (plsregress PCTVAR)", report.tables["pctvar"]),
        (
            "Measured vs thesis (cumulative % of Y variance, modes 1-3)",
            report.tables["thesis_comparison"],
        ),
        ("About the thesis' values", tables.THESIS_NOTE),
        (
            "Prediction error at the reference experiment (SIMPLS)",
            tables.prediction_errors(report.tables["predictions"]),
        ),
    ]
    if "simpls_vs_nipals" in report.tables:
        sections.append(
            (
                "SIMPLS vs scikit-learn NIPALS (relative differences)",
                report.tables["simpls_vs_nipals"],
            )
        )
    if "cross_validation" in report.tables:
        sections.append(
            ("k-fold cross-validation (MSE per component count)", report.tables["cross_validation"])
        )
    report.files += [p for _, p in figures]
    links = "\n\n".join(markdown.figure(p, report.out, c) for c, p in figures)
    sections.append(("Figures", links))
    report.files.append(
        markdown.write(
            report.out / "summary.md", "Partial least squares regression (thesis §5.5)", sections
        )
    )
