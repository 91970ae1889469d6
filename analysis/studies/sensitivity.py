"""`farm analyse sensitivity`: Sobol' indices or Morris screening over a model design.

Thesis §6.2 asks for "a more extensive sensitivity study" of the model choices; this
study answers it over the store of a model-space study (``[models]`` in the study file):
which parameters change the tread force, the contact, and the inner-surface fields that
T2Cam would see. Inputs are plain values (the design's matrix, names, bounds and the
group of each row), so that :mod:`analysis` never imports :mod:`jobs`; the CLI
regenerates the design from the study file and passes them in.

Writes ``sensitivity.csv`` (one row per output and parameter), ``outputs.csv`` (what
each output is, its unit and, for PCA scores, the variance fraction it carries),
``design.csv`` (the design's rows, their groups and outputs), ``sensitivity.png`` (bars
with confidence-interval error bars, one panel per output) and ``summary.md`` (the
ranking of the parameters per output).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from analysis.errors import ParameterError, UndefinedVarianceWarning
from analysis.render import markdown
from analysis.render.plots import DPI, new_figure
from analysis.sensitivity import MIN_SWAPPED_ROWS, MorrisScreening, SobolIndices
from analysis.sensitivity_data import DesignOutputs, OutputRequest, read_outputs
from analysis.studies.common import Report

METHODS = ("sobol", "morris")
PANELS_PER_ROW = 3


def _design_table(matrix: np.ndarray, names: Sequence[str], groups: Sequence[str],
                  outputs: DesignOutputs) -> pd.DataFrame:
    """Each design row: its parameters, store group and outputs."""
    design = pd.DataFrame(matrix, columns=list(names)).assign(group=list(groups))
    design = pd.concat([design, pd.DataFrame(outputs.y, columns=list(outputs.labels))], axis=1)
    return design.rename_axis("row").reset_index()


def run(store: Any, matrix: np.ndarray, names: Sequence[str],
        bounds: Sequence[tuple[float, float]], groups: Sequence[str], request: OutputRequest,
        out: Path, *, method: str = "sobol", num_levels: int = 4, num_resamples: int = 1000,
        conf_level: float = 0.95, seed: int = 0, source: str = "") -> Report:
    """Read the design's outputs from ``store``, fit the indices, write the report.

    Parameters
    ----------
    store : the study's store.
    matrix : ndarray of shape (rows, D)
        The design, rows in SALib's sample order.
    names, bounds : the D parameters and their (low, high).
    groups : sequence of str, length rows
        Store group of each row.
    request : what to read (load cases, scalars, field).
    out : output folder.
    method : "sobol" or "morris" (the design's sampler).
    num_levels : Morris grid levels of the design.
    num_resamples, conf_level, seed : bootstrap of the confidence intervals.
    source : where the design came from (the study file), for the summary.
    """
    matrix = np.asarray(matrix, dtype=float)
    est = _estimator(method, names, bounds, num_levels, num_resamples, conf_level, seed)
    est._check_structure(matrix, tuple(names))  # a wrong design fails before the store is read
    outputs = read_outputs(store, groups, request)
    with warnings.catch_warnings():  # outputs without variance: "undefined" in the summary
        warnings.simplefilter("ignore", UndefinedVarianceWarning)
        est.fit(matrix, outputs.y)  # a DegenerateDesignWarning goes on: the CLI shows it
    report = Report(Path(out))
    table = est.to_frame(outputs.labels)
    report.csv("sensitivity", table)
    report.csv("outputs", outputs.table)
    report.csv("design", _design_table(matrix, names, groups, outputs))
    figure = _bars(table, method, conf_level, report.out / "sensitivity.png")
    report.files.append(figure)
    _summary(report, est, method, table, outputs.table, figure,
             rows=len(matrix), groups=len(set(groups)), source=source,
             num_resamples=num_resamples, conf_level=conf_level)
    return report


def _estimator(method, names, bounds, num_levels, num_resamples, conf_level, seed):
    common = {"num_resamples": num_resamples, "conf_level": conf_level, "seed": seed}
    if method == "sobol":
        return SobolIndices(list(names), [list(b) for b in bounds], **common)
    if method == "morris":
        return MorrisScreening(list(names), [list(b) for b in bounds], num_levels=num_levels,
                               **common)
    raise ParameterError(f"method must be one of {', '.join(METHODS)}, got {method!r}")


def _measures(method: str) -> list[tuple[str, str]]:
    """(value column, CI column) of the bars."""
    if method == "sobol":
        return [("S1", "S1_conf"), ("ST", "ST_conf")]
    return [("mu_star", "mu_star_conf")]


def _bars(table: pd.DataFrame, method: str, conf_level: float, path: Path) -> Path:
    """One panel per output: a bar per parameter and measure, CI half-width as error bar."""
    outputs = list(dict.fromkeys(table["output"]))
    ncols = min(PANELS_PER_ROW, len(outputs))
    nrows = -(-len(outputs) // ncols)
    fig, axes = new_figure(nrows, ncols, 4.2 * ncols, 3.2 * nrows)
    measures = _measures(method)
    width = 0.8 / len(measures)
    for ax, name in zip(axes.ravel(), outputs, strict=False):
        part = table[table["output"] == name]
        ax.set_title(name, fontsize=8)
        if part[measures[0][0]].isna().all():
            ax.text(0.5, 0.5, "no variance over the design:\nindices undefined",
                    ha="center", va="center", transform=ax.transAxes, fontsize=8)
            ax.set_xticks([])
            continue
        x = np.arange(len(part))
        for i, (value, conf) in enumerate(measures):
            ax.bar(x + (i - (len(measures) - 1) / 2) * width, part[value], width,
                   yerr=part[conf], capsize=3, label=value)
        ax.set_xticks(x, part["parameter"].map(_short), rotation=30, ha="right", fontsize=7)
        if method == "sobol":  # indices live in [0, 1]; estimates and CIs may overshoot
            low = np.nanmin([part[v] - part[c] for v, c in measures])
            high = np.nanmax([part[v] + part[c] for v, c in measures])
            ax.set_ylim(min(0.0, 1.05 * low), max(1.05, 1.05 * high))
        ax.axhline(0.0, color="k", lw=0.5)
        ax.legend(fontsize=7)
    for ax in axes.ravel()[len(outputs):]:
        ax.set_visible(False)
    what = "Sobol' indices" if method == "sobol" else "Morris mu*"
    fig.suptitle(f"{what}, error bars: {conf_level:.0%} bootstrap confidence interval")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)
    return path


def _short(name: str) -> str:
    """The last two parts of a dotted model path (``tread.youngs_modulus``)."""
    return ".".join(str(name).split(".")[-2:])


def ranking(table: pd.DataFrame, method: str) -> pd.DataFrame:
    """Per output, the parameters from most to least influential (ST, or mu*) with CIs.

    Outputs whose indices are undefined (no variance over the design) say so; parameters
    the design never varied (Sobol' ``note``, see :data:`analysis.sensitivity.NOT_ESTIMABLE`)
    come last, as "not estimable", never as 0 ± 0.
    """
    key, conf = ("ST", "ST_conf") if method == "sobol" else ("mu_star", "mu_star_conf")
    rows = []
    for output, part in table.groupby("output", sort=False):
        if part[key].isna().all():
            rows.append({"output": output, "ranking": "undefined: the output does not vary "
                         "over the design"})
            continue
        if "note" not in part:  # Morris: its design moves every parameter (checked)
            part = part.assign(note="", swapped_rows=0)
        lost = part[part["note"] != ""]
        part = part[part["note"] == ""].sort_values(key, ascending=False)
        text = "; ".join(
            [f"{p} {v:.3g} ± {c:.2g}"
             for p, v, c in zip(part["parameter"], part[key], part[conf], strict=True)]
            + [f"{p} {n} (changed in {s} base rows)"
               for p, n, s in zip(lost["parameter"], lost["note"], lost["swapped_rows"],
                                  strict=True)])
        rows.append({"output": output, "ranking": text})
    return pd.DataFrame(rows)


def _summary(report: Report, est, method: str, table: pd.DataFrame, outputs: pd.DataFrame,
             figure: Path, *, rows: int, groups: int, source: str, num_resamples: int,
             conf_level: float) -> None:
    D = est.n_features_in_
    if method == "sobol":
        design = (f"Sobol'/Saltelli design (calc_second_order=False): N = {est.n_base_samples_} "
                  f"base samples x (D + 2) = {rows} rows over D = {D} parameters")
        measure = ("first-order S1 and total ST Sobol' indices (SALib.analyze.sobol; "
                   "parameters ranked by ST)")
    else:
        design = (f"Morris design: r = {est.n_trajectories_} trajectories x (D + 1) = {rows} "
                  f"rows over D = {D} parameters")
        measure = "Morris mu* (mean absolute elementary effect; SALib.analyze.morris)"
    text = (
        f"{design}, {groups} store groups{f', from `{source}`' if source else ''}. "
        f"Measures: {measure}. Confidence intervals: {num_resamples} bootstrap resamples, "
        f"{conf_level:.0%} level (half-width z times the bootstrap standard deviation, "
        "as SALib reports it)."
    )
    if "note" in table and (table["note"] != "").any():
        lost = table.loc[table["note"] != "", "parameter"].unique()
        text += (f" Not estimable ({', '.join(map(str, lost))}): the design's A -> AB_j swaps "
                 f"changed them in fewer than {MIN_SWAPPED_ROWS} base rows, so their indices "
                 "would be 0 by construction; they are reported as NaN, not as 0.")
    path = markdown.write(
        report.out / "summary.md",
        "Global sensitivity analysis of the model choices (thesis §6.2)",
        [
            ("Design", text),
            ("Outputs", outputs),
            ("Ranking per output (value ± CI half-width)", ranking(table, method)),
            ("Figures", markdown.figure(figure, report.out, "Indices with confidence intervals")),
        ],
    )
    report.files.append(path)
