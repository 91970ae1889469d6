"""Result tables (pandas) of chapter 5: one function per table, long format for CSV.

Forces are in N; moments are converted from the store's N mm to N m, as the thesis
prints them (Table 5.1).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from analysis.crosscov import CrossCovariancePCA
from analysis.data import family
from analysis.noise import TOTALS, NoiseResult, contact_mask, nodal_average_std

#: Values quoted in thesis chapter 5, cumulative % of output variance per mode.
THESIS_CUMULATIVE_PCT = {
    ("pcr", "output"): [64.0, 78.0, 91.0],
    ("plsr", "displacement"): [53.8, 79.5, 95.2],
    ("plsr", "strain"): [52.9, 79.6, 96.9],
}
THESIS_NOTE = (
    "The thesis' values come from its own dataset: the full TM700 model on its mesh, "
    "7 deflections of 10-40 mm at 200 kPa. A different mesh, element type, node sets or "
    "deflection range changes the spectra, so differences are expected; they are "
    "reported, not tuned away. Thesis values are cumulative (PCR: eigenvalues of the "
    "output covariance; PLSR: plsregress PCTVAR of Y)."
)
N_MM_TO_N_M = 1e-3


def singular_values(fits: Mapping[str, CrossCovariancePCA]) -> pd.DataFrame:
    """direction, family, mode (1-based), singular_value, ratio_to_first."""
    rows = []
    for direction, fit in fits.items():
        s = fit.singular_values_
        for k, value in enumerate(s, start=1):
            ratio = value / s[0] if s[0] > 0 else 0.0
            rows.append((direction, family(direction), k, value, ratio))
    return pd.DataFrame(
        rows, columns=["direction", "family", "mode", "singular_value", "ratio_to_first"]
    )


def components(
    fits: Mapping[str, CrossCovariancePCA], nodes: pd.DataFrame, n_modes: int, which: str
) -> pd.DataFrame:
    """Long table of W (``which="x"``, per inner node) or V (``"y"``, per tread node)."""
    frames = []
    for direction, fit in fits.items():
        vectors = fit.x_components_ if which == "x" else fit.y_components_
        for k in range(min(n_modes, vectors.shape[1])):
            frames.append(nodes.assign(direction=direction, mode=k + 1, value=vectors[:, k]))
    return pd.concat(frames, ignore_index=True)


def variance_explained(
    ratios: Mapping[str, np.ndarray], n_modes: int | None = None
) -> pd.DataFrame:
    """label, mode, pct, cumulative_pct from per-mode fractions (e.g. PCR eigenvalues)."""
    rows = []
    for label, frac in ratios.items():
        frac = np.asarray(frac)[:n_modes]
        for k, (f, c) in enumerate(zip(frac, np.cumsum(frac), strict=True), start=1):
            rows.append((label, k, 100.0 * f, 100.0 * c))
    return pd.DataFrame(rows, columns=["label", "mode", "pct", "cumulative_pct"])


def pctvar(fits: Mapping[tuple[str, str], np.ndarray]) -> pd.DataFrame:
    """inputs, method, component, x_pct, y_pct and their cumulative sums (plsregress PCTVAR)."""
    rows = []
    for (inputs, method), pv in fits.items():
        cx, cy = np.cumsum(pv[0]), np.cumsum(pv[1])
        for a in range(pv.shape[1]):
            rows.append(
                (inputs, method, a + 1, 100 * pv[0, a], 100 * cx[a], 100 * pv[1, a], 100 * cy[a])
            )
    cols = [
        "inputs",
        "method",
        "component",
        "x_pct",
        "x_cumulative_pct",
        "y_pct",
        "y_cumulative_pct",
    ]
    return pd.DataFrame(rows, columns=cols)


def thesis_comparison(measured: Mapping[tuple[str, str], np.ndarray]) -> pd.DataFrame:
    """Cumulative % for modes 1-3 measured here next to the thesis' values."""
    rows = []
    for key, thesis in THESIS_CUMULATIVE_PCT.items():
        if key in measured:
            ours = 100 * np.cumsum(np.asarray(measured[key]))[: len(thesis)]
            for k, (t, m) in enumerate(zip(thesis, ours, strict=False), start=1):
                rows.append((key[0], key[1], k, t, m))
    return pd.DataFrame(
        rows, columns=["method", "inputs", "mode", "thesis_cum_pct", "measured_cum_pct"]
    )


def predictions(
    tread: pd.DataFrame, reference: np.ndarray, preds: Mapping[int, np.ndarray], inputs: str
) -> pd.DataFrame:
    """Long table: inputs, n_modes, tread node columns, reference, predicted, error."""
    frames = [
        tread.assign(
            inputs=inputs, n_modes=n, reference=reference, predicted=p, error=p - reference
        )
        for n, p in preds.items()
    ]
    return pd.concat(frames, ignore_index=True)


def noise_totals(
    inputs: str,
    result: NoiseResult,
    level: int,
    y_ref: np.ndarray,
    totals: np.ndarray,
    model: str = "",
) -> pd.DataFrame:
    """Table 5.1 rows for one input set at noise level index ``level``.

    Columns: case, inputs, model, sigma, the mean totals Fz (N), Mx, My (N m); then two
    different spreads, each Monte Carlo and analytic:

    - ``<T>_nodal_avg_std``: the thesis' ± (§5.6), the mean over the contact nodes of
      each node's standard deviation (of its force for Fz, of its moment for Mx, My),
      see :func:`analysis.noise.nodal_average_std`;
    - ``<T>_total_std``: the standard deviation of the total itself (zero for the
      moments of symmetric forces).
    """
    mask = contact_mask(y_ref)
    conv = np.array([1.0, N_MM_TO_N_M, N_MM_TO_N_M])
    ref, free = (y_ref @ totals) * conv, (result.reference_prediction @ totals) * conv
    sigma = result.sigmas[level]
    nodal = nodal_average_std(result.node_std[level], totals, mask) * conv
    nodal_a = nodal_average_std(result.node_std_analytic[level], totals, mask) * conv
    zero = np.zeros(12)
    rows = [
        ("reference", "", "virtual experiment", 0.0, *ref, *zero),
        (f"{inputs}", inputs, model, 0.0, *free, *zero),
        (
            f"{inputs} + N(0, {sigma:g})",
            inputs,
            model,
            sigma,
            *(result.totals_mean[level] * conv),
            *nodal,
            *(result.totals_std[level] * conv),
            *nodal_a,
            *(result.totals_std_analytic[level] * conv),
        ),
    ]
    return pd.DataFrame(rows, columns=NOISE_TOTALS_COLUMNS)


NOISE_TOTALS_COLUMNS = [
    "case",
    "inputs",
    "model",
    "sigma",
    *TOTALS,
    *(f"{t}_nodal_avg_std" for t in TOTALS),
    *(f"{t}_total_std" for t in TOTALS),
    *(f"{t}_nodal_avg_std_analytic" for t in TOTALS),
    *(f"{t}_total_std_analytic" for t in TOTALS),
]
TABLE_5_1_NOTE = (
    "± is the thesis' measure (§5.6): the nodal-average standard deviation, the mean over "
    "the contact nodes of each node's standard deviation - of its force for Fz, of its "
    "moment (|y| or |x| times its force) for Mx and My. 'std of the total' is the "
    "standard deviation of the total force or moment itself; for the moments it is zero "
    "whenever the predicted forces are symmetric about the contact centre, as a model "
    "trained on symmetric load cases predicts them. Monte Carlo values; the CSV adds "
    "the exact (analytic) ones."
)


def table_5_1(totals: pd.DataFrame, digits: int = 2) -> pd.DataFrame:
    """Thesis layout of :func:`noise_totals`: "mean ± nodal-average std" per total, then
    the standard deviations of the totals, labelled as such (see ``TABLE_5_1_NOTE``)."""

    def pm(row, t: str) -> str:
        mean = f"{row[t]:.{digits}f}"
        return mean if row["sigma"] == 0 else f"{mean} ± {row[f'{t}_nodal_avg_std']:.{digits}f}"

    units = {"Fz": "N", "Mx": "N m", "My": "N m"}
    out = pd.DataFrame({"case": totals["case"], "model": totals["model"]})
    for t in TOTALS:
        out[f"{t} {units[t]} (± nodal-average std)"] = [pm(r, t) for _, r in totals.iterrows()]
    for t in TOTALS:
        out[f"std of the total {t} {units[t]}"] = totals[f"{t}_total_std"].to_numpy()
    return out


def noise_nodes(
    inputs: str, tread: pd.DataFrame, result: NoiseResult, level: int, y_ref: np.ndarray
) -> pd.DataFrame:
    """Per tread node at one level: reference, prediction, mean error and stds (Fig. 5.11)."""
    return tread.assign(
        inputs=inputs,
        sigma=result.sigmas[level],
        reference=y_ref,
        prediction=result.reference_prediction,
        mean_error=result.node_mean[level] - y_ref,
        std=result.node_std[level],
        std_analytic=result.node_std_analytic[level],
    )


def noise_sweep(
    inputs: str, result: NoiseResult, multipliers: np.ndarray, y_ref: np.ndarray
) -> pd.DataFrame:
    """Per level: mean total Fz, the std of the total, and the thesis' nodal-average std
    (Fig. 5.12 plots the latter)."""
    mask = contact_mask(y_ref)
    return pd.DataFrame(
        {
            "inputs": inputs,
            "multiplier": multipliers,
            "sigma": result.sigmas,
            "Fz_mean": result.totals_mean[:, 0],
            "Fz_total_std": result.totals_std[:, 0],
            "Fz_total_std_analytic": result.totals_std_analytic[:, 0],
            "Fz_nodal_avg_std": result.node_std[:, mask].mean(1),
            "Fz_nodal_avg_std_analytic": result.node_std_analytic[:, mask].mean(1),
        }
    )


def prediction_errors(pred: pd.DataFrame) -> pd.DataFrame:
    """Max and RMS nodal error per input set and mode count, from :func:`predictions`."""
    return (
        pred.assign(abs_error=pred["error"].abs(), sq_error=pred["error"] ** 2)
        .groupby(["inputs", "n_modes"], as_index=False)
        .agg(max_abs_error_N=("abs_error", "max"), rms_error_N=("sq_error", "mean"))
        .assign(rms_error_N=lambda f: np.sqrt(f["rms_error_N"]))
    )
