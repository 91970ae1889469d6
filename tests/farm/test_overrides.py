"""farm.overrides: a preset plus a table of changed keys -> one ModelSpec, keys read off it."""

import dataclasses

import pytest

from farm import overrides
from farm.errors import SpecError
from farm.presets import default_model
from farm.reinforcement import Reinforcement
from farm.specs import ModelSpec


def test_keys_kinds_and_optional_parts_are_read_off_model_spec():
    assert {f.name for f in dataclasses.fields(ModelSpec)} == overrides.MODEL_KEYS
    assert overrides.MODEL_KINDS == ("reduced", "full")
    assert {"reinforcement": Reinforcement} == overrides.OPTIONAL_PARTS


def test_an_empty_reinforcement_table_gives_a_cordless_preset_the_default_cords():
    spec = overrides.model({"kind": "full", "reinforcement": {}})
    assert spec.reinforcement == Reinforcement()
    assert spec == dataclasses.replace(default_model("full"), reinforcement=Reinforcement())
    assert overrides.model({"kind": "full"}).reinforcement is None  # no table: no cords


def test_overrides_of_a_design_row_merge_into_nested_tables():
    base = default_model("full", "cord-reinforced")
    spec = overrides.override_model(base, {"reinforcement": {"belt": {"plies": 3}}}, "models")
    assert spec.reinforcement.belt.plies == 3
    assert spec.reinforcement.carcass == base.reinforcement.carcass
    with pytest.raises(SpecError, match=r"^models\.reinforcement\.belt\.ply: unknown key"):
        overrides.override_model(base, {"reinforcement": {"belt": {"ply": 3}}}, "models")


def test_a_merged_model_is_held_to_the_mesh_node_limit_in_farm(monkeypatch):
    """Issue 49: the model's limit is checked below jobs, where the table becomes a model;
    a model built directly (a store's, a convergence level) is not held to it."""
    base = default_model("reduced")
    huge = {"mesh": {"circumferential": 1_000_000}}
    with pytest.raises(SpecError, match=r"^models\.mesh: .* mesh nodes, above the limit of "
                                        r"200000 \(set FARM_MAX_MESH_NODES"):
        overrides.override_model(base, huge, "models")
    assert dataclasses.replace(base, mesh=dataclasses.replace(
        base.mesh, circumferential=1_000_000)).node_estimate > 200_000
    monkeypatch.setenv("FARM_MAX_MESH_NODES", "nine")
    with pytest.raises(SpecError, match=r"^FARM_MAX_MESH_NODES must be a whole number"):
        overrides.override_model(base, {}, "models")
    monkeypatch.setenv("FARM_MAX_MESH_NODES", str(10 ** 8))
    assert overrides.override_model(base, huge).mesh.circumferential == 1_000_000
