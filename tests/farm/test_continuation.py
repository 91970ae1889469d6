"""Forward solves that continue from a solved state (farm.solve.continuation), real ccx.

Physics: the material is hyperelastic and the loads are dead loads, so an equilibrium
does not depend on the path to it. A state continued from a neighbour (a restart file,
or the previous step of a load path) equals the same loads ramped up from rest, to the
.frd's printed digits, when both are converged tightly; each state balances its loads;
a Jacobian's columns taken along one load path equal separate finite differences.
"""

import numpy as np
import pytest

from farm.ccx import deck as D
from farm.errors import SpecError
from farm.mesh import mesh_for
from farm.presets import default_model
from farm.solve.continuation import path_deck, solve_force_path
from farm.solve.forces import force_deck, solve_applied_forces
from farm.specs import MeshDensity, SolverSettings

COARSE = default_model("reduced", mesh=MeshDensity(tread=4, sidewall=2, bead=1,
                                                   circumferential=8))
SETTINGS = SolverSettings()
# .frd values carry 6 significant digits: U up to ~20 mm differs in its last one
DIGITS = 1e-5


@pytest.fixture(scope="module")
def loaded(ccx):
    """Three loaded tread nodes near the contact patch and a solved state there."""
    mesh = mesh_for(COARSE)
    bottom = np.argsort(mesh.xyz(mesh.tread_nodes)[:, 2])[:3]
    nodes = mesh.tread_nodes[bottom]
    x = np.array([120.0, 90.0, 60.0])
    base = solve_force_path(COARSE, mesh, nodes, [x], SETTINGS, keep_state=True)
    return mesh, nodes, x, base


def _same_state(a, b, scale_u: float):
    assert np.abs(a.displacement - b.displacement).max() <= DIGITS * scale_u
    assert np.abs(a.strain - b.strain).max() <= DIGITS * max(np.abs(b.strain).max(), 1e-3)


def test_a_restart_from_a_neighbour_equals_the_ramp_from_rest(loaded):
    mesh, nodes, x, base = loaded
    assert base.state is not None and len(base.state) > 1000
    new = x + np.array([6.0, -4.0, 9.0])
    warm = solve_force_path(COARSE, mesh, nodes, [new], SETTINGS, start=base.state,
                            keep_state=True)
    cold = solve_force_path(COARSE, mesh, nodes, [new], SETTINGS)
    scale = np.abs(cold.solution.states[0].displacement).max()
    assert scale > 1.0  # a real deformation
    _same_state(warm.solution.states[0], cold.solution.states[0], scale)
    # the restarted run took one short step, not the ramp from rest
    assert warm.solution.increments < cold.solution.increments


def test_a_kept_state_can_be_continued_again(loaded):
    mesh, nodes, x, base = loaded
    first = solve_force_path(COARSE, mesh, nodes, [x + 3.0], SETTINGS, start=base.state,
                             keep_state=True)
    second = solve_force_path(COARSE, mesh, nodes, [x + 6.0], SETTINGS, start=first.state)
    cold = solve_force_path(COARSE, mesh, nodes, [x + 6.0], SETTINGS)
    scale = np.abs(cold.solution.states[0].displacement).max()
    _same_state(second.solution.states[0], cold.solution.states[0], scale)
    assert second.state is None  # not asked to keep it


def test_each_state_of_a_load_path_balances_its_loads(loaded):
    mesh, nodes, x, _ = loaded
    loads = [x, x * 0.5, x * 1.2]
    path = solve_force_path(COARSE, mesh, nodes, loads, SETTINGS)
    assert len(path.solution.states) == 3 and path.solution.ccx_runs == 1
    for fz, state in zip(loads, path.solution.states, strict=True):
        assert state.road_reaction[2] == pytest.approx(fz.sum(), rel=1e-4)
        assert state.tread_force[:, 2].sum() == pytest.approx(fz.sum())
    uz = [s.displacement[nodes - 1, 2].mean() for s in path.solution.states]
    assert uz[1] < uz[0] < uz[2]  # pushed up more, moved up more
    seconds = [s.solve_seconds for s in path.solution.states]
    assert seconds == sorted(seconds) and seconds[-1] <= path.solution.solve_seconds


def test_jacobian_columns_along_one_path_equal_separate_differences(loaded):
    mesh, nodes, x, base = loaded
    h = 0.1
    columns = [x + h * np.eye(3)[k] for k in range(3)]
    path = solve_force_path(COARSE, mesh, nodes, columns, SETTINGS, start=base.state)
    u0 = base.solution.states[0].displacement
    for k, state in enumerate(path.solution.states):
        alone = solve_force_path(COARSE, mesh, nodes, [columns[k]], SETTINGS)
        d_path = (state.displacement - u0) / h
        d_alone = (alone.solution.states[0].displacement - u0) / h
        assert np.linalg.norm(d_path) > 0.01  # a 0.1 N push moves the surface
        assert np.linalg.norm(d_path - d_alone) < 1e-2 * np.linalg.norm(d_alone)


def test_the_plain_evaluation_is_unchanged_and_looser(loaded):
    """force_deck (every evaluation before warm starts) keeps ccx's default convergence:
    the tight one agrees with it to its own tolerance, not to the printed digits."""
    mesh, nodes, x, base = loaded
    plain = solve_applied_forces(COARSE, mesh, nodes, x, SETTINGS).states[0]
    tight = base.solution.states[0]
    scale = np.abs(tight.displacement).max()
    assert np.abs(plain.displacement - tight.displacement).max() < 1e-3 * scale
    assert "*CONTROLS" not in force_deck(COARSE, mesh, nodes, x, SETTINGS)


def test_decks_of_a_restart_and_a_ramp():
    mesh = mesh_for(COARSE)
    nodes = mesh.tread_nodes[:2]
    loads = [np.array([1.0, 2.0]), np.array([1.5, 2.0])]
    ramp = path_deck(COARSE, mesh, nodes, loads, SETTINGS, restart=False, keep_state=True)
    lines = ramp.splitlines()
    assert lines.count("*STEP, NLGEOM, INC=500") == 2 and "*NODE, NSET=TYRE" in lines
    assert lines.count(D.tight_controls_lines()[0]) == 2
    assert lines.index("*RESTART, WRITE, FREQUENCY=1") < lines.index("*STEP, NLGEOM, INC=500")
    assert lines.count("*CLOAD") == 1 and lines.count("*CLOAD, OP=NEW") == 1
    again = path_deck(COARSE, mesh, nodes, loads, SETTINGS, restart=True, keep_state=False)
    lines = again.splitlines()
    assert lines[0] == "*RESTART, READ" and "*NODE, NSET=TYRE" not in lines
    assert "*RESTART, WRITE, FREQUENCY=1" not in lines and "*BOUNDARY" not in lines
    assert lines.count("*CLOAD, OP=NEW") == 2


@pytest.mark.parametrize(("loads", "match"), [
    ([], "at least one force vector"),
    ([np.array([1.0])], "one finite force per node"),
    ([np.array([1.0, np.nan])], "one finite force per node"),
])
def test_bad_load_paths_are_refused_before_ccx_runs(loads, match):
    mesh = mesh_for(COARSE)
    with pytest.raises(SpecError, match=match):
        solve_force_path(COARSE, mesh, mesh.tread_nodes[:2], loads, SETTINGS)
