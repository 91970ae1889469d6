"""`farm analyse population`: a model trained on one tyre against one trained on a
population, on nominal and on mismatched tyres (issue 47, docs/population.md).

For each of ``repeats`` seeded splits:

- the **nominal-only** model: :func:`analysis.camera.predictor.fit` on the nominal
  tyre's group (its held-out experiments are the "nominal tyres" of the table);
- the **population** model: the same on every group of the population store, holding
  out whole tyres (:class:`analysis.camera.population.Tyres`);
- both applied to the nominal tyre's held-out experiments and to every mismatched tyre
  (:func:`analysis.camera.mismatch.mismatch`: each tyre measured by its own camera, its
  clouds resampled onto the model's points), and the population model also to its own
  held-out tyres.

Errors are RMSE in % of the **nominal** tyre's range of each target (one scale for every
row), with the 90 % intervals' coverage and the share of clouds the model's domain
flags. A noise-free pass (the same splits, the sensor without noise) separates what
the camera's noise costs from what no camera model can remove: two tyres with the same
deformation and different forces (:func:`knowable`).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from analysis.camera import predictor
from analysis.camera.features import TARGETS, targets
from analysis.camera.mismatch import mismatch
from analysis.camera.sensor import SensorSpec
from analysis.render import markdown
from analysis.studies.common import Report

NOMINAL = "nominal held-out"
OWN = "population held-out tyres"
#: issue 47's goals: error growth on mismatched tyres, the population model's cost on
#: nominal tyres, and the intervals' coverage held out
GOAL_GROWTH, GOAL_NOMINAL_COST, GOAL_COVERAGE = 1.3, 1.2, (0.85, 0.95)


def tyre_label(ds: xr.Dataset, nominal: xr.Dataset) -> str:
    """How ``ds``'s tyre differs from ``nominal``'s, from their groups' ``model_spec``
    (e.g. ``"tread.E 13.86, sidewall.E 20.06"``, E a Young's modulus); the group's
    name when the specs are missing or equal."""
    name = str(ds.attrs.get("group", "?"))
    try:
        mine, theirs = (_flat(json.loads(d.attrs["model_spec"])) for d in (ds, nominal))
    except (KeyError, TypeError, ValueError):
        return name
    changed = [f"{'.'.join(k.split('.')[-2:])} {v:g}" if isinstance(v, float)
               else f"{'.'.join(k.split('.')[-2:])} {v}"
               for k, v in mine.items() if theirs.get(k) != v]
    return ", ".join(changed).replace("youngs_modulus", "E") or name


def _flat(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flat(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def run(nominal: xr.Dataset, population: Sequence[xr.Dataset],
        mismatched: Mapping[str, xr.Dataset], sensor: SensorSpec, out: Path, *,
        learner: str = "plsr", repeats: int = 5, draws: int = 3, folds: int = 4,
        test_fraction: float = 0.25, seed: int = 0, intervals: str = "split") -> Report:
    """Fit both models ``repeats`` times (seeds ``seed`` ..), with the sensor and
    noise-free; write ``errors.csv`` (every split), ``summary.csv`` and ``summary.md``.

    Returns
    -------
    Report
        Tables ``errors`` (one row per pass, split, model, tyre set and target) and
        ``summary`` (mean and spread over the splits).
    """
    span = np.ptp(targets(nominal), axis=0)
    rows = []
    for noisy, spec in ((True, sensor), (False, sensor.noise_free())):
        for r in range(repeats):
            s = seed + r
            fitted = {name: predictor.fit(data, spec, learner=learner, draws=draws,
                                          folds=folds, test_fraction=test_fraction, seed=s,
                                          intervals=intervals)
                      for name, data in (("nominal-only", nominal),
                                         ("population", list(population)))}
            test = fitted["nominal-only"][0].info["test"]
            sets = {NOMINAL: nominal.isel(experiment=test), **mismatched}
            for name, (model, check) in fitted.items():
                if name == "population":
                    rows += _rows(check.assign(outside=0.0), noisy, s, name, OWN, span,
                                  from_check=True)
                for tyre, data in sets.items():
                    if name == "nominal-only" and tyre == NOMINAL:
                        table = check.assign(outside=0.0)
                        rows += _rows(table, noisy, s, name, tyre, span, from_check=True)
                        continue
                    table, _, _ = mismatch(model, data, draws=draws, seed=s)
                    rows += _rows(table, noisy, s, name, tyre, span)
    errors = pd.DataFrame(rows)
    report = Report(out)
    report.csv("errors", errors)
    summary = summarise(errors)
    report.csv("summary", summary)
    report.csv("goals", goals(summary, list(mismatched)))
    (out / "summary.md").write_text(_markdown(summary, report.tables["goals"],
                                              knowable(errors), repeats, sensor,
                                              f"{learner}, {intervals} intervals"))
    report.files.append(out / "summary.md")
    return report


def _rows(table: pd.DataFrame, noisy: bool, seed: int, model: str, tyres: str,
          span: np.ndarray, from_check: bool = False) -> list[dict]:
    out = []
    for j, name in enumerate(TARGETS):
        row = table[table["target"] == name].iloc[0]
        coverage = row["heldout_coverage"] if from_check else row["coverage"]
        out.append({"noisy": noisy, "seed": seed, "model": model, "tyres": tyres,
                    "target": name, "rmse": float(row["rmse"]),
                    "rmse_pct": 100.0 * float(row["rmse"]) / span[j],
                    "coverage": float(coverage), "outside": float(row["outside"])})
    return out


def summarise(errors: pd.DataFrame) -> pd.DataFrame:
    """Mean and standard deviation over the splits of each (pass, model, tyres, target),
    with the error's growth over the same model's nominal held-out error (per split)."""
    base = errors[errors["tyres"] == NOMINAL].set_index(["noisy", "seed", "model", "target"])
    growth = errors["rmse"].to_numpy() / base.loc[
        list(zip(errors["noisy"], errors["seed"], errors["model"], errors["target"],
                 strict=True)), "rmse"].to_numpy()
    keys = ["noisy", "model", "tyres", "target"]
    g = errors.assign(growth=growth).groupby(keys, sort=False)
    out = g[["rmse_pct", "growth", "coverage", "outside"]].agg(["mean", "std"])
    out.columns = [f"{a}_{b}" for a, b in out.columns]
    return out.reset_index().assign(splits=g.size().to_numpy())


def goals(summary: pd.DataFrame, mismatched: Sequence[str]) -> pd.DataFrame:
    """Per target, issue 47's goals from the noisy pass's means: each model's largest
    growth and smallest coverage over the mismatched tyres, and the population model's
    error on the nominal tyre over the nominal-only model's (the GOAL_ constants)."""
    s = summary[summary["noisy"]].set_index(["model", "tyres", "target"])
    rows = []
    for name in TARGETS:
        row: dict[str, float | str] = {"target": name}
        for model in ("nominal-only", "population"):
            part = s.loc[[(model, t, name) for t in mismatched]]
            row[f"{model} growth (max)"] = float(part["growth_mean"].max())
            row[f"{model} coverage (min)"] = float(part["coverage_mean"].min())
        row["population / nominal-only on the nominal tyre"] = float(
            s.loc[("population", NOMINAL, name), "rmse_pct_mean"]
            / s.loc[("nominal-only", NOMINAL, name), "rmse_pct_mean"])
        rows.append(row)
    return pd.DataFrame(rows)


def knowable(errors: pd.DataFrame) -> pd.DataFrame:
    """Per target, what limits the population model on tyres it never saw (its held-out
    tyres), as RMSE in % of the nominal range, squared parts adding up:

    - ``learner``: the nominal-only model's noise-free error on nominal held-out tyres
      (one tyre, exact clouds: what the learner and the design leave);
    - ``tyre``: what the population's noise-free error on unseen tyres adds to it
      (sqrt(pop_nf^2 - learner^2)): tyres whose deformation is alike and whose forces
      differ; no camera model removes it;
    - ``sensor``: what the camera's noise adds (sqrt(pop^2 - pop_nf^2)).
    """
    mean = errors.groupby(["noisy", "model", "tyres", "target"])["rmse_pct"].mean()
    rows = []
    for name in TARGETS:
        learner = mean[(False, "nominal-only", NOMINAL, name)]
        unseen_nf = mean[(False, "population", OWN, name)]
        unseen = mean[(True, "population", OWN, name)]
        rows.append({"target": name, "total": unseen, "learner": learner,
                     "tyre": _part(unseen_nf, learner), "sensor": _part(unseen, unseen_nf)})
    return pd.DataFrame(rows)


def _part(a: float, b: float) -> float:
    """sqrt(a^2 - b^2), 0 where b >= a (the part is not resolved)."""
    return float(np.sqrt(max(a * a - b * b, 0.0)))


def _markdown(summary: pd.DataFrame, goal: pd.DataFrame, parts: pd.DataFrame, repeats: int,
              sensor: SensorSpec, learner: str) -> str:
    noisy = summary[summary["noisy"]]
    lines = ["# A population of tyres against one (issue 47)\n",
             f"Sensor {sensor.name} (noise in training and test), learner {learner}, "
             f"{repeats} seeded splits: mean ± standard deviation. RMSE in % of the "
             "nominal tyre's range; growth over the same model's error on the nominal "
             "tyre's held-out experiments; coverage of the 90 % intervals; outside: the "
             "share of clouds the model's domain flags.\n"]
    for model in ("nominal-only", "population"):
        part = noisy[noisy["model"] == model]
        lines.append(f"\n## {model}\n")
        lines.append(markdown.table(pd.DataFrame({
            "tyres": part["tyres"], "target": part["target"],
            "RMSE %": [_pm(m, s) for m, s in zip(part["rmse_pct_mean"], part["rmse_pct_std"],
                                                 strict=True)],
            "growth": [_pm(m, s, 2) for m, s in zip(part["growth_mean"], part["growth_std"],
                                                    strict=True)],
            "coverage": [_pm(m, s, 2) for m, s in zip(part["coverage_mean"],
                                                      part["coverage_std"], strict=True)],
            "outside": [f"{v:.2f}" for v in part["outside_mean"]]})))
    lines.append("\n## Issue 47's goals\n")
    lines.append(f"Growth on mismatched tyres at most {GOAL_GROWTH}x; coverage "
                 f"{GOAL_COVERAGE[0]:.2f}-{GOAL_COVERAGE[1]:.2f}; the population "
                 f"model on the nominal tyre at most {GOAL_NOMINAL_COST}x the "
                 "nominal-only model's error (means over the splits).\n")
    lines.append(markdown.table(goal.round(2)))
    lines.append("\n## What limits the population model on unseen tyres\n")
    lines.append("RMSE % of the nominal range, parts adding in squares (noise-free passes "
                 "of the same splits; `analysis.studies.population.knowable`).\n")
    lines.append(markdown.table(parts.round(2)))
    return "\n".join(lines) + "\n"


def _pm(mean: float, std: float, digits: int = 1) -> str:
    return f"{mean:.{digits}f} ± {std:.{digits}f}" if np.isfinite(std) else f"{mean:.{digits}f}"
