"""The schema in code agrees with the written contract, docs/schema.md."""

from __future__ import annotations

import re

import pytest
from store_helpers import ROOT

from storage import schema


def _contract_rows() -> dict[str, tuple[str, str, str]]:
    """name -> (dims, dtype, units) from the variables table of docs/schema.md."""
    text = (ROOT / "docs" / "schema.md").read_text()
    table = text.split("## Variables", 1)[1].split("\n## ", 1)[0]
    rows = {}
    for line in table.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 5 or not cells[0].startswith("`"):
            continue
        for name in re.findall(r"`([a-z_]+)`", cells[0]):
            rows[name] = (cells[1], cells[2], cells[3])
    return rows


CONTRACT = _contract_rows()


def test_contract_table_was_read():
    assert {"displacement", "status", "inner_row", "tread_col", "pressure"} <= set(CONTRACT)


def test_combined_variables_and_parameters_are_in_the_contract():
    assert {*schema.COMBINED_NAMES, *schema.COMBINED_PARAMETERS} <= set(CONTRACT)


@pytest.mark.parametrize("name", sorted(CONTRACT))
def test_variable_matches_contract(name):
    dims, dtype, units = CONTRACT[name]
    var = schema.FIXED_VARIABLES.get(name)
    if var is None:  # a load-case parameter (required, or a combined-load one)
        var = schema.parameter(name, schema.KNOWN_PARAMETER_UNITS[name])
    assert ", ".join(var.dims) == dims
    assert var.dtype == dtype
    assert var.units == units


@pytest.mark.parametrize("name", ["inner_node", "tread_node", "component", "strain_component"])
def test_coordinates_are_in_the_schema(name):
    assert schema.FIXED_VARIABLES[name].dims == (name,)


def test_status_flags_follow_cf():
    attrs = schema.STATUS.attrs
    assert attrs["flag_values"] == [0, 1, 2]
    assert attrs["flag_meanings"].split() == ["pending", "done", "failed"]


def test_worker_writes_status_last():
    assert schema.WORKER_VARIABLES[-1].name == "status"


@pytest.mark.parametrize("n", [0, 1, schema.MAX_ERROR_CHARS, schema.MAX_ERROR_CHARS + 1, 10**5])
def test_truncate_error_keeps_head_and_tail_within_limit(n):
    reason = "H" + "m" * max(n - 2, 0) + "T" if n >= 2 else "x" * n
    cut = schema.truncate_error(reason)
    assert len(cut) <= schema.MAX_ERROR_CHARS
    if n <= schema.MAX_ERROR_CHARS:
        assert cut == reason
    else:
        assert cut.startswith("H") and cut.endswith("T") and f"{n} characters" in cut
