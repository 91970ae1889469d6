"""The adaptive study's chooser (issue 28) on a synthetic combined-load store: it fits the
done experiments, reports held-out errors by output, and picks distinct candidates."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.adaptive import SurrogateChooser
from analysis.errors import TooFewExperimentsError
from tests.synthetic import make_combined_store

TINY = {"rows": 6, "cols": 12, "tread_rows": 5, "tread_cols": 10}
NAMES = ("deflection", "shift_x", "shift_y", "tilt")


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    path = tmp_path_factory.mktemp("stores") / "combined.zarr"
    make_combined_store(path, n_experiments=20, seed=3, **TINY)
    return path


def _candidates(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(10, 40, n), rng.uniform(-5, 5, n),
                            rng.uniform(-5, 5, n), rng.uniform(-4, 4, n)])


def test_the_chooser_reports_errors_and_picks_a_batch(store):
    from analysis import data

    group = data.resolve_group(store, None)
    chooser = SurrogateChooser(restarts=1)
    cands = _candidates(64, 0)
    choice = chooser(store, group, NAMES, "displacement", cands, 4)
    assert choice.fitted_on == 20
    assert len(set(choice.picks)) == 4 and all(0 <= k < 64 for k in choice.picks)
    assert set(choice.errors) == {"field", "Fx", "Fy", "Fz", "Mx", "My", "Mz"}
    # smooth synthetic maps: small held-out errors; Mz is round-off here (None)
    assert 0 < choice.errors["field"] < 5 and 0 < choice.errors["Fz"] < 5, choice.errors
    assert choice.errors["Mz"] is None
    # the first pick is where the fitted surrogate is least sure
    u = chooser.model_.uncertainty(cands)
    assert choice.picks[0] == int(np.argmax(u))
    # size 0: a fit for its errors only
    assert chooser(store, group, NAMES, "displacement", cands, 0).picks == ()


def test_too_few_done_experiments_is_one_clear_error(tmp_path):
    path = tmp_path / "s.zarr"
    make_combined_store(path, n_experiments=2, seed=1, **TINY)
    from analysis import data

    group = data.resolve_group(path, None)
    with pytest.raises(TooFewExperimentsError, match=r"2 done experiments.*needs 3"):
        SurrogateChooser()(path, group, NAMES, "displacement", _candidates(8, 1), 2)


def test_failed_points_are_the_failed_experiments_load_cases(tmp_path):
    import storage
    from analysis.adaptive import failed_points
    from tests.synthetic import make_store

    path = tmp_path / "s.zarr"
    group = make_store(path, n_experiments=6, n_failed=2, n_pending=1, rows=4, cols=6,
                       tread_rows=3, tread_cols=4)
    points = failed_points(path, group, ("deflection", "pressure"))
    ds = storage.open_dataset(path, group)
    failed = ds["status"].values == storage.FAILED
    assert points.shape == (2, 2)
    np.testing.assert_array_equal(points[:, 0], ds["deflection"].values[failed])
    assert failed_points(path, group, ("deflection",)).shape == (2, 1)
