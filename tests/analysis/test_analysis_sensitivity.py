"""Sobol indices and Morris screening (issue 15): known values, SALib parity, the store reader."""

from __future__ import annotations

import numpy as np
import pytest
import zarr
from SALib.analyze import morris as salib_morris
from SALib.analyze import sobol as salib_sobol
from SALib.sample import morris as morris_sample
from SALib.sample import sobol as sobol_sample
from SALib.test_functions import Ishigami
from sklearn.base import clone

from analysis.errors import (
    CommonMeshError,
    ComponentsError,
    DegenerateDesignWarning,
    DesignError,
    IncompleteDesignError,
    NonFiniteError,
    ParameterError,
    UndefinedVarianceWarning,
)
from analysis.sensitivity import NOT_ESTIMABLE, MorrisScreening, SobolIndices, ci_width
from analysis.sensitivity_data import OutputRequest, read_outputs, tread_areas
from tests.synthetic import make_store

PI = np.pi
ISHIGAMI = {"num_vars": 3, "names": ["x1", "x2", "x3"], "bounds": [[-PI, PI]] * 3}
# Analytic indices of Ishigami (a=7, b=0.1; Ishigami & Homma 1990, Saltelli et al. 2008):
# V = a²/8 + b π⁴/5 + b² π⁸/18 + 1/2, V1 = (1 + b π⁴/5)²/2, V2 = a²/8, V13 = 8 b² π⁸/225.
_A, _B = 7.0, 0.1
_V = _A**2 / 8 + _B * PI**4 / 5 + _B**2 * PI**8 / 18 + 0.5
_V1, _V2, _V13 = 0.5 * (1 + _B * PI**4 / 5) ** 2, _A**2 / 8, 8 * _B**2 * PI**8 / 225
S1_ISHIGAMI = np.array([_V1, _V2, 0.0]) / _V
ST_ISHIGAMI = np.array([_V1 + _V13, _V2, _V13]) / _V


@pytest.fixture(scope="module")
def ishigami():
    X = sobol_sample.sample(ISHIGAMI, 1024, calc_second_order=False, seed=1)
    return X, Ishigami.evaluate(X)


def test_analytic_ishigami_values_are_the_published_ones():
    np.testing.assert_allclose(S1_ISHIGAMI, [0.3139, 0.4424, 0.0], atol=5e-5)
    np.testing.assert_allclose(ST_ISHIGAMI, [0.5576, 0.4424, 0.2437], atol=5e-5)


def test_sobol_reproduces_ishigami_within_its_confidence_intervals(ishigami):
    """N = 1024 base rows (5120 runs): every index within its 95 % interval and 0.01."""
    X, y = ishigami
    est = SobolIndices(ISHIGAMI["names"], ISHIGAMI["bounds"], seed=3).fit(X, y)
    assert est.first_order_.shape == est.total_order_conf_.shape == (1, 3)
    assert est.n_base_samples_ == 1024
    for value, conf, exact in (
        (est.first_order_[0], est.first_order_conf_[0], S1_ISHIGAMI),
        (est.total_order_[0], est.total_order_conf_[0], ST_ISHIGAMI),
    ):
        assert np.all(np.abs(value - exact) <= conf), (value, conf, exact)
        np.testing.assert_allclose(value, exact, atol=0.01)
        assert np.all((conf > 0) & (conf < 0.1))


@pytest.mark.parametrize("seed", [0, 7])
def test_sobol_equals_salibs_own_analysis_exactly(ishigami, seed):
    """One call per column, SALib's estimators and bootstrap untouched; seed 0 too (SALib
    alone treats 0 as 'no seed' and would draw from the global generator)."""
    X, y = ishigami
    Y = np.column_stack([y, 2.0 * y + X[:, 2] ** 2])
    est = SobolIndices(ISHIGAMI["names"], ISHIGAMI["bounds"], num_resamples=200, seed=seed)
    est.fit(X, Y)
    for j in range(2):
        ref = salib_sobol.analyze(ISHIGAMI, Y[:, j], calc_second_order=False,
                                  num_resamples=200, seed=np.random.default_rng(seed))
        np.testing.assert_array_equal(est.first_order_[j], ref["S1"])
        np.testing.assert_array_equal(est.first_order_conf_[j], ref["S1_conf"])
        np.testing.assert_array_equal(est.total_order_[j], ref["ST"])
        np.testing.assert_array_equal(est.total_order_conf_[j], ref["ST_conf"])
    if seed:  # a nonzero integer seed is the same stream as SALib's own
        ref = salib_sobol.analyze(ISHIGAMI, y, calc_second_order=False, num_resamples=200,
                                  seed=seed)
        np.testing.assert_array_equal(est.total_order_conf_[0], ref["ST_conf"])
    again = clone(est).fit(X, Y)
    np.testing.assert_array_equal(again.first_order_conf_, est.first_order_conf_)


def test_sobol_to_frame_and_ci_width(ishigami):
    X, y = ishigami
    est = SobolIndices(ISHIGAMI["names"], ISHIGAMI["bounds"], num_resamples=100).fit(X, y)
    frame = est.to_frame(["f"])
    assert list(frame.columns) == ["output", "parameter", "S1", "S1_conf", "ST", "ST_conf",
                                   "swapped_rows", "note"]
    assert frame["parameter"].tolist() == ["x1", "x2", "x3"]
    assert frame["swapped_rows"].tolist() == [1024] * 3 and (frame["note"] == "").all()
    np.testing.assert_array_equal(frame["ST"], est.total_order_[0])
    width = ci_width(est)
    assert width["S1"] == pytest.approx(2 * est.first_order_conf_.mean())
    with pytest.raises(ParameterError, match="output_names must name the 1 outputs"):
        est.to_frame(["a", "b"])


def test_morris_ranks_an_inert_parameter_last():
    """f = x1 + 2 x2² on [0, 1]^3: x3 does nothing, so mu* = sigma = 0 exactly for it;
    x1 is linear (sigma = 0, every elementary effect equal)."""
    problem = {"num_vars": 3, "names": ["a", "b", "inert"], "bounds": [[0.0, 1.0]] * 3}
    X = morris_sample.sample(problem, 20, num_levels=4, seed=2)
    y = X[:, 0] + 2.0 * X[:, 1] ** 2
    est = MorrisScreening(problem["names"], problem["bounds"], seed=5).fit(X, y)
    assert est.n_trajectories_ == 20
    ranking = np.argsort(-est.mu_star_[0])
    assert ranking[-1] == 2
    assert est.mu_star_[0, 2] == 0 and est.sigma_[0, 2] == 0
    assert est.mu_star_[0, 0] == pytest.approx(1.0)  # Δy / Δx of a unit slope
    assert est.sigma_[0, 0] == pytest.approx(0.0, abs=1e-12)
    assert est.sigma_[0, 1] > 0.1  # x2² is non-linear
    ref = salib_morris.analyze(problem, X, y, num_resamples=1000, num_levels=4,
                               seed=np.random.default_rng(5))
    np.testing.assert_array_equal(est.mu_star_conf_[0], ref["mu_star_conf"])
    assert list(est.to_frame().columns) == [
        "output", "parameter", "mu", "mu_star", "mu_star_conf", "sigma"]


def test_design_structure_errors(ishigami):
    X, y = ishigami
    est = SobolIndices(ISHIGAMI["names"], ISHIGAMI["bounds"], num_resamples=10)
    with pytest.raises(DesignError, match=r"N \* 5 rows .* got 5119 rows"):
        est.fit(X[:-1], y[:-1])
    order = np.random.default_rng(0).permutation(len(X))
    with pytest.raises(DesignError, match="SALib's Sobol' sample order"):
        est.fit(X[order], y[order])
    wide = SobolIndices(ISHIGAMI["names"], [[-1, 1]] * 3, num_resamples=10)
    with pytest.raises(DesignError, match="outside the bounds of 'x1'"):
        wide.fit(X, y)
    bad = y.copy()
    bad[17] = np.nan
    with pytest.raises(NonFiniteError, match="cannot drop rows"):
        est.fit(X, bad)
    with pytest.raises(ParameterError, match=r"X must have shape \(rows, 3\)"):
        est.fit(X[:, :2], y)
    with pytest.raises(ParameterError, match="y must have shape"):
        est.fit(X, y[:-5])
    problem = {"num_vars": 2, "names": ["a", "b"], "bounds": [[0.0, 1.0]] * 2}
    Xm = morris_sample.sample(problem, 4, seed=1)
    shuffled = Xm[np.random.default_rng(0).permutation(len(Xm))]
    with pytest.raises(DesignError, match=r"changes \d parameters, not 1.*Morris sample order"):
        MorrisScreening(["a", "b"], [[0, 1]] * 2).fit(shuffled, shuffled[:, 0])
    with pytest.raises(DesignError, match=r"r \* 3 rows"):
        MorrisScreening(["a", "b"], [[0, 1]] * 2).fit(Xm[:-1], Xm[:-1, 0])


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"names": "x1"}, "sequence of parameter names"),
        ({"names": ["a", "a", "b"]}, "unique"),
        ({"bounds": [[0, 1]] * 2}, "one .low, high. pair per name"),
        ({"bounds": [[1, 0]] * 3}, "low < high"),
        ({"num_resamples": 1}, "num_resamples"),
        ({"conf_level": 1.0}, "conf_level"),
        ({"seed": -1}, "seed"),
    ],
)
def test_parameters_are_checked(ishigami, params, message):
    X, y = ishigami
    kw = {"names": ISHIGAMI["names"], "bounds": ISHIGAMI["bounds"], **params}
    with pytest.raises(ParameterError, match=message):
        SobolIndices(**kw).fit(X, y)


def test_an_output_without_variance_gives_nan_and_a_warning(ishigami):
    X, y = ishigami
    Y = np.column_stack([y, np.full(len(y), 4.0)])
    with pytest.warns(UndefinedVarianceWarning, match="same in every row"):
        est = SobolIndices(ISHIGAMI["names"], ISHIGAMI["bounds"], num_resamples=10).fit(X, Y)
    assert np.isnan(est.total_order_[1]).all() and np.isfinite(est.total_order_[0]).all()


# ---- degenerate swaps (issue 15 review) -------------------------------------------------
# Six parameters, N = 8, the sixth a two-level choice taken from floor(2 u): the first
# binary digit of Sobol' dimensions 6 and 12, the same in every row (the model-space
# example's mesh.circumferential): its AB_6 rows equal the A rows.
SIX = {"num_vars": 6, "names": [f"x{i}" for i in range(6)], "bounds": [[0.0, 1.0]] * 6}


def _six(first_digit: bool, seed: int = 0):
    X = sobol_sample.sample(SIX, 8, calc_second_order=False, seed=seed)
    if first_digit:
        X[:, 5] = np.floor(2 * X[:, 5])
    return X


def _f(X):
    """Depends on the two-level x5 most: ST of x5 is far from 0."""
    return X[:, 0] + 0.5 * X[:, 1] ** 2 + 3.0 * X[:, 5] + X[:, 0] * X[:, 5]


def test_a_parameter_its_swap_never_changes_is_nan_and_warned_not_zero():
    X = _six(first_digit=True)
    blocks = X.reshape(8, 8, 6)
    assert np.array_equal(blocks[:, 0, 5], blocks[:, 6, 5])  # the degenerate design
    est = SobolIndices(SIX["names"], SIX["bounds"], num_resamples=50)
    raw = salib_sobol.analyze(SIX, _f(X), calc_second_order=False, num_resamples=50,
                              seed=np.random.default_rng(0))
    assert raw["ST"][5] == 0.0 and raw["S1"][5] == 0.0  # what SALib alone reports
    with pytest.warns(DegenerateDesignWarning, match=r"'x5'.*0 of 8 base rows"):
        est.fit(X, _f(X))
    assert est.swapped_rows_.tolist() == [8, 8, 8, 8, 8, 0]
    for attr in ("first_order_", "first_order_conf_", "total_order_", "total_order_conf_"):
        values = getattr(est, attr)[0]
        assert np.isnan(values[5]) and np.isfinite(values[:5]).all()
        np.testing.assert_array_equal(  # the other parameters as SALib computes them
            values[:5], raw[{"first_order_": "S1", "first_order_conf_": "S1_conf",
                             "total_order_": "ST", "total_order_conf_": "ST_conf"}[attr]][:5])
    frame = est.to_frame(["f"])
    assert frame["note"].tolist() == [""] * 5 + [NOT_ESTIMABLE]


def test_the_ranking_says_not_estimable_instead_of_zero():
    from analysis.studies.sensitivity import ranking

    X = _six(first_digit=True)
    with pytest.warns(DegenerateDesignWarning):
        est = SobolIndices(SIX["names"], SIX["bounds"], num_resamples=20).fit(X, _f(X))
    text = ranking(est.to_frame(["f"]), "sobol")["ranking"].iloc[0]
    assert text.endswith("x5 not estimable: never varied by the design (changed in 0 base rows)")
    assert "x5 0 ±" not in text and text.startswith("x0 ")


def test_one_changed_row_is_not_enough_and_two_are(recwarn):
    X = _six(first_digit=True)
    for changed, estimable in ((1, False), (2, True)):
        Z = X.copy()
        for n in range(changed):  # flip x5 in AB_6 and B of base row n (a consistent design)
            Z[n * 8 + 6, 5] = Z[n * 8 + 7, 5] = 1.0 - Z[n * 8, 5]
        est = SobolIndices(SIX["names"], SIX["bounds"], num_resamples=20).fit(Z, _f(Z))
        assert est.swapped_rows_[5] == changed
        assert bool(est.estimable_[5]) is estimable
        assert np.isnan(est.total_order_[0, 5]) is not estimable


def test_an_estimable_design_with_a_level_parameter_is_salibs_result_unchanged():
    import warnings

    X = sobol_sample.sample(SIX, 8, calc_second_order=False, seed=0)
    X[:, 5] = np.floor(2 * X[:, 4])  # the fifth column's digit pair does differ: 4 of 8
    X = X.reshape(8, 8, 6)
    X[:, 1:-1, 5] = X[:, :1, 5]  # a level parameter: AB_j rows keep A's level ...
    X[:, 6, 5] = X[:, -1, 5]     # ... except its own swap, from B
    X = X.reshape(64, 6)
    est = SobolIndices(SIX["names"], SIX["bounds"], num_resamples=50)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DegenerateDesignWarning)
        est.fit(X, _f(X))
    assert 2 <= est.swapped_rows_[5] < 8 and est.estimable_.all()
    raw = salib_sobol.analyze(SIX, _f(X), calc_second_order=False, num_resamples=50,
                              seed=np.random.default_rng(0))
    np.testing.assert_array_equal(est.total_order_[0], raw["ST"])
    np.testing.assert_array_equal(est.first_order_conf_[0], raw["S1_conf"])
    assert est.total_order_[0, 5] > 0.3  # x5 dominates _f


def test_morris_refuses_a_parameter_a_trajectory_never_moves():
    problem = {"num_vars": 3, "names": ["a", "b", "c"], "bounds": [[0.0, 1.0]] * 3}
    X = morris_sample.sample(problem, 4, num_levels=4, seed=2)
    traj = X.reshape(4, 4, 3)
    traj[1, :, 2] = traj[1, 0, 2]  # trajectory 1 never moves c
    with pytest.raises(DesignError, match="changes 0 parameters"):
        MorrisScreening(problem["names"], problem["bounds"]).fit(traj.reshape(16, 3),
                                                                np.arange(16.0))


# ---- contact area --------------------------------------------------------------------


def _grid_nodes(rows, cols):
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    return r.ravel(), c.ravel()


def test_tread_areas_of_a_flat_unit_grid():
    r, c = _grid_nodes(3, 4)
    xyz = np.column_stack([c * 2.0, r * 3.0, np.zeros(r.size)])  # 2 mm x 3 mm cells
    areas = tread_areas(xyz, r, c)
    assert areas.sum() == pytest.approx(6 * 6.0)  # 2 x 3 cells of 6 mm²
    corner = (r == 0) & (c == 0)
    inner = (r == 1) & (c == 1)
    assert areas[corner] == pytest.approx(1.5) and areas[inner] == pytest.approx(6.0)


def test_tread_areas_of_a_ring_wrap_around_and_of_a_sector_do_not():
    """A full cylinder (radius 300 mm, width 200 mm, 360 columns) has area 2πRW, shared
    equally along a row; a 90° sector of it has no cell from its last column to the first."""
    R, W, n = 300.0, 200.0, 360
    r, c = _grid_nodes(5, n)
    th = 2 * PI * c / n
    xyz = np.column_stack([R * np.sin(th), W * (r / 4 - 0.5), -R * np.cos(th)])
    ring = tread_areas(xyz, r, c)
    assert ring.sum() == pytest.approx(2 * PI * R * W, rel=2e-5)  # chords vs arcs
    np.testing.assert_allclose(ring[r == 2], ring[r == 2][0])
    sector = c < n // 4
    rs, cs = r[sector], c[sector]
    part = tread_areas(xyz[sector], rs, cs)
    assert part.sum() == pytest.approx(2 * PI * R * W * (n // 4 - 1) / n, rel=2e-5)


# ---- outputs of a design from the store ---------------------------------------------

DESIGN = {"num_vars": 3, "names": ["stiff", "soft", "inert"], "bounds": [[0.0, 1.0]] * 3}
TINY = {"rows": 4, "cols": 6, "tread_rows": 4, "tread_cols": 6, "n_experiments": 2,
        "deflection_range": (20.0, 30.0), "include_strain": False}


def _fz(x, d):
    """Known output: Fz depends on the first parameter only."""
    return 1000.0 * (1.0 + x[0]) * d / 30.0


def _pattern(n):
    return np.linspace(-1.0, 1.0, n * 3).reshape(n, 3)


@pytest.fixture(scope="module")
def design_store(tmp_path_factory):
    """One group per row of a Sobol' design (N = 8, D = 3: 40 rows), with Fz a function
    of 'stiff' only and the displacement field 'soft' times a fixed pattern."""
    path = tmp_path_factory.mktemp("stores") / "design.zarr"
    X = sobol_sample.sample(DESIGN, 8, calc_second_order=False, seed=4)
    groups = [f"m{i}" for i in range(len(X))]
    for i, (g, x) in enumerate(zip(groups, X, strict=True)):
        make_store(path, group=g, seed=i, **TINY)
        root = zarr.open_group(str(path), path=g, mode="r+")
        d = root["deflection"][:]
        tf = root["total_force"][:]
        tf[:, 2] = _fz(x, d)
        root["total_force"][:] = tf
        disp = root["displacement"][:]
        disp[:] = x[1] * _pattern(disp.shape[1])[None] * (d[:, None, None] / 30.0)
        root["displacement"][:] = disp
    return path, X, groups


def test_outputs_of_a_design_give_the_known_sensitivities(design_store):
    path, X, groups = design_store
    request = OutputRequest(deflections=(20.0, 30.0), scalars=("Fz",), field="displacement",
                            components=1)
    out = read_outputs(path, groups, request)
    assert out.labels == ("Fz d=20mm p=200kPa", "displacement PC1 d=20mm p=200kPa",
                          "Fz d=30mm p=200kPa", "displacement PC1 d=30mm p=200kPa")
    np.testing.assert_allclose(out.y[:, 0], _fz(X.T, 20.0), rtol=1e-12)
    np.testing.assert_allclose(out.y[:, 2], _fz(X.T, 30.0), rtol=1e-12)
    assert out.table["explained_variance"].iloc[1] == pytest.approx(1.0)
    est = SobolIndices(DESIGN["names"], DESIGN["bounds"], num_resamples=100).fit(X, out.y)
    # Fz: only 'stiff' matters (ST of the others is exactly 0: f(A) = f(AB_j) row by row)
    for fz in (0, 2):
        assert est.total_order_[fz, 0] > 0.8
        np.testing.assert_allclose(est.total_order_[fz, 1:], 0.0, atol=1e-9)
    for pc in (1, 3):  # the field's first score: only 'soft'
        assert est.total_order_[pc, 1] > 0.8
        np.testing.assert_allclose(est.total_order_[pc, [0, 2]], 0.0, atol=1e-9)


def test_contact_outputs_and_explicit_pressure(design_store):
    path, _, groups = design_store
    out = read_outputs(path, groups[:3], OutputRequest((20.0, 30.0), pressures=(0.2,),
                                                      scalars=("contact_nodes", "contact_area")))
    assert out.table["unit"].tolist() == ["1", "mm2", "1", "mm2"]
    nodes20, area20, nodes30, area30 = out.y[0]
    assert 0 < nodes20 <= nodes30 and 0 < area20 <= area30
    assert (out.y[:, 3] == out.y[0, 3]).all()  # same mesh, same contact in every group


def test_rows_without_a_done_experiment_are_one_error(design_store, tmp_path):
    path, _, groups = design_store
    with pytest.raises(IncompleteDesignError,
                       match=r"7 of 7 design rows \(7 groups: m0, m1, m2, m3, m4 and 2 "
                             r"more\) .* 7 missing"):
        read_outputs(path, groups[:7], OutputRequest((25.0,), scalars=("Fz",)))
    store = tmp_path / "holes.zarr"
    for i, g in enumerate(("a", "b", "c", "d")):
        make_store(store, group=g, seed=i, **TINY)
    zarr.open_group(str(store), path="b", mode="r+")["status"][1] = 2  # failed at 30 mm
    zarr.open_group(str(store), path="c", mode="r+")["status"][1] = 0  # pending
    with pytest.raises(IncompleteDesignError,
                       match=r"3 of 5 design rows \(2 groups: b, c\).*1 failed, 1 pending"):
        read_outputs(store, ["a", "b", "c", "c", "d"], OutputRequest((20.0, 30.0)))


def test_field_outputs_need_a_common_mesh(tmp_path):
    store = tmp_path / "meshes.zarr"
    make_store(store, group="coarse", **TINY)
    make_store(store, group="fine", **{**TINY, "rows": 5})
    with pytest.raises(CommonMeshError, match=r"common mesh.*24 inner nodes but 'fine' has 30"):
        read_outputs(store, ["coarse", "fine"], OutputRequest((20.0,), field="displacement"))
    # scalar outputs do not need one
    out = read_outputs(store, ["coarse", "fine"], OutputRequest((20.0,), scalars=("Fz",)))
    assert out.y.shape == (2, 1)
    with pytest.raises(ComponentsError, match="rank 0"):  # the same field in both groups
        read_outputs(store, ["coarse", "coarse"],
                     OutputRequest((20.0,), scalars=(), field="displacement"))


def test_several_pressures_must_be_chosen(tmp_path):
    store = tmp_path / "pressures.zarr"
    make_store(store, group="a", pressures=(0.2, 0.25), **TINY)
    with pytest.raises(ParameterError, match=r"several pressures at deflection 20 mm "
                                             r"\(200, 250 kPa\)"):
        read_outputs(store, ["a", "a"], OutputRequest((20.0,), scalars=("Fz",)))
    out = read_outputs(store, ["a", "a"], OutputRequest((20.0,), (0.2, 0.25), scalars=("Fz",)))
    assert out.labels == ("Fz d=20mm p=200kPa", "Fz d=20mm p=250kPa")
    assert out.y[0, 1] > out.y[0, 0]  # stiffer at the higher pressure (synthetic Fz ~ p^0.3)


@pytest.mark.parametrize(
    ("kw", "message"),
    [
        ({"deflections": ()}, "deflections must be positive"),
        ({"deflections": (20.0,), "scalars": ("Fx",)}, "unknown scalar"),
        ({"deflections": (20.0,), "field": "stress"}, "field must be one of"),
        ({"deflections": (20.0,), "components": 0}, "components must be a positive"),
    ],
)
def test_output_requests_are_checked(kw, message):
    with pytest.raises(ParameterError, match=message):
        OutputRequest(**kw)



# ---- field outputs across circumferential mesh densities ----------------------------
R_RING = 300.0


def _ring_field(theta, r, amp):
    """Known smooth fields on a full ring: displacement as (radial, axial, tangential)
    and the local-frame strain, functions of the angle and the meridional row."""
    radial = amp * (1.0 + r) * (1.0 + 0.3 * np.cos(theta) + 0.1 * np.sin(2 * theta))
    disp = np.column_stack([radial, 0.2 * np.sin(theta), 0.5 * np.cos(theta)])
    strain = np.column_stack([amp * (1 + r) * np.cos(theta), np.sin(theta),
                              0.1 * np.cos(2 * theta)])
    return disp, strain


def _cartesian(w, theta):
    s, c = np.sin(theta), np.cos(theta)
    return np.column_stack([w[:, 0] * s + w[:, 2] * c, w[:, 1], -w[:, 0] * c + w[:, 2] * s])


def _ring(store, group, cols, amp=1.0, phase=0.1, field=_ring_field):
    """A synthetic full-tyre group: 4 meridional rows of ``cols`` nodes round the y axis."""
    make_store(store, group=group, **{**TINY, "cols": cols, "include_strain": True})
    root = zarr.open_group(str(store), path=group, mode="r+")
    r, c = root["inner_row"][:], root["inner_col"][:]
    theta = phase + 2 * PI * c / cols
    root["inner_xyz"][:] = np.column_stack(
        [R_RING * np.sin(theta), 50.0 * (r - 1.5), -R_RING * np.cos(theta)])
    disp, strain = field(theta, r, amp)
    root["displacement"][:] = np.repeat(_cartesian(disp, theta)[None], 2, axis=0)
    root["strain"][:] = np.repeat(strain[None], 2, axis=0)
    return theta, r


def _chosen(store, groups):
    import storage

    return {g: storage.open_dataset(store, g).isel(experiment=[0]) for g in groups}


@pytest.mark.parametrize("name", ["displacement", "strain"])
def test_a_finer_ring_is_resampled_onto_the_coarse_nodes_within_interpolation_error(
        tmp_path, name):
    from analysis.sensitivity_data import _field_scores, _grid, _resampled

    store = tmp_path / "rings.zarr"
    theta, r = _ring(store, "coarse", 16, phase=0.0)
    _ring(store, "fine", 24, amp=1.5, phase=0.05)  # other angles: nothing coincides
    chosen = _chosen(store, ["fine", "coarse"])
    shapes = {g: chosen[g][name].shape[1:] for g in chosen}
    grids = {g: _grid(chosen[g]) for g in chosen}
    got = _resampled(chosen, ["fine", "coarse"], name, shapes, grids, ["coarse"])
    assert got.shape == (2, 16 * 4 * 3)
    disp, strain = _ring_field(theta, r, 1.5)
    exact = _cartesian(disp, theta) if name == "displacement" else strain
    # linear interpolation: |error| <= h^2 / 8 max|f''|, h the fine spacing; f'' of the
    # fields above is at most 4 (1 + r) (0.3 + 4 * 0.1) * 1.5 <= 17 (radial, row 3)
    h = 2 * PI / 24
    error = np.abs(got[0].reshape(-1, 3) - exact)
    assert error.max() <= h**2 / 8 * 17
    assert error.max() > 1e-6  # it did interpolate (the angles do not coincide)
    np.testing.assert_array_equal(got[1], chosen["coarse"][name].values[0].ravel())
    # PCA scores of the two groups: defined, one mode (they differ by 1.5x)
    scores, explained = _field_scores(chosen, ["fine", "coarse"], np.array([0, 1]),
                                      OutputRequest((20.0,), scalars=(), field=name,
                                                    components=1))
    assert scores.shape == (2, 1) and explained[0] == pytest.approx(1.0)


def test_a_uniform_radial_displacement_is_resampled_exactly():
    """Interpolated as x, y, z vectors, a radial field would shrink by cos(h/2) between
    columns; as radial/axial/tangential components it stays exact."""
    import tempfile

    from analysis.sensitivity_data import _grid, _resampled

    def uniform(theta, r, amp):
        disp = np.column_stack([np.full_like(theta, 2.0), np.zeros_like(theta),
                                np.zeros_like(theta)])
        return disp, np.zeros((len(theta), 3))

    with tempfile.TemporaryDirectory() as tmp:
        store = f"{tmp}/uniform.zarr"
        _ring(store, "coarse", 12, field=uniform, phase=0.0)
        _ring(store, "fine", 8, field=uniform, phase=0.2)  # now the coarsest is 'fine'
        chosen = _chosen(store, ["coarse", "fine"])
        grids = {g: _grid(chosen[g]) for g in chosen}
        shapes = {g: chosen[g]["displacement"].shape[1:] for g in chosen}
        got = _resampled(chosen, ["coarse", "fine"], "displacement", shapes, grids, ["fine"])
    assert got.shape == (2, 8 * 4 * 3)
    np.testing.assert_allclose(got[0], got[1], atol=1e-12)


def test_field_scores_over_a_mesh_density_design_follow_the_field_amplitude(tmp_path):
    store = tmp_path / "design.zarr"
    amps = [0.5, 1.0, 1.5, 2.0, 2.5, 3.0]
    groups = [f"g{i}" for i in range(len(amps))]
    for i, (g, a) in enumerate(zip(groups, amps, strict=True)):
        _ring(store, g, (16, 24)[i % 2], amp=a, phase=0.03 * i)
    out = read_outputs(store, groups, OutputRequest((20.0,), scalars=(), field="strain",
                                                    components=1))
    pc1 = out.y[:, 0]
    assert abs(np.corrcoef(pc1, amps)[0, 1]) > 0.999
    assert out.table["explained_variance"].iloc[0] > 0.99


def test_a_common_mesh_is_not_resampled(design_store, monkeypatch):
    """Groups on one mesh: the stored fields, never interpolated (the PCA of the raw fields)."""
    import analysis.sensitivity_data as data

    path, X, groups = design_store

    def boom(*args, **kwargs):
        raise AssertionError("a common mesh must not be resampled")

    monkeypatch.setattr(data, "_resampled", boom)
    after = read_outputs(path, groups, OutputRequest((20.0,), scalars=(), field="displacement",
                                                     components=1))
    F = np.stack([X[i, 1] * _pattern(24).ravel() * (20.0 / 30.0) for i in range(len(X))])
    F = F - F.mean(axis=0)
    U, S, _ = np.linalg.svd(F, full_matrices=False)
    np.testing.assert_allclose(np.abs(after.y[:, 0]), np.abs(U[:, 0] * S[0]), rtol=1e-9)
