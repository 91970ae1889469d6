"""The reproduction report as a reader sees it (issue 25): a findings section computed from
the stages' results, human headers, one missing-value mark, round-off as ~0, Table 5.1 as
one table beside the thesis. Chapter 5 runs on the synthetic thesis-like store (no ccx)."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest

from analysis.report import ch3, ch5, findings, readable, reproduction, table_5_1, thesis
from analysis.report.stage import StageResult


def _validation(fz_200_30: float = 4700.0) -> StageResult:
    """A chapter-3 stage as ch3.validation hands it in (NaN where a curve has no point)."""
    stage = StageResult("validation")
    stage.tables[ch3.FULL_NODAL] = pd.DataFrame(
        {"quantity": ["mean nodal force N", "std nodal force N"], "measured": [250.0, 250.0],
         "thesis": [263.3, 227.4]})
    stage.tables[ch3.FORCE_DEFLECTION] = pd.DataFrame(
        {"deflection mm": [10.0, 30.0], "full 80 kPa: Fz N": [np.nan, 4400.0],
         "reduced: Fz N": [100.0, np.nan]})
    stage.tables[ch3.REFERENCE_POINTS] = pd.DataFrame(
        {"case": ["full 200 kPa, 30 mm"], "measured Fz N": [fz_200_30], "thesis Fz N": [4476.0],
         "difference %": [100 * (fz_200_30 - 4476) / 4476]})
    return stage


def _inverse() -> StageResult:
    """A chapter-4 stage as `farm reproduce` builds it: thesis values as text, "-" if none."""
    stage = StageResult("inverse")
    stage.tables["Nodal force errors"] = pd.DataFrame(
        {"condition": ["noise", "ideal"], "method": ["displacement", "strain"],
         "optimizer": ["least-squares", "nelder-mead"], "std": [3.0, 1.0],
         "std_over_max_force": [0.1, 0.03], "thesis_std": ["2", "-"],
         "thesis_std_over_max_force": ["0.05", "-"]})
    return stage


@pytest.fixture(scope="module")
def dataset(thesis_store, tmp_path_factory):
    return ch5.dataset(thesis_store, "synthetic", tmp_path_factory.mktemp("rep"), quick=True)


@pytest.fixture(scope="module")
def report(dataset, tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    from analysis.render.provenance import Run

    prov = reproduction.provenance(Run("farm reproduce --quick"), solver="CalculiX test",
                                   store="s.zarr", quick=True, meshes="coarse",
                                   materials="table-3.1")
    path = reproduction.write(out, [_validation(), dataset, _inverse()], prov, quick=True)
    return path.read_text()


def _tables(text: str) -> list[list[list[str]]]:
    """Every Markdown table of ``text``: rows of cells, the header first."""
    tables, rows = [], []
    for line in [*text.splitlines(), ""]:
        if line.startswith("|"):
            if not set(line) <= set("|-"):
                rows.append([c.strip() for c in line.strip("|").split("|")])
        elif rows:
            tables.append(rows)
            rows = []
    return tables


def _section(text: str, heading: str) -> str:
    return text.split(heading, 1)[1].split("\n## ", 1)[0]


def test_no_table_prints_nan_or_a_dash_for_a_missing_value(report):
    cells = [c for t in _tables(report) for row in t[1:] for c in row]
    assert not [c for c in cells if c.lower() in {"nan", "-", "", "none"}]
    assert readable.MISSING in cells  # the force-deflection gaps, the thesis' absent std


def test_no_header_is_snake_case(report):
    headers = [c for t in _tables(report) for c in t[0]]
    assert "thesis cumulative %" in headers
    assert not [h for h in headers if "_" in h]


def test_round_off_prints_as_about_zero_with_the_threshold_stated(report):
    table = _section(report, "(Table 5.1)")
    assert "~0" in table  # the symmetric model's moments, ~1e-14 N m
    assert not re.search(r"e-(1\d|0[5-9])\b", table)
    assert f"{readable.ROUND_OFF:g}" in report.split("## Findings")[0]


def test_table_5_1_is_one_table_with_the_thesis_values_in_it(report):
    [table] = _tables(_section(report, "(Table 5.1)"))
    assert len(table[0]) <= 10
    assert "thesis ± Fz N" in table[0]
    cases = [row[0] for row in table[1:]]
    assert cases[0] == "reference (virtual experiment)"
    assert "PLSR from displacement + noise σ = 1 mm" in cases
    noisy = table[1 + cases.index("PLSR from displacement + noise σ = 1 mm")]
    assert noisy[table[0].index("thesis ± Fz N")] == "133.1"
    # issue 25: noisy training sits beside the clean ±, on the same row, not as new rows
    assert len(cases) == len(set(cases)) == 5
    both = noisy[table[0].index("± Fz N")], noisy[table[0].index(table_5_1.NOISY_TRAINING)]
    assert readable.MISSING not in both and both[0] != both[1]
    free = table[1 + cases.index("PLSR from displacement, noise-free")]
    assert free[table[0].index(table_5_1.NOISY_TRAINING)] == readable.MISSING


def test_findings_come_first_and_hold_every_chapters_headline(report):
    assert report.index("## Findings") < report.index("## Provenance")
    # the run's rows, as every `farm analyse` writes them (analysis/render/provenance.py)
    assert "farm reproduce --quick" in _section(report, "## Provenance")
    assert "commit" in _section(report, "## Provenance")
    [table] = _tables(_section(report, "## Findings"))
    assert table[0] == findings.COLUMNS
    assert {row[0] for row in table[1:]} == {"3", "4", "5"}


def test_findings_numbers_come_from_the_results(dataset):
    table = findings.findings([_validation(4476.0 * 1.05), dataset, _inverse()])
    row = table[table["quantity"] == "Fz N, full 200 kPa, 30 mm"].iloc[0]
    assert (row["this run"], row["thesis"]) == (4476.0 * 1.05, 4476.0)
    assert row["difference %"] == pytest.approx(5.0)
    moved = findings.findings([_validation(4000.0)])
    assert moved.iloc[0]["this run"] == 4000.0  # not a number written into the report
    std = table[table["quantity"].str.startswith("std of the nodal force errors")]
    assert list(std["this run"]) == [3.0] and list(std["thesis"]) == [2.0]  # none for "-"
    nodal = table[table["quantity"].str.startswith("mean nodal force N")].iloc[0]
    assert nodal["thesis"] == thesis.FULL_30_80_NODAL["mean nodal force N"]
    variance = dataset.tables["plsr/thesis_comparison"]
    pcr = variance[(variance["method"] == "pcr") & (variance["mode"] == 3)].iloc[0]
    row = table[table["quantity"].str.startswith("PCR")].iloc[0]
    assert (row["this run"], row["thesis"]) == (pcr["measured_cum_pct"], 91.0)


def test_a_report_without_results_has_no_findings(tmp_path):
    prov = pd.DataFrame({"item": ["solver"], "value": ["test"]})
    text = reproduction.write(tmp_path, [StageResult("validation")], prov, quick=True)
    assert "## Findings" not in text.read_text()


@pytest.mark.parametrize(("value", "shown"), [
    (np.nan, "n/a"), (None, "n/a"), ("-", "n/a"), ("", "n/a"), ("0.01 (-)", "0.01 (n/a)"),
    (9.8e-14, "~0"), (-3e-12, "~0"), (0.0, "0"), (0.036, "0.036"), (4475.7, "4476"),
    (True, "yes"), (np.int64(14), "14")])
def test_cells(value, shown):
    assert readable.cell(value, scale=4475.7) == shown


def test_a_small_value_in_a_table_of_small_values_is_no_round_off():
    text = readable.table(pd.DataFrame({"rmse": [1e-12, 2e-12]}))
    assert "~0" not in text and "1e-12" in text


def test_headers_gain_words_and_units():
    assert readable.header("Fz_err_pct") == "Fz error %"
    assert readable.header("thesis_Fz") == "thesis Fz N"
    assert readable.header("some_new_column") == "some new column"


def test_table_5_1_matches_the_thesis_row_by_input_set_and_noise():
    totals = pd.DataFrame({
        "case": ["reference", "strain", "strain + N(0, 0.0004)"], "inputs": ["", "strain",
                                                                             "strain"],
        "sigma": [0.0, 0.0, 4e-4], "Fz": [4400.0, 4410.0, 4420.0], "Mx": [1e-14, 0.0, 0.01],
        "My": [0.0, 0.0, 0.02], "Fz_nodal_avg_std": [0.0, 0.0, 150.0]})
    table = table_5_1.beside_thesis(totals)
    assert list(table["thesis Fz N"]) == [4475.70, 4475.70, 4485.20]
    assert table["± Fz N"].isna().tolist() == [True, True, False]
    assert table.loc[2, "thesis ± Fz N"] == 149.28
    assert table.loc[2, "case"] == "PLSR from strain + noise σ = 0.04 % strain (σ = 0.0004)"
    assert table[table_5_1.NOISY_TRAINING].isna().all()  # no training column: all clean


def test_table_5_1_puts_noisy_training_beside_the_clean_row():
    totals = pd.DataFrame({
        "case": ["reference", "strain", "strain + N(0, 0.0004)", "strain + N(0, 0.0004)"],
        "training": ["", "clean", "clean", "noisy"], "inputs": ["", "strain", "strain",
                                                                "strain"],
        "sigma": [0.0, 0.0, 4e-4, 4e-4], "Fz": [4400.0, 4410.0, 4420.0, 4300.0],
        "Mx": [0.0] * 4, "My": [0.0] * 4, "Fz_nodal_avg_std": [0.0, 0.0, 150.0, 90.0]})
    table = table_5_1.beside_thesis(totals)
    assert len(table) == 3  # the noisy-training row is merged, not listed
    assert table.loc[2, "Fz N"] == 4420.0 and table.loc[2, "± Fz N"] == 150.0
    assert table.loc[2, table_5_1.NOISY_TRAINING] == 90.0
    assert table[table_5_1.NOISY_TRAINING].iloc[:2].isna().all()
