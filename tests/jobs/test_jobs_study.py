"""Study files: examples parse; anything malformed is one line, nothing submitted."""

from pathlib import Path

import pytest
from conftest import study_text
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from jobs.errors import StudyError
from jobs.study import load_study, parse_study
from tyre_farm_cli import main

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

    monkeypatch.setattr("jobs.cluster.connect", no_cluster)
    with pytest.raises(SystemExit) as info:
        main(["sweep", "submit", str(path)])
    err = capsys.readouterr().err
    assert info.value.code == 1
    assert err.startswith("farm: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err
    assert not store.exists()


# ------------------------------------------------- hostile input: files, counts, bounds
# (issue 14; the seeded corpus of tests/jobs/test_fuzz_inputs.py runs these and more
# through the CLI, these name each rule and its property)


def _write(tmp_path, text: str | bytes, name="study.toml") -> Path:
    path = tmp_path / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return path


def test_a_study_that_is_not_utf8_is_one_error_naming_the_line(tmp_path):
    text = study_text(tmp_path / "s.zarr").encode()
    path = _write(tmp_path, text.replace(b"[loads]", b"# \xe9t\xe9\n[loads]"))
    with pytest.raises(StudyError, match=r"not UTF-8 text \(byte 0xe9 on line 1[0-9]\)"):
        load_study(path)


@pytest.mark.parametrize("kind", ["fifo", "directory", "device"])
def test_files_that_are_not_regular_are_refused_without_reading(tmp_path, kind):
    import os
    import threading

    path = {"fifo": tmp_path / "pipe.toml", "directory": tmp_path,
            "device": Path("/dev/zero")}[kind]
    if kind == "fifo":
        os.mkfifo(path)
    errors = []

    def load():
        try:
            load_study(path)
        except StudyError as e:
            errors.append(str(e))

    reader = threading.Thread(target=load, daemon=True)
    reader.start()
    reader.join(timeout=10)
    if reader.is_alive() and kind == "fifo":  # unblock the reader: it opened the FIFO
        with open(path, "w"):
            pass
    assert not reader.is_alive() and len(errors) == 1, "the reader waited on the file"
    assert "not a regular file" in errors[0]


def test_a_study_file_over_the_size_limit_is_refused(tmp_path):
    from jobs.validate import limits

    text = study_text(tmp_path / "s.zarr") + "#" * limits.MAX_FILE_BYTES
    with pytest.raises(StudyError, match="larger than 1 MiB"):
        load_study(_write(tmp_path, text))


@pytest.mark.parametrize("depth", [9, 2000])
def test_deep_nesting_is_one_error_not_a_recursion_error(tmp_path, depth):
    text = study_text(tmp_path / "s.zarr").replace(
        'name = "test"', "name = " + "[" * depth + "]" * depth)
    with pytest.raises(StudyError, match="nested"):
        parse_study(text, "deep.toml")


@pytest.mark.parametrize(("step", "match"), [
    ("1e-308", "too many"),  # (stop - start) / step overflows to inf: no int, no list
    ("1e-12", "25000000000001 values is too many"),
])
def test_a_range_step_is_counted_before_anything_is_made(step, match):
    text = study_text(Path("/tmp/s.zarr"), deflections=f"{{ start = 5, stop = 30, step = {step} }}")
    with pytest.raises(StudyError, match=match):
        parse_study(text)


def _grid(pressures: int, deflections: int) -> str:
    return (study_text(Path("/tmp/s.zarr"), deflections=f"{{ start = 1, stop = 100, step = "
                       f"{99 / (deflections - 1)!r} }}")
            .replace('kind = "reduced"\nroad = "contact"', 'kind = "full"')
            .replace("[loads]", f"[loads]\npressure_kpa = {{ start = 100, stop = 300, step = "
                                f"{200 / (pressures - 1)!r} }}"))


def test_the_experiment_count_is_limited_and_the_limit_can_be_raised(monkeypatch):
    study = parse_study(_grid(100, 100))  # exactly the limit
    assert len(study.pressures) * len(study.deflections) == 10_000
    with pytest.raises(StudyError, match=r"loads: 101 pressures x 100 deflections is 10100 "
                                         r"experiments, above the limit of 10000 \(set "
                                         r"FARM_MAX_EXPERIMENTS"):
        parse_study(_grid(101, 100))
    monkeypatch.setenv("FARM_MAX_EXPERIMENTS", "20000")
    assert len(parse_study(_grid(101, 100)).pressures) == 101
    monkeypatch.setenv("FARM_MAX_EXPERIMENTS", "lots")
    with pytest.raises(StudyError, match="FARM_MAX_EXPERIMENTS must be a whole number"):
        parse_study(_grid(101, 100))


def test_a_sampled_design_counts_with_the_loads_it_does_not_sample():
    text = _grid(2, 2).replace("[loads]", "[loads.sample]\nmethod = 'lhs'\nn = 4000\n"
                               "deflection_mm = [5, 30]\n[loads]")
    text = text.replace("deflection_mm = { start", "# deflection_mm = { start")
    with pytest.raises(StudyError, match=r"a design of 4000 points x 3 pressures is 12000"):
        parse_study(text.replace("step = 200.0", "step = 100.0"))
    assert parse_study(text).sampling.n == 4000  # 4000 x 2 pressures


def test_mesh_node_bound_counts_what_the_mesher_makes(monkeypatch):
    import dataclasses

    from farm.mesh import mesh_for
    from farm.presets import default_model
    from farm.specs import MeshDensity

    for kind in ("reduced", "full"):
        spec = dataclasses.replace(default_model(kind), mesh=MeshDensity(4, 2, 1, 8))
        assert spec.node_estimate == len(mesh_for(spec).nodes)
    text = study_text(Path("/tmp/s.zarr")).replace("circumferential = 8",
                                                   "circumferential = 1000000")
    with pytest.raises(StudyError, match=r"model\.mesh: .*circumferential=1000000\) is 22000022 "
                                         r"mesh nodes.*FARM_MAX_MESH_NODES"):
        parse_study(text)
    monkeypatch.setenv("FARM_MAX_MESH_NODES", str(10 ** 8))
    assert parse_study(text).model.mesh.circumferential == 1_000_000


@pytest.mark.parametrize(("edit", "needle"), [
    (("[loads]", "[model.materials.tread]\nyoungs_modulus = 1e308\n[loads]"),
     "model.materials.tread.youngs_modulus must be a number in [0.001, 1e+06] MPa"),
    (("[loads]", "[model.materials.bead]\nyoungs_modulus = 1e-308\n[loads]"),
     "model.materials.bead.youngs_modulus"),
    (("[loads]", "[model.contact]\nclearance = 1e308\n[loads]"), "model.contact.clearance"),
    (("[loads]", "[model.geometry]\nrim_diameter = 1e308\n[loads]"),
     "model.geometry.rim_diameter"),
    (("[loads]", "[model.geometry]\nbead_thickness = 60\n[loads]"),
     "model.geometry.bead_thickness (60.0 mm) is too large"),
    (("[solver]", "[solver]\nthreads = 9223372036854775807"), "solver.threads must be an integer "
     "in [1, 256]"),
    (("[solver]", "[solver]\ntimeout_s = 1e-9"), "solver.timeout_s: must be in [1, 604800]"),
    (("[solver]", "[solver]\nmin_increment = 1e-300"), "solver.min_increment must be >= 1e-12"),
    (("[solver]", "[solver]\nmax_increments = 9223372036854775807"), "solver.max_increments"),
    (("[solver]", "[solver]\ngrow_after = 17"), "solver.grow_after must be an integer in "
     "[1, 16]"),
    (("[solver]", "[solver]\nrestart_every_mm = 5"), "solver.restart_every_mm must be 0 (no "
     "restart points) or in [10, 10000] mm of road travel, got 5"),
    (("start = 5", "start = 5e-324"), "loads.deflection_mm: must be > 0, got 5e-324 (rounds to 0"),
    (('store = "', 'store = "~no_such_user_x/'), "study.store: cannot resolve the path"),
    (('store = "', 'store = "a\\u0000b'), "study.store: must be a directory path or URL"),
])
def test_absurd_values_are_one_error_naming_the_key_and_the_range(edit, needle, tmp_path):
    text = study_text(tmp_path / "s.zarr").replace(*edit)
    with pytest.raises(StudyError) as info:
        load_study(_write(tmp_path, text))
    assert needle in str(info.value) and "\n" not in str(info.value)


def test_pressures_are_bounded_in_kpa():
    text = _grid(2, 2).replace("start = 100, stop = 300", "start = 100, stop = 1e308")
    with pytest.raises(StudyError, match=r"loads.pressure_kpa.stop: must be in \(0, 1000\]"):
        parse_study(text.replace("step = 200.0", "step = 1e307"))


@pytest.mark.parametrize(("address", "ok"), [
    ("tcp://127.0.0.1:8786", True), ("10.0.0.5:8786", True), ("tls://sched.example:8786", True),
    ("tcp://[::1]:8786", True), ("inproc://10.0.0.1/123/1", True), ("ucx://h:13337", False),
    ("tcp://farm_scheduler_1:8786", True), ("not a url", False), ("tcp://host", False),
    ("http://host:8786", False), ("tcp://host:0", False), ("tcp://host:65536", False),
    ("tcp://[::1:8786", False), ("", False), ("tcp://host:8786/x", False),
])
def test_scheduler_addresses(address, ok):
    from jobs.validate import addresses

    if ok:
        assert addresses.scheduler_address(address) == address
    else:
        with pytest.raises(StudyError, match="--scheduler: "):
            addresses.scheduler_address(address)


@pytest.mark.parametrize("argv", [["--workers", "-3"], ["--workers", "0"],
                                  ["--workers", "100000"], ["--scheduler", "not a url"]])
def test_bad_cluster_options_are_usage_errors_before_the_study_is_read(argv, capsys,
                                                                       monkeypatch):
    monkeypatch.setattr("jobs.cluster.connect", lambda *a, **k: pytest.fail("connected"))
    with pytest.raises(SystemExit) as info:
        main(["sweep", "submit", "no-such-study.toml", *argv])
    err = capsys.readouterr().err
    assert info.value.code == 2 and err.count("\n") == 1
    assert err.startswith(f"farm: error: Invalid value for '{argv[0]}'")
