"""Learners on the PLS scores side by side in one run (issue 46: a nonlinear learner
chosen by grouped CV), the comparison behind docs/sensor.md's table "Why kernel ridge".

    .venv/bin/python benchmarks/bench_learners.py [--kinds plsr,gp,krr,auto,trees,hgb,mlp]
        [--problems latent-60,latent-200,store-40,store-80,store-80-noisy]

Each problem is split once (a quarter of its experiments held out, 3 noisy draws each);
every learner fits on the training draws, its hyper-parameters by grouped k-fold CV (5
folds, one experiment's draws in one fold), and is scored on the held-out draws:
RMSE per target in % of the target's range, and the fit's seconds.

- ``latent-60``, ``latent-200``: a rank-3 latent L seen through 400 noisy features,
  targets ``L0**2`` and ``tanh(1.5 L1) + 0.5 L2`` (60 or 200 experiments);
- ``store-40``, ``store-80``, ``store-80-noisy``: ``tests.synthetic.make_combined_store``
  (a small mesh; 40 experiments with coupling 0.1, 80 with coupling 0.5) through a
  virtual ``t2cam-2017,spacing_mm=20`` at 0.2 mm of noise (2 mm for ``-noisy``), the
  features ``farm fit`` builds; targets Fx, Fy, Fz, Mz.

``plsr``, ``gp``, ``krr``, ``auto`` are the farm's (:mod:`analysis.camera.learners`);
``trees`` (extra trees), ``forest``, ``hgb`` (gradient boosting) and ``mlp`` are scikit-learn
regressors fitted here the way ``krr`` is - on the PLSR's residuals, over the PLSR's
scores or all the folds allow, a small grid chosen by the same grouped CV, but without
``krr``'s one-standard-error fallback to the PLSR - to show why they were not adopted.
Nothing is asserted; one split per problem (a comparison of learners, not of errors to
quote).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from sklearn.base import BaseEstimator, MultiOutputMixin, RegressorMixin, clone
from sklearn.ensemble import (
    ExtraTreesRegressor,
    HistGradientBoostingRegressor,
    RandomForestRegressor,
)
from sklearn.multioutput import MultiOutputRegressor
from sklearn.neural_network import MLPRegressor

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from analysis import data  # noqa: E402
from analysis.camera.features import displacements, measured_features, targets  # noqa: E402
from analysis.camera.learners import (  # noqa: E402
    PLSCV,
    AutoLearner,
    GPOnScores,
    KRROnScores,
    scores_residuals,
    unit_scale,
)
from analysis.camera.sensor import InnerSurface, VirtualSensor, sensor_spec  # noqa: E402
from analysis.combined import BlockRegression  # noqa: E402
from analysis.splits import path_groups, split  # noqa: E402
from tests.synthetic import make_combined_store  # noqa: E402

SMALL = {"rows": 9, "cols": 24, "tread_rows": 4, "tread_cols": 8}
#: the grids of the learners not adopted (each fitted on the PLSR's residuals)
GRIDS = {
    "trees": [ExtraTreesRegressor(n_estimators=100, min_samples_leaf=m, max_features=f,
                                  random_state=0) for m in (1, 4, 16) for f in (1.0, 0.5)],
    "forest": [RandomForestRegressor(n_estimators=100, min_samples_leaf=m, random_state=0)
               for m in (1, 4, 16)],
    "hgb": [MultiOutputRegressor(HistGradientBoostingRegressor(
        max_iter=n, max_depth=3, min_samples_leaf=m, random_state=0))
        for n in (50, 200) for m in (5, 20)],
    "mlp": [MLPRegressor(hidden_layer_sizes=(32,), alpha=a, max_iter=2000, random_state=0)
            for a in (1e-3, 1e-1, 1.0)],
}
FARM = {"plsr": PLSCV, "gp": GPOnScores, "krr": KRROnScores, "auto": AutoLearner}


class OnScores(MultiOutputMixin, RegressorMixin, BaseEstimator):
    """PLSR plus a scikit-learn regressor of :data:`GRIDS` on its (unit-variance)
    scores for the residual; the score count (the PLSR's or all) and the grid point
    chosen by grouped CV, no correction when none beats the PLSR."""

    def __init__(self, kind="trees", max_components=10, folds=5, x_blocks=None,
                 y_blocks=None, seed=0):
        self.kind = kind
        self.max_components = max_components
        self.folds = folds
        self.x_blocks = x_blocks
        self.y_blocks = y_blocks
        self.seed = seed

    def fit(self, X, Y, groups=None):
        X, Y = np.asarray(X, float), np.asarray(Y, float)
        self.pls_ = PLSCV(self.max_components, self.folds, self.x_blocks, self.y_blocks,
                          self.seed).fit(X, Y, groups)
        n, top = self.pls_.n_components_, int(self.pls_.cv_table_["n_components"][-1])
        counts, grid = sorted({n, top}), GRIDS[self.kind]
        mse = np.zeros(1 + len(counts) * len(grid))
        splits = self.pls_._splits(X.shape[0], groups)
        for tr, te in splits:
            fit = BlockRegression("plsr", top, self.x_blocks, self.y_blocks).fit(X[tr], Y[tr])
            (Ttr, Rtr), (Tte, Rte) = (scores_residuals(fit, X[tr], Y[tr], n),
                                      scores_residuals(fit, X[te], Y[te], n))
            s = unit_scale(Ttr)
            mse[0] += np.mean(Rte ** 2) / len(splits)
            for i, (k, est) in enumerate(((k, e) for k in counts for e in grid), start=1):
                m = clone(est).fit(Ttr[:, :k] / s[:k], _target(Rtr))
                P = np.asarray(m.predict(Tte[:, :k] / s[:k])).reshape(Rte.shape)
                mse[i] += np.mean((P - Rte) ** 2) / len(splits)
        best = int(np.argmin(mse))
        self.choice_ = None if best == 0 else (counts[(best - 1) // len(grid)],
                                               (best - 1) % len(grid))
        self.model_ = None
        if self.choice_ is not None:
            self.scores_ = BlockRegression("plsr", top, self.x_blocks, self.y_blocks).fit(X, Y)
            T = self.scores_.model_.transform(self.scores_.x_scaler_.transform(X))
            self.scale_ = unit_scale(T)
            k, g = self.choice_
            ys = self.pls_.model_.y_scaler_
            R = ys.transform(Y) - ys.transform(self.pls_.predict(X))
            self.model_ = clone(grid[g]).fit(T[:, :k] / self.scale_[:k], _target(R))
        return self

    def predict(self, X):
        lin = self.pls_.predict(X)
        if self.model_ is None:
            return lin
        k = self.choice_[0]
        T = self.scores_.model_.transform(self.scores_.x_scaler_.transform(X))
        ys = self.pls_.model_.y_scaler_
        fix = np.asarray(self.model_.predict(T[:, :k] / self.scale_[:k])).reshape(lin.shape)
        return ys.inverse_transform(ys.transform(lin) + fix)


def _target(R: np.ndarray) -> np.ndarray:
    return R.ravel() if R.shape[1] == 1 else R


def latent(k: int, draws: int = 3, seed: int = 0):
    rng = np.random.default_rng(seed)
    L, W = rng.normal(size=(k, 3)), rng.normal(size=(3, 400))
    Y = np.c_[L[:, 0] ** 2, np.tanh(1.5 * L[:, 1]) + 0.5 * L[:, 2]]
    X = np.stack([L @ W + 0.3 * rng.normal(size=(k, 400)) for _ in range(draws)])
    train = np.arange(k) >= k // 4
    Xf, Xt = X[:, train].reshape(-1, 400), X[:, ~train].reshape(-1, 400)
    g = np.tile(np.arange(k)[train], draws)
    return (Xf, np.tile(Y[train], (draws, 1)), g, Xt, np.tile(Y[~train], (draws, 1)),
            None, np.ptp(Y, axis=0))


def store(n: int, coupling: float, noise_mm: float, seed: int = 1, draws: int = 3):
    root = tempfile.mkdtemp()
    make_combined_store(root + "/a.zarr", n_experiments=n, seed=seed, coupling=coupling,
                        **SMALL)
    ds = data.load(root + "/a.zarr")
    v = VirtualSensor(sensor_spec(f"t2cam-2017,spacing_mm=20,noise_mm={noise_mm}"),
                      InnerSurface.from_dataset(ds))
    train, test = split(ds, 0.25, 0)
    U, Y = displacements(ds), targets(ds)
    rng = np.random.default_rng(0)
    Xf, blocks = measured_features(v, v.clean(U[train]), draws, rng)
    reps = Xf.shape[0] // train.size
    Xt, _ = measured_features(v, v.clean(U[test]), draws, rng)
    return (Xf, np.tile(Y[train], (reps, 1)), np.tile(path_groups(ds)[train], reps), Xt,
            np.tile(Y[test], (Xt.shape[0] // test.size, 1)), blocks, np.ptp(Y, axis=0))


PROBLEMS = {"latent-60": lambda: latent(60), "latent-200": lambda: latent(200),
            "store-40": lambda: store(40, 0.1, 0.2), "store-80": lambda: store(80, 0.5, 0.2),
            "store-80-noisy": lambda: store(80, 0.5, 2.0)}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--kinds", default="plsr,gp,krr,auto,trees,mlp")
    p.add_argument("--problems", default=",".join(PROBLEMS))
    a = p.parse_args()
    for name in a.problems.split(","):
        Xf, Yf, g, Xt, Yt, blocks, span = PROBLEMS[name]()
        for kind in a.kinds.split(","):
            kw = dict(max_components=10, folds=5, x_blocks=blocks,
                      y_blocks=[1] * Yf.shape[1], seed=0)
            m = FARM[kind](**kw) if kind in FARM else OnScores(kind, **kw)
            start = time.perf_counter()
            m.fit(Xf, Yf, g)
            seconds = time.perf_counter() - start
            pct = 100 * np.sqrt(np.mean((m.predict(Xt) - Yt) ** 2, axis=0)) / span
            chose = getattr(m, "chosen_", "")
            print(f"{name:15s} {kind:6s} {seconds:6.1f} s  "
                  + " ".join(f"{v:6.2f}" for v in pct) + (f"  chose {chose}" if chose else ""),
                  flush=True)


if __name__ == "__main__":
    main()
