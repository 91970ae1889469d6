"""Synthetic stores shared by the analysis tests (small: N = 128 inner, M = 72 tread nodes)."""

from __future__ import annotations

import numpy as np
import pytest

from analysis import data
from tests.synthetic import make_store

SMALL = {"rows": 8, "cols": 16, "tread_rows": 6, "tread_cols": 12}


@pytest.fixture(scope="session")
def thesis_store(tmp_path_factory):
    """Like the thesis' ch. 5 dataset: 7 deflections 10..40 mm at 0.2 MPa, one latent
    variable, plus one failed and one pending experiment that must never be read."""
    path = tmp_path_factory.mktemp("stores") / "thesis.zarr"
    make_store(path, n_experiments=7, n_failed=1, n_pending=1, **SMALL)
    return path


@pytest.fixture(scope="session")
def thesis_ds(thesis_store):
    return data.load(thesis_store)


@pytest.fixture(scope="session")
def thesis_xy(thesis_ds):
    """(X = Uz, Y = vertical tread forces) of the thesis-like store, in memory."""
    X = np.asarray(data.inputs(thesis_ds, "Uz").compute())
    Y = np.asarray(data.outputs(thesis_ds).compute())
    return X, Y


@pytest.fixture(scope="session")
def uz_only_store(tmp_path_factory):
    """Only Uz depends on the deflection; everything else is small noise."""
    path = tmp_path_factory.mktemp("stores") / "uz_only.zarr"
    make_store(path, n_experiments=9, signal="uz_only", noise=1e-3, seed=3, **SMALL)
    return path


@pytest.fixture(scope="session")
def two_pressure_store(tmp_path_factory):
    """Two pressures and two groups (so the group must be named)."""
    path = tmp_path_factory.mktemp("stores") / "two.zarr"
    make_store(path, n_experiments=5, pressures=(0.2, 0.25), group="mesh_a", **SMALL)
    make_store(path, n_experiments=4, group="mesh_b", include_strain=False, **SMALL)
    return path


def _random_xy(K, N, M, seed=0, rank=None):
    """Gaussian test matrices; ``rank`` < min(K, N) makes X exactly low-rank."""
    rng = np.random.default_rng(seed)
    if rank is None:
        X = rng.standard_normal((K, N))
    else:
        X = rng.standard_normal((K, rank)) @ rng.standard_normal((rank, N))
    X = X + 5.0  # a mean offset, so centring matters
    Y = X @ rng.standard_normal((N, M)) + 0.1 * rng.standard_normal((K, M)) - 2.0
    return X, Y


@pytest.fixture(scope="session")
def random_xy():
    """Factory ``random_xy(K, N, M, seed=0, rank=None) -> (X, Y)``."""
    return _random_xy
