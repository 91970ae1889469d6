"""The population study, quick (issue 47), as a user runs it: a sweep of four tyres with
load cases of their own, `farm fit` across three of them, `farm mismatch` on the fourth,
and a cloud of another tyre refused by `farm predict`."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SENSOR = "t2cam-2017,spacing_mm=20,noise_mm=0.2"


def _farm(argv, capsys) -> tuple[int, str, str]:
    from tyre_farm_cli import main

    try:
        main([str(a) for a in argv])
        code = 0
    except SystemExit as e:
        code = int(e.code or 0)
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.ccx
@pytest.mark.e2e
def test_the_quick_population_sweeps_fits_and_meets_a_tyre_it_never_saw(tmp_path, capsys):
    import storage
    from jobs.study import load_study
    from jobs.sweep import parts

    text = (ROOT / "examples" / "population" / "quick.toml").read_text()
    study = tmp_path / "quick.toml"
    study.write_text(text.replace('"results/population_quick.zarr"',
                                  f'"{tmp_path / "pop.zarr"}"'))
    code, _, err = _farm(["sweep", "submit", study, "--workers", "2"], capsys)
    assert code in (0, 1), err
    groups = [p.group_name for p in parts(load_study(study))]
    store = tmp_path / "pop.zarr"
    assert sorted(storage.list_groups(store)) == sorted(groups)
    # four tyres, each at load cases of its own
    cases = []
    for g in groups:
        ds = storage.open_dataset(store, g)
        cases.append({(round(float(d), 6), round(float(f), 6)) for d, f in
                      zip(ds["deflection"].values, ds["friction"].values, strict=True)})
    assert all(a.isdisjoint(b) for i, a in enumerate(cases) for b in cases[i + 1:])

    model = tmp_path / "model"
    code, out, err = _farm(["fit", store, "--group", ",".join(groups[:3]), "--out", model,
                            "--sensor", SENSOR, "--folds", 2, "--draws", 2,
                            "--test-fraction", 0.34], capsys)
    assert code == 0, err
    assert "3 tyres, 1 held out" in out
    code, out, err = _farm(["mismatch", model, store, "--group", groups[3], "--json"], capsys)
    assert code == 0, err
    errors = json.loads(out)["errors"]
    assert [e["target"] for e in errors] == ["Fx", "Fy", "Fz", "Mz"]
    fz = next(e for e in errors if e["target"] == "Fz")
    # a tyre the model never saw, inside the population's ranges: its Fz is predicted
    # better than by its own mean (R^2 > 0; 12 training experiments are few)
    own = storage.open_dataset(store, groups[3])["total_force"].sel(component="z").values
    assert fz["rmse"] < own.std(), (fz, own)

    # a cloud of a tyre 1.5x this one's size is refused, not predicted
    clouds = tmp_path / "clouds"
    code, _, err = _farm(["measure", store, "--group", groups[3], "--out", clouds,
                          "--sensor", SENSOR, "--limit", 1], capsys)
    assert code == 0, err
    import pandas as pd

    ref = pd.read_csv(clouds / "reference.csv")
    cloud = next(p for p in clouds.glob("*.csv") if p.name not in ("reference.csv",
                                                                   "truth.csv"))
    big = tmp_path / "big"
    big.mkdir()
    (ref * 1.5).to_csv(big / "reference.csv", index=False)
    (pd.read_csv(cloud) * 1.5).to_csv(big / "cloud.csv", index=False)
    code, out, err = _farm(["predict", model, big / "reference.csv", big / "cloud.csv"],
                           capsys)
    lines = [line for line in err.splitlines() if line.strip()]
    assert code not in (0, 3) and out == "", (out, err)
    assert len(lines) == 1 and "mm" in lines[0], err
