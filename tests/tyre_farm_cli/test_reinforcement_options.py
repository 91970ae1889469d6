"""Issue 24's belt options reach the model from ``--set`` and from a study's [model] table
alike (docs/reinforcement.md)."""

import pytest

from farm.errors import SpecError
from jobs.errors import StudyError
from jobs.validate import spec_tables
from tyre_farm_cli.params import build_model


def test_set_and_study_table_give_the_same_cord_options():
    cli = build_model("full", "cord-reinforced", None,
                      ["reinforcement.belt_layout=cords", "reinforcement.tension_only=true"])
    study = spec_tables.model({"kind": "full", "materials": "cord-reinforced",
                               "reinforcement": {"belt_layout": "cords", "tension_only": True}})
    assert cli == study
    assert cli.reinforcement.belt_layout == "cords" and cli.reinforcement.tension_only is True
    off = build_model("full", "cord-reinforced", None, ["reinforcement.tension_only=False"])
    assert off == build_model("full", "cord-reinforced", None, [])


def test_a_bad_layout_names_the_key_and_the_fix():
    with pytest.raises(SpecError, match=r"model\.reinforcement\.belt_layout must be one of "
                                        r".*--set reinforcement\.belt_layout=cords"):
        build_model("full", "cord-reinforced", None, ["reinforcement.belt_layout=diagonal"])
    with pytest.raises(StudyError, match=r"model\.reinforcement\.tension_only must be true"):
        spec_tables.model({"kind": "full", "materials": "cord-reinforced",
                           "reinforcement": {"tension_only": "yes"}})
