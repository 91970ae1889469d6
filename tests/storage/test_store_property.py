"""Property: any valid sequence of reserve / write / fail reads back what was written."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from store_helpers import GROUP, make_attrs, make_info, make_mesh, make_params, make_result
from zarr.storage import MemoryStore

import storage
from storage.schema import RESULT_NAMES

N_INNER, N_TREAD = 4, 2
POOL = [f"id{i}" for i in range(6)]

ops = st.lists(
    st.one_of(
        st.tuples(st.just("reserve"), st.lists(st.sampled_from(POOL), min_size=1, max_size=4,
                                               unique=True)),
        st.tuples(st.just("write"), st.sampled_from(POOL), st.integers(0, 2)),
        st.tuples(st.just("fail"), st.sampled_from(POOL),
                  st.text(min_size=1, max_size=40).filter(str.strip)),
    ),
    max_size=12,
)


def _apply(store, op, index: dict, state: dict) -> None:
    kind, eid = op[0], op[1]
    if kind == "reserve":
        got = storage.reserve(store, GROUP, eid, make_params(eid))
        for e in eid:
            index.setdefault(e, len(index))
            state.setdefault(e, ("pending", None))
        assert got == {e: index[e] for e in eid}
    elif eid not in index:
        with pytest.raises(storage.NotReservedError):
            _write_or_fail(store, op)
    elif kind == "fail" and state[eid][0] == "done":
        with pytest.raises(storage.AlreadyDoneError):
            _write_or_fail(store, op)
    else:
        _write_or_fail(store, op)
        state[eid] = ("done", op[2]) if kind == "write" else ("failed", op[2])


def _write_or_fail(store, op) -> None:
    kind, eid, arg = op
    if kind == "write":
        key = f"{eid}/{arg}"  # a re-write may bring other values
        storage.write_experiment(store, GROUP, eid, make_result(key, N_INNER, N_TREAD),
                                 make_info(key))
    else:
        storage.write_failure(store, GROUP, eid, arg, {"ccx_runs": 2})


@settings(max_examples=30, deadline=None)
@given(ops)
def test_any_sequence_reads_back_what_was_written(sequence):
    store = MemoryStore()
    storage.create_group(store, GROUP, make_mesh(N_INNER, N_TREAD), make_attrs())
    index: dict[str, int] = {}
    state: dict[str, tuple[str, object]] = {}
    for op in sequence:
        _apply(store, op, index, state)
    codes = {"pending": storage.PENDING, "done": storage.DONE, "failed": storage.FAILED}
    assert storage.statuses(store, GROUP) == {e: codes[s] for e, (s, _) in state.items()}
    if not index:
        return
    ds = storage.open_dataset(store, GROUP).load()
    assert ds["experiment"].values.tolist() == sorted(index, key=index.get)
    for e, i in index.items():
        kind, arg = state[e]
        assert ds["error"].values[i] == (arg if kind == "failed" else "")
        assert ds["deflection"].values[i] == make_params([e])["deflection"][0]
        want = make_result(f"{e}/{arg}", N_INNER, N_TREAD) if kind == "done" else None
        for name in RESULT_NAMES:
            got = ds[name].values[i]
            assert np.array_equal(got, want[name]) if want else np.isnan(got).all(), (e, name)
        runs = make_info(f"{e}/{arg}")["ccx_runs"] if kind == "done" else (
            2 if kind == "failed" else -1)
        assert ds["ccx_runs"].values[i] == runs
