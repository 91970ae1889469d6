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
