"""Which tyre and mesh a model is, in one line (issue 48): `farm run` and `farm roll`
start with it, so a default run is never mistaken for the credible tyre."""

from __future__ import annotations

import dataclasses

import pytest

from farm.presets import (
    CREDIBLE,
    MATERIAL_PRESETS,
    MESH_PRESETS,
    default_model,
    describe_model,
    materials_name,
    mesh_name,
)
from farm.specs import Material, ModelSpec
from tyre_farm_cli.params import kpa_hint


@pytest.mark.parametrize("mesh", [m for m, kinds in MESH_PRESETS.items() if "full" in kinds])
@pytest.mark.parametrize("materials", [m for m, k in MATERIAL_PRESETS.items() if "full" in k])
def test_every_preset_pair_is_named_back(materials, mesh):
    spec = default_model("full", materials=materials, mesh=mesh)
    assert (materials_name(spec), mesh_name(spec)) == (materials, mesh)
    line = describe_model(spec)
    assert f"materials {materials}: " in line and f"mesh {mesh}: " in line
    credible = (materials, mesh) == CREDIBLE
    assert ("for results use" in line) is not credible
    assert "\n" not in line


def test_the_credible_pair_exists_and_is_said_to_be_converged():
    spec = default_model("full", materials=CREDIBLE[0], mesh=CREDIBLE[1])
    assert "converged in every direction" in describe_model(spec)


def test_a_changed_preset_is_not_named_as_the_preset():
    base = default_model("full", materials="reinforced-calibrated", mesh="converged")
    mesh = dataclasses.replace(base, mesh=dataclasses.replace(base.mesh, sidewall=5))
    assert mesh_name(mesh) is None
    assert "a mesh of its own (tread 12, sidewall 5, bead 2, 66 round, 2 through" in \
        describe_model(mesh)
    rubber = dataclasses.replace(base, materials=dataclasses.replace(
        base.materials, tread=Material(5.0, 0.49)))
    assert materials_name(rubber) is None
    assert "materials of its own" in describe_model(rubber)
    cordless = dataclasses.replace(base, reinforcement=None)  # same rubber, no cords
    assert materials_name(cordless) is None


@pytest.mark.parametrize(("kpa", "hinted"), [(0.2, True), (0.08, True), (4.9, True),
                                              (0.0, False), (5.0, False), (80.0, False),
                                              (200.0, False)])
def test_a_pressure_that_looks_like_mpa_gets_a_hint(kpa, hinted):
    hint = kpa_hint(kpa)
    assert bool(hint) is hinted
    if hinted:
        assert f"--pressure {kpa * 1000:g}" in hint


def test_a_preset_read_back_from_its_stored_dict_keeps_its_name():
    """A stated belt depth its wall gives anyway is not stored (one id per model), so the
    spec read back has belt_depth None: still its preset's (issue 44)."""
    spec = default_model("full", "reinforced-converged", mesh="converged")
    back = ModelSpec.from_dict(spec.to_dict())
    assert back.reinforcement.belt_depth is None and back != spec
    assert materials_name(back) == materials_name(spec) == "reinforced-converged"
    lean = default_model("full", "reinforced-lean", mesh="lean")
    assert materials_name(ModelSpec.from_dict(lean.to_dict())) == "reinforced-lean"
