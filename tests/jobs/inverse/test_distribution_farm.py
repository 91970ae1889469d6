"""The "tyre distribution" on the farm's own data (real solver, coarse reduced mesh).

The chapter-3 force-deflection sweep of the reduced model (5-40 mm, Table 3.1
materials: what `farm reproduce` writes) trains the distribution; its 30 mm experiment
is left out and then predicted. The uncalibrated and calibrated reduced models differ
by a common modulus only, so their normalised force maps are the same: the held-out
map stands for the inverse problem's truth up to scale.
"""

import numpy as np
import pytest

from jobs.errors import StudyError
from jobs.inverse.distribution import check_mesh, fit_distribution, guess_from, training_set
from jobs.inverse.run import Inverse
from jobs.inverse.study import parse_inverse_study
from jobs.reproduce import validation
from jobs.reproduce.options import Options
from jobs.study import parse_study
from jobs.sweep import run_sweep
from tyre_farm_cli import main

pytestmark = pytest.mark.ccx

INVERSE = """
[study]
name = "dist"
store = "{tmp}/inverse.zarr"
cache = "{tmp}/cache"
[model]
kind = "reduced"
materials = "thesis-calibrated"
[model.mesh]
tread = 4
sidewall = 2
bead = 1
circumferential = {circumferential}
[optimizers.least-squares]
max_evaluations = 40
[distribution]
store = "{store}"
group = "{group}"
[[conditions]]
name = "distribution"
initial = "distribution"
"""


@pytest.fixture(scope="module")
def sweep(tmp_path_factory, ccx):
    tmp = tmp_path_factory.mktemp("dist-sweep")
    opts = Options(out=tmp, store=str(tmp / "thesis.zarr"), coarse=True)
    study = parse_study(validation.study_text(opts, "ch3-reduced", "reduced",
                                              validation.STEPS), "ch3-reduced.toml")
    report = run_sweep(study, workers=2)
    assert report.ok
    return opts.store, study.group_name


def test_the_held_out_30_mm_map_beats_the_uniform_guess(sweep):
    data = training_set(*sweep)
    d = data.params["deflection"]
    k = int(np.flatnonzero(np.isclose(d, 30.0))[0])
    model = fit_distribution(data, n_components=3, degree=2, exclude={"deflection": 30.0},
                             within=0.5)
    assert model.parameters_ == ("deflection",)
    truth = data.forces[k]
    contact = truth > 0
    nodes = data.tread_nodes[contact]
    total = float(truth[contact].sum())
    guess = guess_from(model, data.tread_nodes, nodes, {"deflection": 30.0}, total)
    uniform = np.full(nodes.size, total / nodes.size)
    err, err_uniform = (np.sqrt(np.mean((g - truth[contact]) ** 2)) for g in (guess, uniform))
    assert err < err_uniform
    # the model's own total, interpolated between 25 and 35 mm: 7 % low on this coarse
    # mesh, whose force-deflection curve steps as tread nodes come into contact
    # (+558 N from 25 to 30 mm, +340 N from 30 to 35 mm)
    assert model.predict_total({"deflection": 30.0})[0] == pytest.approx(total, rel=0.10)


def test_the_study_trains_before_anything_runs_and_refuses_another_mesh(sweep, tmp_path):
    store, group = sweep
    study = parse_inverse_study(INVERSE.format(tmp=tmp_path, store=store, group=group,
                                               circumferential=8))
    inverse = Inverse(study, write=False)  # no cluster, no solver: training only
    assert inverse.distribution is not None and inverse.distribution.n_components_ == 3
    other = parse_inverse_study(INVERSE.format(tmp=tmp_path, store=store, group=group,
                                               circumferential=10))
    with pytest.raises(StudyError, match=r"distribution\.group: its tread nodes"):
        Inverse(other, write=False)
    data = training_set(store, group)
    with pytest.raises(StudyError):
        check_mesh(data, data.tread_nodes[::-1], data.tread_xyz[::-1])


def test_cli_refuses_a_missing_training_group_in_one_line(sweep, tmp_path, capsys):
    store, _ = sweep
    path = tmp_path / "s.toml"
    path.write_text(INVERSE.format(tmp=tmp_path, store=store, group="nope",
                                   circumferential=8))
    with pytest.raises(SystemExit) as info:
        main(["invert", str(path), "--workers", "1"])
    err = capsys.readouterr().err
    assert info.value.code == 1 and len(err.strip().splitlines()) == 1
    assert "distribution: cannot read group 'nope'" in err
    assert not (tmp_path / "cache").exists()  # nothing solved
