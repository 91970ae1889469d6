"""Chapter-4 tables and figures from a stored inverse-solves group (hand-checked numbers).

The group is written and read back through storage, so every column the tables need
must be in the store: nothing here knows about loops or problems.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from analysis.errors import MissingVariableError
from analysis.report import ch4
from storage.paths import open_store, publish
from storage.solves import (
    DIRECTIONS,
    SolveRecord,
    SolvesAttrs,
    Unknowns,
    open_solves,
    solves_dataset,
    write_solves,
)

X_TRUE = np.array([10.0, 20.0, 40.0])  # the largest reference nodal force: 40 N
UNKNOWNS = Unknowns(np.array([7, 8, 9]), X_TRUE, np.zeros((3, 3)),
                    np.array([0.0, 0.0, 70.5]), np.array([-840.0, 20.0, 0.0]))
ATTRS = SolvesAttrs("t", '{"kind": "reduced"}', "CalculiX 2.20", 30.0, -369.2,
                    '{"displacement_mm": 1.0, "strain": 0.0004}', "abc")


def solve(i, condition, method, optimizer, repeat, *, fz=None, m=(0.0, 0.0), rmse=None,
          error=(0.0, 0.0, 0.0), evaluations=4, solved=3, rounds=2, wall=10.0,
          status="converged") -> SolveRecord:
    ok = fz is not None
    return SolveRecord(
        id=f"s{i}", condition=condition, method=method, optimizer=optimizer, repeat=repeat,
        status=status if ok else "failed", message="" if ok else "ccx diverged",
        objective_units="mm" if method == "displacement" else "1",
        x0=0.9 * X_TRUE, x_final=X_TRUE + np.array(error),
        x_history=np.tile(X_TRUE, (evaluations, 1)),
        objective_history=np.linspace(1.0, 0.1, evaluations), objective=0.1,
        total_force=np.array([0.0, 0.0, fz]) if ok else None,
        moment=np.array([m[0], m[1], 0.0]) if ok else None,
        rmse=dict(zip(DIRECTIONS, rmse, strict=True)) if ok else None,
        solved=solved, rounds=rounds, wall_seconds=wall, solver_seconds=wall / 2)


SOLVES = [
    # noise/displacement/least-squares: two repeats finish, one's final evaluation fails
    solve(0, "noise", "displacement", "least-squares", 0, fz=69.0, m=(-1000.0, 0.0),
          rmse=(0.01, 0.02, 0.03, 1e-4, 2e-4, 3e-4), error=(1.0, -1.0, 2.0), evaluations=4),
    solve(1, "noise", "displacement", "least-squares", 1, fz=71.0, m=(-2000.0, 100.0),
          rmse=(0.03, 0.04, 0.05, 3e-4, 4e-4, 5e-4), error=(-1.0, 1.0, 0.0), evaluations=6,
          status="max_evaluations"),
    solve(2, "noise", "displacement", "least-squares", 2, evaluations=2),
    solve(3, "ideal", "strain", "nelder-mead", 0, fz=70.0, m=(500.0, -500.0),
          rmse=(0.1, 0.2, 0.3, 1e-3, 2e-3, 3e-3), error=(4.0, 0.0, -4.0), evaluations=8),
    solve(4, "mine", "strain", "nelder-mead", 0),  # nothing finished: no figure, no errors
]


@pytest.fixture(scope="module")
def ds(tmp_path_factory):
    path = tmp_path_factory.mktemp("ch4") / "s.zarr"
    write_solves(path, "inverse-t", UNKNOWNS, SOLVES, ATTRS)
    return open_solves(path, "inverse-t")


def test_forces_are_tables_4_1_and_4_3(ds):
    f = ch4.forces(ds)
    assert list(f["condition"]) == ["reference", "noise", "ideal", "mine"]
    ref, noise, ideal = f.iloc[0], f.iloc[1], f.iloc[2]
    # the reference experiment's own totals, moments in N m
    assert (ref["Fz_mean"], ref["Mx_mean"], ref["My_mean"]) == (70.5, -0.84, 0.02)
    assert ref["thesis_Fz"] == 359.08 and ref["repeats"] == 1
    # mean and sample std of the two finished repeats; the failed one is still counted
    assert noise["repeats"] == 3 and noise["Fz_mean"] == 70.0
    assert noise["Fz_std"] == pytest.approx(np.sqrt(2))
    assert noise["Mx_mean"] == -1.5 and noise["Mx_std"] == pytest.approx(np.sqrt(0.5))
    assert noise["My_mean"] == pytest.approx(0.05)
    assert (noise["thesis_Fz"], noise["thesis_Fz_std"], noise["thesis_Mx"]) == (358.28, 0.4,
                                                                                 -0.84)
    assert ideal["Fz_mean"] == 70.0 and np.isnan(ideal["Fz_std"])
    assert (ideal["Mx_mean"], ideal["My_mean"]) == (0.5, -0.5)
    assert ideal["thesis_Fz"] == 356.71
    assert np.isnan(f.iloc[3]["Fz_mean"]) and pd.isna(f.iloc[3]["thesis_Fz"])


def test_rmse_is_tables_4_2_and_4_4_in_mm_and_microstrain(ds):
    r = ch4.rmse(ds).set_index("condition")
    assert r.loc["noise", "Ux"] == pytest.approx(0.02) and r.loc["noise", "Uz"] == 0.04
    assert r.loc["noise", "exx"] == pytest.approx(200.0)  # mean of 100 and 300 microstrain
    assert r.loc["ideal", "exy"] == pytest.approx(3000.0)
    assert r.loc["noise", "thesis_Ux"] == 0.010 and r.loc["ideal", "thesis_exx"] == 485.70


def test_nodal_errors_pool_the_finished_repeats(ds):
    n = ch4.nodal_errors(ds).set_index("condition")
    assert list(n.index) == ["noise", "ideal"]  # "mine" has no finished solve
    e = np.array([1.0, -1.0, 2.0, -1.0, 1.0, 0.0])  # x_final - x_true of repeats 0 and 1
    assert n.loc["noise", "mean"] == pytest.approx(1 / 3)
    assert n.loc["noise", "std"] == pytest.approx(np.sqrt(np.mean(e**2) - 1 / 9))
    assert n.loc["noise", "rms"] == pytest.approx(np.sqrt(8 / 6))
    assert n.loc["noise", "std_over_max_force"] == pytest.approx(n.loc["noise", "std"] / 40)
    assert n.loc["noise", "thesis_std"] == 2.0
    assert n.loc["noise", "thesis_std_over_max_force"] == pytest.approx(2.0 / 35.5)
    assert n.loc["ideal", "std"] == pytest.approx(np.sqrt(32 / 3))


def test_cost_counts_every_solve(ds):
    c = ch4.cost(ds).set_index("condition")
    assert c.loc["noise", "solves"] == 3 and c.loc["noise", "evaluations"] == 4.0
    assert c.loc["noise", "statuses"] == "converged 1, max_evaluations 1, failed 1"
    assert c.loc["ideal", "wall_s"] == 10.0 and c.loc["ideal", "solver_s"] == 5.0


def test_per_solve_has_one_row_per_solve_nan_where_the_final_evaluation_failed(ds):
    p = ch4.per_solve(ds)
    assert len(p) == 5 and list(p["repeat"]) == [0, 1, 2, 0, 0]
    assert p.loc[0, "Fz"] == 69.0 and p.loc[1, "My"] == 0.1
    assert p.loc[2, ["Fz", "Mx", "Ux", "exy"]].isna().all()
    assert list(p["evaluations"]) == [4, 6, 2, 8, 4]


def test_views_put_ours_beside_the_thesis(ds):
    v = ch4.views(ds)
    forces = v["forces"].set_index("condition")
    assert forces.loc["noise", "Fz N"] == "70 ± 1.4"
    assert forces.loc["noise", "thesis Fz"] == "358.28 ± 0.4"
    assert forces.loc["reference", "Fz N"] == "70.5" and forces.loc["mine", "Fz N"] == "n/a"
    assert v["rmse"].set_index("condition").loc["noise", "Ux (thesis)"] == "0.02 (0.01)"
    assert set(v) == {"forces", "rmse", "nodal_errors", "cost"}


def test_histograms_one_png_per_condition_with_a_finished_solve(ds, tmp_path):
    paths = ch4.histograms(ds, tmp_path / "figs")
    assert [p.name for p in paths] == ["nodal_errors_noise.png", "nodal_errors_ideal.png"]
    assert all(p.stat().st_size > 1000 for p in paths)


def test_the_in_memory_dataset_gives_the_same_tables_as_the_stored_one(ds):
    mem = solves_dataset(UNKNOWNS, SOLVES)
    for name, frame in ch4.tables(ds).items():
        pd.testing.assert_frame_equal(ch4.tables(mem)[name], frame, check_exact=True)


def test_a_group_of_the_first_layout_has_no_reference_row_values(tmp_path):
    """Groups written before the reference totals were stored still give tables."""
    path = tmp_path / "old.zarr"
    write_solves(path, "inverse-t", UNKNOWNS, SOLVES[:2], ATTRS)
    old = xr.open_zarr(path, group="inverse-t").load().drop_vars(
        ["reference_total_force", "reference_moment"])
    del old.attrs["solves_version"]
    old.to_zarr(path, group="inverse-t", mode="w", zarr_format=3, consolidated=False)
    publish(open_store(path))  # as the first writer did
    f = ch4.forces(open_solves(path, "inverse-t"))
    assert np.isnan(f.loc[0, "Fz_mean"]) and f.loc[1, "Fz_mean"] == 70.0


def test_anything_but_a_solves_group_is_refused():
    with pytest.raises(MissingVariableError, match="not an inverse-solves group"):
        ch4.forces(xr.Dataset({"x_final": ("solve", [1.0])}))


# ------------------------------------------------- issue 16: initial guesses, regularisation

def test_guesses_table_has_evaluations_and_the_nodal_errors_of_guess_and_solution(ds):
    from analysis.report import ch4_extra

    g = ch4_extra.guesses(ds)
    noise = g[(g["condition"] == "noise") & (g["method"] == "displacement")].iloc[0]
    assert noise["solves"] == 3 and noise["evaluations"] == 4.0  # (4 + 6 + 2) / 3
    # the guess: 0.9 x_true, errors -1, -2, -4 N in each of the three solves
    assert noise["guess_rms"] == pytest.approx(np.sqrt((1 + 4 + 16) / 3))
    # the solution: the two finished solves' errors (1, -1, 2, -1, 1, 0), pooled
    e = np.array([1.0, -1.0, 2.0, -1.0, 1.0, 0.0])
    assert noise["nodal_std"] == pytest.approx(e.std())
    assert noise["nodal_rms"] == pytest.approx(np.sqrt(np.mean(e**2)))
    assert noise["Fz"] == 70.0
    assert noise["Fz_err_pct"] == pytest.approx(100 * (70.0 / 70.5 - 1))


def test_regularisation_table_reads_the_chosen_weights_from_the_messages(tmp_path):
    import dataclasses

    from analysis.report import ch4_extra

    tagged = [dataclasses.replace(s, message=f"discrepancy weight {w}; converged")
              for s, w in zip(SOLVES[:2], ("0.25", "1e-2"), strict=True)]
    write_solves(tmp_path / "s.zarr", "inverse-r", UNKNOWNS, tagged, ATTRS)
    groups = {"none": open_solves(tmp_path / "s.zarr", "inverse-r"),
              "plain": solves_dataset(UNKNOWNS, SOLVES[:2], ATTRS)}
    r = ch4_extra.regularisation(groups)
    assert list(r["setting"]) == ["none", "plain"]
    assert r.iloc[0]["weight"] == pytest.approx(np.median([0.25, 1e-2]))
    assert np.isnan(r.iloc[1]["weight"])  # a fixed weight records nothing
    assert r.iloc[0]["thesis_nodal_std"] == 2.0  # Fig. 4.2, noise/displacement
    assert r.iloc[0]["nodal_std"] == pytest.approx(np.array([1.0, -1, 2, -1, 1, 0]).std())


def test_the_unregularised_baseline_pools_the_same_noise_draws(ds):
    """Regularised studies of one repeat sit beside the unregularised solves of that
    repeat, not beside every repeat of the base study."""
    from analysis.report import ch4_extra

    first = ds.isel(solve=[k for k, r in enumerate(ds["repeat"].values) if r == 0])
    same = ch4_extra.same_solves(ds, {"tikhonov": first})
    assert same.sizes["solve"] == first.sizes["solve"] < ds.sizes["solve"]
    assert set(same["repeat"].values.tolist()) == {0}
    assert ch4_extra.same_solves(ds, {"all": ds}).sizes["solve"] == ds.sizes["solve"]
