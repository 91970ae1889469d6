"""Specs are validated once, at construction, with errors that name the bad key."""

import dataclasses

import pytest

from farm.errors import SpecError
from farm.presets import default_model
from farm.specs import (
    ContactLaw,
    LoadPath,
    Material,
    MeshDensity,
    ModelSpec,
    SolverSettings,
    TyreGeometry,
    content_hash,
)


@pytest.mark.parametrize("kind,elements", [("reduced", 440), ("full", 880)])
def test_presets_match_thesis_table_3_1(kind, elements):
    spec = default_model(kind)
    assert spec.mesh.meridional * spec.mesh.circumferential == elements
    e = {r: m.youngs_modulus for r, m in spec.materials.by_region().items()}
    if kind == "reduced":
        assert e == {"tread": 10, "sidewall": 10, "bead": 10}
        assert spec.materials.tread.poisson_ratio == 0.499 and not spec.inflated
    else:
        assert e == {"tread": 60, "sidewall": 20, "bead": 20}
        assert spec.materials.tread.poisson_ratio == 0.4 and spec.inflated


def test_neo_hooke_constants_follow_from_small_strain_moduli():
    m = Material(10.0, 0.499)
    shear, bulk = 10 / (2 * 1.499), 10 / (3 * (1 - 0.998))
    assert m.c10 == pytest.approx(shear / 2)
    assert m.d1 == pytest.approx(2 / bulk)


@pytest.mark.parametrize(
    "make, needle",
    [
        (lambda: TyreGeometry(section_width=-1), "geometry.section_width"),
        (lambda: TyreGeometry(rim_width=300), "rim_width"),
        (lambda: TyreGeometry(tread_thickness=60), "thickness"),
        (lambda: MeshDensity(tread=3), "mesh.tread"),
        (lambda: MeshDensity(circumferential=0), "mesh.circumferential"),
        (lambda: Material(10, 0.5), "poisson_ratio"),
        (lambda: ContactLaw(clearance=0), "contact.clearance"),
        (lambda: ContactLaw(stick_slope=0.0), "contact.stick_slope"),
        (lambda: ModelSpec(kind="half"), "kind"),
        (lambda: dataclasses.replace(default_model("full"), road="iterative"), "road"),
        (lambda: dataclasses.replace(default_model("full"), mesh=MeshDensity(circumferential=22)),
         "multiple of 4"),
        (lambda: dataclasses.replace(default_model("reduced"), sector_angle=10), "sector_angle"),
        (lambda: LoadPath((10.0, 5.0)), "increasing"),
        (lambda: LoadPath((-1.0,)), "positive"),
        (lambda: LoadPath(()), "at least one"),
        (lambda: SolverSettings(min_increment=0.5, initial_increment=0.1), "increments"),
    ],
)
def test_invalid_specs_raise_one_clear_line(make, needle):
    with pytest.raises(SpecError) as info:
        make()
    assert needle in str(info.value)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("kind", ["reduced", "full"])
def test_from_dict_round_trips_and_rejects_unknown_keys(kind):
    spec = default_model(kind)
    assert ModelSpec.from_dict(spec.to_dict()) == spec
    data = spec.to_dict()
    data["geometry"]["tread_widht"] = 200.0
    with pytest.raises(SpecError, match=r"unknown key model\.geometry\.tread_widht"):
        ModelSpec.from_dict(data)


def test_from_dict_rejects_wrong_types():
    data = default_model("full").to_dict()
    data["mesh"]["tread"] = "eight"
    with pytest.raises(SpecError, match=r"model\.mesh\.tread must be a int"):
        ModelSpec.from_dict(data)


def test_load_path_checked_against_model():
    with pytest.raises(SpecError, match="reaches through the tyre"):
        LoadPath((10.0, 190.0), 0.2).check_against(default_model("full"))
    with pytest.raises(SpecError, match="not inflated"):
        LoadPath((10.0,), 0.2).check_against(default_model("reduced"))
    with pytest.raises(SpecError, match="is inflated"):
        LoadPath((10.0,), 0.0).check_against(default_model("full"))


def test_content_hash_is_canonical():
    a = {"b": 1.0, "a": [1, 2]}
    assert content_hash(a) == content_hash({"a": [1, 2], "b": 1.0})
    assert content_hash(default_model("full").to_dict()) != content_hash(
        default_model("reduced").to_dict())


def test_mesh_key_ignores_materials():
    a = default_model("full")
    b = dataclasses.replace(a, materials=default_model("reduced").materials)
    assert a.mesh_key() == b.mesh_key()
    c = dataclasses.replace(a, mesh=MeshDensity(circumferential=80))
    assert a.mesh_key() != c.mesh_key()


def test_a_contact_laws_own_stick_slope_is_in_its_id_only_when_set():
    """Issue 24: a preset's stick slope; every id from before it stays."""
    from farm.ccx.deck import stick_slope

    plain = default_model("full")
    assert "stick_slope" not in plain.to_dict()["contact"]
    assert plain.editable_dict()["contact"]["stick_slope"] is None
    own = dataclasses.replace(plain, contact=ContactLaw(stick_slope=1.0))
    assert own.to_dict()["contact"]["stick_slope"] == 1.0
    assert ModelSpec.from_dict(own.to_dict()) == own
    assert ModelSpec.from_dict(plain.to_dict()) == plain
    assert stick_slope(own.contact) == 1.0
    assert stick_slope(plain.contact) == pytest.approx(4.605, abs=1e-3)  # ln(100) p0 / c0


def test_every_family_name_is_imported_from_farm_specs():
    """Issue 49: farm/specs/ is one module per family; ``from farm.specs import X`` keeps
    working for every public class and bound a family module defines."""
    import farm.specs
    from farm.specs import bounds, loads, model, serial, solver

    for module in (bounds, loads, model, serial, solver):
        own = {n for n, v in vars(module).items() if not n.startswith("_")
               and ((n.isupper() and n != "TYPE_CHECKING")
                    or getattr(v, "__module__", None) == module.__name__)}
        own -= {"Limit", "spec_from_dict", "within"}  # the families' helpers
        assert own <= set(farm.specs.__all__), (module.__name__, own - set(farm.specs.__all__))
    assert all(hasattr(farm.specs, n) for n in farm.specs.__all__)
