"""Several elements through the wall (issue 15, farm/mesh/layers.py): ids, geometry, physics.

The split is exact geometry (each child is its parent's trilinear map on a slab of the
through-wall coordinate), so volumes and node positions are checked against the
one-element mesh; the solved checks use the coarse reduced sector of tests/farm/test_forces.py.
"""

import dataclasses

import numpy as np
import pytest

from farm.ccx.deck import cavity_pressure_lines, contact_lines
from farm.errors import MeshError, SpecError
from farm.experiment import run_load_path
from farm.mesh import TyreMesh, build_mesh, mesh_for
from farm.mesh.layers import split_wall
from farm.mesh.tyremesh import hex_jacobians
from farm.mesh.version import mesh_key
from farm.mesh.volume import hex_volumes
from farm.presets import default_model
from farm.solve.contact import inflate, slave_faces
from farm.solve.forces import solve_applied_forces
from farm.specs import LoadPath, MeshDensity, ModelSpec, SolverSettings
from jobs.identity import experiment_id

COARSE = {"reduced": MeshDensity(tread=4, sidewall=2, bead=1, circumferential=8),
          "full": MeshDensity(tread=4, sidewall=2, bead=1, circumferential=16)}
SETTINGS = SolverSettings()


def _spec(kind: str, through: int, **changes) -> ModelSpec:
    spec = default_model(kind, mesh=dataclasses.replace(COARSE[kind], through=through))
    return dataclasses.replace(spec, **changes)


# ---- ids: a one-element wall keeps every key it had before the option existed ----

# Computed on the code before `mesh.through` existed (commit 8bc2bcb, gmsh of
# scripts/setup.sh): python -c "from farm.presets import default_model; from
# farm.mesh.version import mesh_key; print(mesh_key(default_model('full')))", and
# jobs.identity.experiment_id(model, 10.0, 200.0, "iterative").
BEFORE = {
    "full": ("f260b2b6e1f24206b098b1ede9be63d8603f66fead4bcf7faf4f57e5ce4dc9f7",
             "c963d9163a516f56f7d2bc9731b7674feb6a6aa7da444216aee06582cd704815"),
    "reduced": ("d3b7814ce78bff0c737677d1fb370de4801db808fd6c5648b4953d725ed55727",
                "9169afea045d72994c010d54180c32281fc5b64a08e2b6efd6108700fcd70342"),
}


@pytest.mark.parametrize("kind", ["full", "reduced"])
def test_one_element_wall_keeps_its_mesh_key_and_experiment_id(kind):
    model = default_model(kind)
    assert model.mesh.through == 1
    assert mesh_key(model) == BEFORE[kind][0]
    assert experiment_id(model, 10.0, 200.0, "iterative") == BEFORE[kind][1]
    assert "through" not in model.to_dict()["mesh"]


def test_a_layered_wall_is_another_mesh_and_another_experiment():
    one = default_model("full")
    two = dataclasses.replace(one, mesh=dataclasses.replace(one.mesh, through=2))
    assert two.to_dict()["mesh"]["through"] == 2
    assert ModelSpec.from_dict(two.to_dict()) == two  # sweepable like any spec field
    assert mesh_key(two) != mesh_key(one)
    assert experiment_id(two, 10.0, 200.0, "iterative") != BEFORE["full"][1]
    assert two.node_estimate == 3 * one.node_estimate // 2  # three node layers, not two


def test_only_a_layered_key_depends_on_the_splitter_source(monkeypatch):
    from farm.mesh import version

    one = default_model("reduced")
    two = dataclasses.replace(one, mesh=dataclasses.replace(one.mesh, through=2))
    before = mesh_key(one), mesh_key(two)
    monkeypatch.setattr(version, "layers_fingerprint", lambda: "an edited layers.py")
    assert mesh_key(one) == before[0]
    assert mesh_key(two) != before[1]


def test_editable_dict_names_through_and_round_trips():
    one = default_model("reduced")
    table = one.editable_dict()
    assert table["mesh"]["through"] == 1 and "through" not in one.to_dict()["mesh"]
    assert ModelSpec.from_dict(table) == one
    table["mesh"]["through"] = 3
    assert ModelSpec.from_dict(table).mesh.through == 3


@pytest.mark.parametrize("bad", [0, 5, 2.0, True])
def test_through_is_validated(bad):
    with pytest.raises(SpecError, match=r"mesh\.through"):
        ModelSpec.from_dict({"kind": "reduced", "mesh": {"through": bad}})


# ---- geometry of the split ----

@pytest.fixture(scope="module", params=["reduced", "full"])
def meshes(request):
    """The coarse mesh of one kind with 1..4 elements through the wall."""
    return {t: build_mesh(_spec(request.param, t)) for t in (1, 2, 3, 4)}


@pytest.mark.parametrize("through", [2, 3, 4])
def test_split_keeps_the_volume_and_every_jacobian_positive(meshes, through):
    one, many = meshes[1], meshes[through]
    v1 = hex_volumes(one.nodes, one.elements)
    vn = hex_volumes(many.nodes, many.elements)
    assert vn.sum() == pytest.approx(v1.sum(), rel=1e-9)
    # layer by layer each parent's volume is shared out exactly
    np.testing.assert_allclose(vn.reshape(through, -1).sum(axis=0), v1, rtol=1e-9)
    assert np.all(hex_jacobians(many.nodes, many.elements) > 0)


@pytest.mark.parametrize("through", [2, 3, 4])
def test_node_and_element_counts(meshes, through):
    one, many = meshes[1], meshes[through]
    n_lines = one.inner_grid.size  # one through-wall line per cavity node
    assert many.n_nodes == one.n_nodes + (through - 1) * n_lines
    assert many.n_elements == through * one.n_elements
    spec = _spec("full" if one.periodic else "reduced", through)
    assert spec.node_estimate == many.n_nodes  # the arithmetic jobs/validate bounds
    assert np.array_equal(many.element_region, np.tile(one.element_region, through))
    # surfaces and grids are the one-element mesh's, node ids included
    np.testing.assert_array_equal(many.nodes[:one.n_nodes], one.nodes)
    for name in ("INNER", "OUTER", "TREAD_OUTER"):
        np.testing.assert_array_equal(many.node_sets[name], one.node_sets[name])
    np.testing.assert_array_equal(many.inner_grid, one.inner_grid)
    np.testing.assert_array_equal(many.outer_grid, one.outer_grid)
    # supports gain the interior nodes of their through-wall lines: (through + 1) levels
    for name in ("BEAD_SEAT", "CUT_START", "CUT_END"):
        if name in one.node_sets:
            assert len(many.node_sets[name]) == len(one.node_sets[name]) * (through + 1) // 2


def test_interior_nodes_divide_the_wall_evenly(meshes):
    """The new nodes are exactly the thirds of the parent's through-wall edges."""
    one, three = meshes[1], meshes[3]
    inner, outer = one.node_sets["INNER"], one.node_sets["OUTER"]
    edges = one.elements[:, [[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4],
                             [0, 4], [1, 5], [2, 6], [3, 7]]].reshape(-1, 2)
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    a_in = np.isin(edges[:, 0], inner) & np.isin(edges[:, 1], outer)
    b_in = np.isin(edges[:, 1], inner) & np.isin(edges[:, 0], outer)
    walls = np.vstack([edges[a_in], edges[b_in][:, ::-1]])  # (lines, 2): cavity, outside
    assert len(walls) == inner.size  # one straight line through the wall per cavity node
    xi, xo = one.xyz(walls[:, 0]), one.xyz(walls[:, 1])
    expected = np.vstack([xi + (xo - xi) / 3, xi + 2 * (xo - xi) / 3])
    got = three.nodes[one.n_nodes:]
    assert len(got) == len(expected)
    order = np.lexsort(np.round(expected, 6).T)
    np.testing.assert_allclose(got[np.lexsort(np.round(got, 6).T)], expected[order],
                               atol=1e-9)


def test_only_the_cavity_and_outside_layers_have_surface_faces(meshes):
    one, two = meshes[1], meshes[2]
    e = one.n_elements
    np.testing.assert_array_equal(two.inner_face[:e], one.inner_face)
    np.testing.assert_array_equal(two.outer_face[e:], one.outer_face)
    assert np.all(two.inner_face[e:] == 0) and np.all(two.outer_face[:e] == 0)
    # the deck loads the cavity faces only and makes the last layer the contact slave
    pressure = cavity_pressure_lines(two, 0.2, None)[1:]
    assert pressure == cavity_pressure_lines(one, 0.2, None)[1:]
    faces = contact_lines(two, default_model("full").contact)
    slaves = faces[1:faces.index("*SURFACE INTERACTION, NAME=ROAD_CONTACT")]
    assert len(slaves) == len(one.region_elements("tread"))
    assert all(int(s.split(",")[0]) > e and ", S0" not in s for s in slaves)
    np.testing.assert_array_equal(np.sort(slave_faces(two), axis=1),
                                  np.sort(slave_faces(one), axis=1))


def test_split_refuses_a_layered_mesh_and_round_trips_through_the_cache(meshes, tmp_path):
    two = meshes[2]
    with pytest.raises(MeshError, match="one-element-thick"):
        split_wall(two, 2)
    assert split_wall(meshes[1], 1) is meshes[1]
    two.save(tmp_path / "m.npz")
    back = TyreMesh.load(tmp_path / "m.npz")
    np.testing.assert_array_equal(back.inner_face, two.inner_face)
    assert back.node_sets["BEAD_SEAT"].size == two.node_sets["BEAD_SEAT"].size
    np.testing.assert_array_equal(back.elements, two.elements)


# ---- physics with the real solver (coarse reduced sector) ----

@pytest.fixture(scope="module")
def contact_10mm(ccx):
    """Rigid-plane contact at 10 mm, one and two elements through the wall."""
    return {t: run_load_path(_spec("reduced", t, road="contact"), LoadPath((10.0,)),
                             SETTINGS) for t in (1, 2)}


@pytest.mark.ccx
def test_layered_wall_balances_the_road_and_stays_symmetric(contact_10mm):
    m = contact_10mm[2].measurements[0]
    fz = m.total_force[2]
    assert fz > 0
    assert fz == pytest.approx(m.road_reaction[2], rel=5e-3)
    assert np.abs(m.total_force[:2]).max() < 1e-6 * fz  # frictionless: Fx = Fy = 0
    assert abs(m.road_reaction[1]) < 1e-6 * fz
    # symmetric about the wheel plane: the contact pressures mirror in y
    lever = fz * 100.0  # the coarse patch is ~100 mm wide
    assert abs(m.moment[0]) < 1e-3 * lever and abs(m.moment[1]) < 1e-3 * lever


@pytest.mark.ccx
def test_layered_wall_force_is_close_to_the_one_element_wall(contact_10mm):
    # measured: 436.4 N with two elements vs 461.9 N with one (-5.5 %): the uninflated
    # sector deforms mainly in wall bending, which a second C3D8I layer softens a little
    one, two = (contact_10mm[t].measurements[0].total_force[2] for t in (1, 2))
    assert 0.85 < two / one < 1.02


@pytest.mark.ccx
def test_layered_wall_writes_the_interior_displacement(contact_10mm):
    """Interior nodes are solved and written (full fields, VTU export): each moves
    between the cavity and outside nodes of its through-wall line."""
    result = contact_10mm[2]
    u = result.states[0].displacement
    assert np.isfinite(u).all()
    mesh = mesh_for(result.model)
    n1 = mesh_for(_spec("reduced", 1)).n_nodes
    interior = np.arange(n1 + 1, mesh.n_nodes + 1)
    inner = mesh.node_sets["INNER"]
    # each interior node's cavity-side neighbour: the nearest inner-surface node
    near = inner[np.linalg.norm(mesh.xyz(interior)[:, None] - mesh.xyz(inner)[None],
                                axis=2).argmin(axis=1)]
    assert np.abs(u[interior - 1]).max() > 1.0  # the wall under the road moves
    # the middle of a 2-element wall moves with the wall: within a few mm of its cavity node
    assert np.abs(u[interior - 1] - u[near - 1]).max() < 0.5 * np.abs(u).max()


@pytest.mark.ccx
def test_layered_wall_supports_carry_the_applied_forces():
    """The iterative road's reaction is what the supports do not carry; with a layered
    wall the supports have interior nodes, whose reactions must be written too."""
    spec = _spec("reduced", 2)
    mesh = mesh_for(spec)
    nodes = mesh.tread_nodes[[1, len(mesh.tread_nodes) // 2, -2]]
    forces = np.array([50.0, 20.0, 5.0])
    state = solve_applied_forces(spec, mesh, nodes, forces, SETTINGS).states[0]
    assert np.isfinite(state.road_reaction).all()
    assert state.road_reaction[2] == pytest.approx(forces.sum(), rel=1e-3)


@pytest.mark.ccx
def test_layered_wall_on_the_iterative_road_balances():
    m = run_load_path(_spec("reduced", 2), LoadPath((10.0,)), SETTINGS).measurements[0]
    assert m.total_force[2] == pytest.approx(m.road_reaction[2], rel=5e-3)
    assert abs(m.total_force[1]) < 1e-6 * m.total_force[2]


@pytest.mark.slow
@pytest.mark.ccx
def test_full_model_inflation_growth_barely_depends_on_the_layers():
    # measured at 200 kPa on the default full mesh: 16.124 mm (one element), 16.108 mm
    # (two; -0.10 %), 16.097 mm (three): inflation is membrane action, which one C3D8I
    # element already carries; the thesis' growth is ~16 mm (§3.3.2)
    growth = {}
    for t in (1, 2):
        full = default_model("full")
        spec = dataclasses.replace(full, mesh=dataclasses.replace(full.mesh, through=t))
        mesh = mesh_for(spec)
        _, lowest = inflate(spec, mesh, 0.2, SETTINGS)
        growth[t] = mesh.bottom_z - lowest
    assert growth[1] > 10.0
    assert growth[2] == pytest.approx(growth[1], rel=0.01)


@pytest.mark.slow
@pytest.mark.ccx
def test_full_model_force_barely_depends_on_the_layers():
    # measured at 200 kPa, 20 mm on the default full mesh: Fz 3439.0 N (one element),
    # 3451.5 N (two; +0.36 %); at 10 mm 1595.2 / 1613.1 N (+1.1 %)
    full = default_model("full")
    fz = {}
    for t in (1, 2):
        spec = dataclasses.replace(full, mesh=dataclasses.replace(full.mesh, through=t))
        m = run_load_path(spec, LoadPath((20.0,), 0.2), SETTINGS).measurements[0]
        assert m.total_force[2] == pytest.approx(m.road_reaction[2], rel=5e-3)
        assert abs(m.total_force[1]) < 1e-6 * m.total_force[2]
        fz[t] = m.total_force[2]
    assert fz[2] == pytest.approx(fz[1], rel=0.02)
