"""Study files: examples parse; anything malformed is one line, nothing submitted."""

from pathlib import Path

import pytest
from conftest import study_text
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from cli import main
from jobs.errors import StudyError
from jobs.study import load_study, parse_study

EXAMPLES = sorted(Path(__file__).parents[2].joinpath("examples").glob("*.toml"))


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_examples_are_valid(path):
    if path.name.startswith("inverse_"):  # chapter-4 studies have their own format
        from jobs.inverse.study import load_inverse_study

        study = load_inverse_study(path)
    else:
        study = load_study(path)
    assert study.model.kind in ("reduced", "full") and Path(study.store).is_absolute()


def test_thesis_ch5_dataset_is_seven_experiments_at_200_kpa():
    study = load_study(Path(__file__).parents[2] / "examples/thesis_ch5_dataset.toml")
    assert study.pressures == (0.2,)
    assert study.deflections == (10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0)
    assert study.model.materials.tread.youngs_modulus == 60.0


def test_material_table_overrides_one_region():
    text = study_text(Path("/tmp/s.zarr")).replace(
        "[loads]", "[model.materials.tread]\nyoungs_modulus = 7.5\n\n[loads]")
    study = parse_study(text)
    assert study.model.materials.tread.youngs_modulus == 7.5
    assert study.model.materials.sidewall.youngs_modulus == 10.0  # the preset's


@pytest.mark.parametrize(
    "edit, needle",
    [
        (lambda t: t.replace("[loads]", "[loads]\npresure_kpa = [1]"), "loads.presure_kpa"),
        (lambda t: t.replace("tread = 4", "tread = 4\ntreads = 3"), "treads"),
        (lambda t: t.replace('kind = "reduced"', 'kind = "half"'), "model.kind"),
        (lambda t: t.replace("step = 5 }", "step = -5 }"), "loads.deflection_mm.step"),
        (lambda t: t.replace("start = 5", "start = -5"), "loads.deflection_mm.start"),
        (lambda t: t.replace("stop = 30", "stop = 300"), "reaches through the tyre"),
        (lambda t: t.replace("tread = 4", 'tread = "four"'), "model.mesh.tread"),
        (lambda t: t.replace("max_path_length = 1", "max_path_length = -1"),
         "solver.max_path_length"),
        (lambda t: t.replace("[loads]", "[loads]\npressure_kpa = [200]"), "not inflated"),
        (lambda t: t + "\n[extra]\n", "study file.extra"),
        (lambda t: t.replace("[study]", "[study\n"), "not valid TOML"),
        (lambda t: t.replace('store = "', 'stor = "'), "study.stor"),
    ],
)
def test_errors_name_the_key(edit, needle):
    with pytest.raises(StudyError) as info:
        parse_study(edit(study_text(Path("/tmp/s.zarr"))), "bad.toml")
    message = str(info.value)
    assert needle in message and message.startswith("bad.toml") and "\n" not in message


VALID = study_text(Path("STORE"))
lines = VALID.splitlines()


@st.composite
def malformed(draw):
    """Mutations of a valid study: drop, duplicate, retype, misspell or corrupt lines."""
    out = list(lines)
    for _ in range(draw(st.integers(1, 3))):
        k = draw(st.integers(0, len(out) - 1))
        kind = draw(st.sampled_from(["drop", "value", "key", "garbage", "dup"]))
        line = out[k]
        if kind == "drop":
            out.pop(k)
        elif kind == "dup":
            out.insert(k, line)
        elif kind == "value" and "=" in line:
            key = line.split("=")[0]
            out[k] = key + "= " + draw(st.sampled_from(
                ['"x"', "-1", "0", "1e9", "[]", "{}", "true", "[1, -2]", "nan", "{ a = 1 }"]))
        elif kind == "key" and "=" in line:
            out[k] = draw(st.text("abcxyz_", min_size=1, max_size=6)) + line[line.index("="):]
        else:
            out[k] = draw(st.text(min_size=1, max_size=12))
    return "\n".join(out)


def _is_valid(text: str) -> bool:
    try:
        parse_study(text)
        return True
    except StudyError:
        return False


@settings(max_examples=300, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much])
@given(text=malformed())
def test_malformed_study_is_one_line_and_touches_nothing(text, tmp_path_factory, monkeypatch,
                                                         capsys):
    folder = tmp_path_factory.mktemp("study")
    store = folder / "store.zarr"
    text = text.replace("STORE", str(store))
    if _is_valid(text):  # a mutation that still makes sense (e.g. a dropped optional key)
        event("still valid")
        return
    event("malformed")
    path = folder / "study.toml"
    path.write_text(text)

    def no_cluster(*args, **kwargs):
        raise AssertionError("a cluster was started for an invalid study")

    monkeypatch.setattr("jobs.driver.connect", no_cluster)
    with pytest.raises(SystemExit) as info:
        main(["sweep", "submit", str(path)])
    err = capsys.readouterr().err
    assert info.value.code == 1
    assert err.startswith("farm: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err
    assert not store.exists()
