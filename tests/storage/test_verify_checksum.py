"""Per-experiment checksums: what they cover, what they ignore, and the block check."""

from __future__ import annotations

import numpy as np
import pytest
from store_helpers import GROUP, make_attrs, make_info, make_mesh, make_result

import storage
from storage import checksum as cs
from storage.schema import CHECKED_NAMES, DONE, FAILED
from storage.verify import verify

N_INNER, N_TREAD = 12, 5
PARAMS = {"deflection": 17.3, "pressure": 0.2}


def _values(e: str = "e1") -> dict[str, np.ndarray]:
    """One done experiment's slices of every checked variable, as a worker writes them."""
    info = make_info(e)
    out = {k: np.asarray(v, dtype=np.float64) for k, v in
           make_result(e, N_INNER, N_TREAD).items()}
    out["solve_seconds"] = np.float64(info["solve_seconds"])
    for k in ("increments", "ccx_runs", "contact_nodes"):
        out[k] = np.int32(info[k])
    out["error"] = np.array("", dtype=object)
    return out


BASE = cs.checksum("e1", PARAMS, DONE, _values())


def test_same_inputs_same_checksum_and_format():
    assert cs.checksum("e1", dict(PARAMS), DONE, _values()) == BASE
    label, data = cs.split(BASE)
    assert len(label) == len(data) == 32 and int(label, 16) >= 0


@pytest.mark.parametrize("name", CHECKED_NAMES)
def test_one_changed_value_of_any_variable_changes_the_data_digest(name):
    values = _values()
    a = np.array(values[name], dtype=object if name == "error" else None)
    flat = a.reshape(-1)
    flat[-1] = "x" if name == "error" else flat[-1] + 1
    values[name] = a
    changed = cs.checksum("e1", PARAMS, DONE, values)
    assert cs.split(changed)[0] == cs.split(BASE)[0]  # the label is the same
    assert cs.split(changed)[1] != cs.split(BASE)[1]


def test_one_flipped_bit_changes_the_digest():
    values = _values()
    raw = values["displacement"].copy().view(np.uint64)
    raw[3, 1] ^= np.uint64(1)  # the least significant mantissa bit
    values["displacement"] = raw.view(np.float64)
    assert cs.checksum("e1", PARAMS, DONE, values) != BASE


@pytest.mark.parametrize("change", [
    {"experiment_id": "e2"},
    {"params": {"deflection": 17.3 * (1 + 1e-15), "pressure": 0.2}},
    {"params": {"deflection": 0.2, "pressure": 17.3}},  # swapped values
    {"params": {**PARAMS, "friction": 0.8}},
    {"status": FAILED},
])
def test_id_load_case_and_status_are_covered(change):
    args = {"experiment_id": "e1", "params": PARAMS, "status": DONE, "values": _values(),
            **change}
    assert cs.checksum(**args) != BASE


def test_a_nan_parameter_is_no_parameter():
    """A parameter added to the group later is NaN in older slots: their checksums hold."""
    assert cs.checksum("e1", {**PARAMS, "friction": np.nan}, DONE, _values()) == BASE


def test_every_nan_is_the_same_nan():
    values = _values()
    values["displacement"] = values["displacement"].copy()
    quiet = np.full(3, np.nan)
    odd = np.array([0x7FF8000000000001, 0xFFF8000000000000, 0x7FF0000000000F00],
                   dtype=np.uint64).view(np.float64)
    assert np.isnan(odd).all()
    values["displacement"][0] = quiet
    a = cs.checksum("e1", PARAMS, DONE, values)
    values["displacement"][0] = odd
    assert cs.checksum("e1", PARAMS, DONE, values) == a


def test_dtype_and_byte_order_are_canonical():
    values = _values()
    values["displacement"] = values["displacement"].astype(">f8")
    values["increments"] = np.int64(values["increments"])
    assert cs.checksum("e1", PARAMS, DONE, values) == BASE


@pytest.mark.parametrize("text", ["", "x", "abc:def", "0" * 32 + ":" + "0" * 31,
                                  "g" * 32 + ":" + "0" * 32])
def test_split_refuses_what_is_not_a_checksum(text):
    assert cs.split(text) is None


def _slots(n: int, broken: set[int] = frozenset()) -> tuple[cs.Slots, list[str]]:
    ids = [f"e{i}" for i in range(n)]
    rows = [_values(e) for e in ids]
    sums = [cs.checksum(e, PARAMS, DONE, r) for e, r in zip(ids, rows, strict=True)]
    stacked = {name: np.stack([np.asarray(r[name]) for r in rows]) for name in CHECKED_NAMES}

    def read(name, lo, hi):
        if any(k in broken for k in range(lo, hi)):
            raise RuntimeError("Zstd decompression error: invalid input data")
        return stacked[name][lo:hi]

    sizes = {name: stacked[name].nbytes // n for name in CHECKED_NAMES}
    params = {k: np.full(n, v) for k, v in PARAMS.items()}
    return cs.Slots(ids, np.full(n, DONE), params, sums, read, sizes), ids


def test_check_reads_in_blocks_and_names_undecodable_experiments(monkeypatch):
    monkeypatch.setattr(cs, "BLOCK_BYTES", 1)  # one experiment per block
    slots, _ = _slots(7, broken={2, 5})
    bad = cs.check(slots, range(7))
    assert sorted(bad) == [2, 5]
    assert all("does not decode" in r and "RuntimeError" in r for r in bad.values())


def test_check_of_a_large_block_falls_back_to_single_experiments():
    slots, _ = _slots(9, broken={4})
    assert list(cs.check(slots, range(9))) == [4]


def test_check_labels_only_reads_no_data():
    slots, _ = _slots(3)
    calls = []
    lazy = cs.Slots(slots.ids, slots.status, slots.params, slots.checksums,
                    lambda *a: calls.append(a), slots.sizes)
    assert cs.check(lazy, range(3), data=False) == {}
    assert calls == []


# --- through the store ---------------------------------------------------------------------


@pytest.fixture
def filled(store, group, mesh):
    ids = ["e0", "e1", "e2"]
    storage.reserve(store, group, ids, {"deflection": [10.0, 20.0, 30.0], "pressure": 0.2})
    for e in ids[:2]:
        storage.write_experiment(store, group, e, make_result(e, mesh.n_inner, mesh.n_tread),
                                 make_info(e))
    storage.write_failure(store, group, "e2", "boom", {})
    return store


def test_stored_checksums_verify_in_every_kind_of_store(filled):
    report = verify(filled)
    assert report.ok, report.lines()
    assert (report.groups[0].checked, report.groups[0].ok) == (3, 3)


def test_rewriting_an_experiment_keeps_its_checksum(filled, mesh):
    before = storage.open_dataset(filled, GROUP)["checksum"].values.tolist()
    storage.write_experiment(filled, GROUP, "e1", make_result("e1", mesh.n_inner, mesh.n_tread),
                             make_info("e1"))
    assert storage.open_dataset(filled, GROUP)["checksum"].values.tolist() == before


def test_a_parameter_added_later_keeps_older_checksums(filled, mesh):
    storage.reserve(filled, GROUP, ["f0"], {"deflection": 5.0, "pressure": 0.2,
                                             "friction": 0.8})
    storage.write_experiment(filled, GROUP, "f0", make_result("f0", mesh.n_inner, mesh.n_tread),
                             make_info("f0"))
    assert verify(filled).ok
    done = storage.done(storage.open_dataset(filled, GROUP))
    assert sorted(done["experiment"].values.tolist()) == ["e0", "e1", "f0"]


def test_a_changed_load_case_is_refused_by_name(tmp_path):
    path = tmp_path / "s.zarr"
    storage.create_group(path, GROUP, make_mesh(), make_attrs())
    storage.reserve(path, GROUP, ["e0", "e1"], {"deflection": [10.0, 20.0], "pressure": 0.2})
    for e in ("e0", "e1"):
        storage.write_experiment(path, GROUP, e, make_result(e, 12, 5), make_info(e))
    import zarr

    zarr.open_array(str(path / GROUP / "deflection"), mode="r+")[1] = 25.0  # relabelled
    with pytest.raises(storage.StoreError, match=r"e1 \(its id or load case \(deflection=25"):
        storage.done(storage.open_dataset(path, GROUP))
