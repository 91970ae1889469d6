"""The adaptive study's record in its group (storage.rounds, issue 28): kept as given,
replaced whole, readable through xarray's metadata too, bad values refused."""

from __future__ import annotations

import math

import pytest

import storage
from storage.errors import SchemaError


def test_a_record_round_trips_and_is_replaced_whole(store, group):
    assert storage.read_rounds(store, group) is None  # no adaptive study wrote one
    record = {"version": 1, "rounds": [{"round": 1, "points": [[10.5, 0.25]],
                                        "errors": {"Fz": 1.25, "Mz": None}}], "final": None}
    storage.write_rounds(store, group, record)
    assert storage.read_rounds(store, group) == record
    storage.write_rounds(store, group, {"version": 1, "rounds": [], "final": None})
    assert storage.read_rounds(store, group)["rounds"] == []
    # the group is still a whole experiment group: readers open it as before
    assert storage.open_dataset(store, group).sizes["experiment"] == 0


@pytest.mark.parametrize("bad", [{"x": math.nan}, {"x": object()}])
def test_values_json_cannot_hold_are_refused(store, group, bad):
    with pytest.raises(SchemaError, match="must be plain JSON"):
        storage.write_rounds(store, group, bad)
    assert storage.read_rounds(store, group) is None  # nothing half-written


def test_a_missing_group_is_named(store, group):
    with pytest.raises(storage.GroupNotFoundError, match="no group 'other'"):
        storage.read_rounds(store, "other")
