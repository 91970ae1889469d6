"""Initial guesses and regularisation on the quick chapter-4 setup, measured (issue 16).

Run: .venv/bin/python benchmarks/bench_inverse.py --guesses [--coarse] [--workers 2] [--out DIR]
     .venv/bin/python benchmarks/bench_inverse.py --regularisation [--coarse] [--out DIR]

Both use the setup of ``farm reproduce --quick``'s chapter-4 stage (the reduced model at
30 mm, ``thesis-calibrated`` materials, least squares with shared Jacobians, tolerance
1e-5; ``--coarse``: its test-sized mesh) and one evaluation cache in ``DIR`` (a re-run
replays it; the store in ``DIR`` keeps every group, so the tables can be redrawn).

- ``--guesses``: first the training data of the "tyre distribution" (thesis §6.2): the
  chapter-3 force-deflection sweep of the reduced model that ``farm reproduce`` runs
  (5-40 mm, Table 3.1 materials, the same mesh); the model leaves out the 30 mm
  experiment (``exclude_within_mm``), so the guess interpolates and never looks the
  reference up. Then one study with one condition per initial guess - the thesis'
  three (90 %; 90 % + N(0, 4 N); uniform + N(0, 4 N)), uniform without noise, the
  thickness offset and the distribution - each without and with measurement noise
  (``--repeats`` draws, default 3), displacement and strain objectives, least squares
  with ``jacobian = "broyden"`` (every loop pays for its own Jacobians; shared ones
  exist only at the scaled/uniform guesses). Printed: evaluations and rounds to
  converge, the nodal error of the guess and of the solution, Fz
  (:func:`analysis.report.ch4_extra.guesses`).
- ``--regularisation``: the noisy conditions (``noise``: 90 %; ``guess-uniform``; and
  ``distribution``, the §6.2 guess) with ``repeats`` draws, once per setting: none;
  ``tikhonov`` (towards zero), ``smoothness`` and ``guess`` (towards the initial guess)
  with the weight each loop chooses by the discrepancy principle at its unregularised
  solution (jobs/inverse/regularisation.py: from the noise level, never the truth); a
  PCA mask (``farm analyse pca`` on the chapter-3 sweep, keep 50 % of the inner nodes,
  §6.2).
  Printed: nodal error std and Fz error per setting beside the thesis' values
  (:func:`analysis.report.ch4_extra.regularisation`).

Wall times depend on the machine's load: measured figures only.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pandas as pd

from analysis.report import ch4_extra
from jobs.inverse.run import run_inverse
from jobs.inverse.study import parse_inverse_study
from jobs.reproduce import validation
from jobs.reproduce.options import COARSE_MESH, Options
from jobs.study import parse_study
from jobs.sweep import run_sweep
from storage.solves import open_solves

# (name, initial, scale, guess sigma N): the thesis' three (§4.3-4.5), then ours
GUESSES = (("scaled-90", "scaled", 0.9, 0.0), ("guess-90", "scaled", 0.9, 4.0),
           ("guess-uniform", "uniform", 1.0, 4.0), ("uniform", "uniform", 1.0, 0.0),
           ("offset", "offset", 1.0, 0.0), ("distribution", "distribution", 1.0, 0.0))
# label -> (regularisation, mask?)
SETTINGS = {"none": ("none", False), "tikhonov": ("tikhonov", False),
            "smoothness": ("smoothness", False), "guess": ("guess", False),
            "mask": ("none", True)}


def _head(name: str, opts: Options, cache: Path, regularisation: str = "none",
          mask: Path | None = None, jacobian: str = "shared", tau: float = 1.0) -> str:
    mesh = f"[model.mesh]\n{COARSE_MESH['reduced']}\n" if opts.coarse else ""
    weight = (f'weight = "discrepancy"\ndiscrepancy = {tau}\n' if regularisation != "none"
              else "")
    text = (f'[study]\nname = "{name}"\nstore = "{opts.store}"\ncache = "{cache}"\nseed = 0\n'
            f'[model]\nkind = "reduced"\nmaterials = "thesis-calibrated"\n{mesh}'
            "[reference]\ndeflection_mm = 30\n[noise]\ndisplacement_mm = 1.0\nstrain = 4e-4\n"
            "[optimizers.least-squares]\nmax_evaluations = 200\nfd_step_n = 0.1\n"
            f'tolerance = 1e-5\njacobian = "{jacobian}"\nregularisation = "{regularisation}"\n'
            f"{weight}")
    if mask is not None:
        text += f'[mask]\neigen_vectors = "{mask}"\nkeep = 0.5\n'
    return text


def _condition(name, initial, scale, sigma, noise, repeats=1) -> str:
    return (f'[[conditions]]\nname = "{name}"\nmethods = ["displacement", "strain"]\n'
            f'initial = "{initial}"\nscale = {scale}\nguess_sigma_n = {sigma}\n'
            f"noise = {str(noise).lower()}\nrepeats = {repeats}\n")


def training_sweep(opts: Options, workers: int) -> str:
    """The chapter-3 reduced sweep of ``farm reproduce`` (the distribution's data)."""
    text = validation.study_text(opts, "ch3-reduced", "reduced", validation.STEPS)
    study = parse_study(text, "ch3-reduced.toml")
    start = time.perf_counter()
    report = run_sweep(study, workers=workers)
    print(f"training sweep {study.group_name}: {report.total} experiments, {report.ccx_runs} "
          f"ccx runs, {time.perf_counter() - start:.1f} s", flush=True)
    return study.group_name


def _distribution(opts: Options, group: str) -> str:
    return (f'[distribution]\nstore = "{opts.store}"\ngroup = "{group}"\n'
            "components = 3\ndegree = 2\nexclude_within_mm = 0.5\n")


def guesses_text(opts: Options, cache: Path, group: str, repeats: int = 3) -> str:
    # broyden, not shared: every loop pays for its own Jacobians (shared ones exist only
    # at the scaled/uniform guesses and would flatter them)
    text = _head("guesses", opts, cache, jacobian="broyden") + _distribution(opts, group)
    for noise in (False, True):
        for name, initial, scale, sigma in GUESSES:
            label = f"{name}{'-noise' if noise else ''}"
            text += _condition(label, initial, scale, sigma, noise, repeats if noise else 1)
    return text


def _run(text: str, name: str, workers: int):
    study = parse_inverse_study(text, f"{name}.toml")
    start = time.perf_counter()
    report = run_inverse(study, workers=workers)
    print(f"{name}: {report.summary()} ({time.perf_counter() - start:.1f} s)", flush=True)
    for label, error in report.errors.items():
        print(f"  {label}: {error}", flush=True)
    return study, report


def _print(title: str, frame: pd.DataFrame) -> None:
    print(title)
    with pd.option_context("display.width", 250, "display.max_columns", 30,
                           "display.float_format", "{:.4g}".format):
        print(frame.to_string(index=False))


def compare_guesses(coarse: bool, workers: int, out: Path, repeats: int = 3) -> None:
    opts = Options(out=out, store=str(out / "thesis.zarr"), quick=True, coarse=coarse)
    group = training_sweep(opts, workers)
    study, _ = _run(guesses_text(opts, out / "evaluations", group, repeats), "guesses",
                    workers)
    _print("initial guesses (evaluations to converge; nodal errors x - x_true, N)",
           ch4_extra.guesses(open_solves(study.store, study.group)))


def pca_mask(opts: Options, group: str, out: Path) -> Path:
    """eigen_vectors.csv of the cross-covariance PCA of the chapter-3 sweep (§5.3)."""
    folder = out / "pca"
    subprocess.run([str(Path(sys.executable).parent / "farm"), "analyse", "pca", opts.store,
                    "--group", group, "--out", str(folder)], check=True,
                   stdout=subprocess.DEVNULL)
    return folder / "eigen_vectors.csv"


def compare_regularisation(coarse: bool, workers: int, out: Path, repeats: int = 2,
                           tau: float = 1.0, settings: tuple[str, ...] = tuple(SETTINGS)
                           ) -> None:
    """``tau``: the discrepancy principle's τ; ``settings``: labels of :data:`SETTINGS`."""
    opts = Options(out=out, store=str(out / "thesis.zarr"), quick=True, coarse=coarse)
    group = training_sweep(opts, workers)
    mask = pca_mask(opts, group, out) if any(SETTINGS[s][1] for s in settings) else None
    groups = {}
    for label in settings:
        reg, masked = SETTINGS[label]
        name = "reg-" + label.replace("+", "-") + (f"-tau{tau:g}" if tau != 1.0 else "")
        text = _head(name, opts, out / "evaluations", reg, mask if masked else None,
                     tau=tau)
        text += _distribution(opts, group)
        text += _condition("noise", "scaled", 0.9, 0.0, True, repeats)
        text += _condition("guess-uniform", "uniform", 1.0, 4.0, True, repeats)
        text += _condition("distribution", "distribution", 1.0, 0.0, True, repeats)
        study, _ = _run(text, name, workers)
        groups[label] = open_solves(study.store, study.group)
    _print("regularisation on the noisy conditions (weights by the discrepancy principle; "
           "nodal errors x - x_true, N)", ch4_extra.regularisation(groups))
