"""The surrogate-first start of the inverse loops (issue 28): from a measured field to the
load and to the tread force map, on a synthetic sweep whose maps are known."""

from __future__ import annotations

import numpy as np
import pytest

import storage
from analysis.errors import ParameterError
from analysis.surrogate_guess import from_group
from tests.synthetic import make_store


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    path = tmp_path_factory.mktemp("stores") / "sweep.zarr"
    group = make_store(path, n_experiments=9, rows=6, cols=8, tread_rows=4, tread_cols=6)
    ds = storage.done(storage.open_dataset(path, group))
    return path, group, ds


def _experiment(ds, k):
    u = ds["displacement"].transpose("experiment", "inner_node", "component").values[k]
    f = ds["reaction_force"].sel(component="z").transpose("experiment", "tread_node").values[k]
    return np.asarray(u, float), np.asarray(f, float), float(ds["deflection"].values[k])


def test_a_held_out_load_and_its_force_map_are_recovered_from_the_field(sweep):
    path, group, ds = sweep
    order = np.argsort(ds["deflection"].values)
    k = int(order[4])  # a middle experiment, left out of the training as the reference
    u, f, d = _experiment(ds, k)
    guess = from_group(path, group, exclude={"deflection": d}, within=0.1, restarts=1)
    assert guess.names_ == ["deflection"] and len(guess.loads_) == 8
    nodes = np.asarray(ds["tread_node"].values)[f > 0]
    x = guess(u, nodes)
    assert guess.p_[0] == pytest.approx(d, rel=0.02)
    assert np.abs(x - f[f > 0]).max() < 0.05 * f.max()


def test_a_field_of_another_mesh_or_unknown_nodes_are_refused(sweep):
    path, group, ds = sweep
    guess = from_group(path, group, restarts=1)
    u, _, _ = _experiment(ds, 0)
    with pytest.raises(ParameterError, match="same mesh"):
        guess(u[:-1], [])
    with pytest.raises(ParameterError, match="tread node 999999"):
        guess(u, [999999])
