"""The fsspec code path, against an S3-compatible server on 127.0.0.1 (moto's server).

Skips (with the reason) when s3fs or moto[server] is not installed: ``pip install
-e '.[s3]'``.
"""

from __future__ import annotations

import pickle
import uuid

import numpy as np
import pytest
from store_helpers import GROUP, make_attrs, make_info, make_mesh, make_params, make_result

import storage
from storage import NotAStoreError

s3fs = pytest.importorskip("s3fs", reason="s3fs is not installed (pip install -e '.[s3]')")


@pytest.fixture
def bucket(s3_endpoint, monkeypatch):
    """A fresh bucket; credentials and endpoint come from the environment, as on a farm."""
    for key, value in {"AWS_ACCESS_KEY_ID": "testing", "AWS_SECRET_ACCESS_KEY": "testing",
                       "AWS_DEFAULT_REGION": "us-east-1", "AWS_ENDPOINT_URL": s3_endpoint}.items():
        monkeypatch.setenv(key, value)
    name = f"farm-{uuid.uuid4().hex[:12]}"
    fs = s3fs.S3FileSystem(client_kwargs={"endpoint_url": s3_endpoint}, skip_instance_cache=True)
    fs.mkdir(name)
    return name


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_a_store_url_goes_through_fsspec(bucket):
    url = f"s3://{bucket}/farm.zarr"
    mesh = make_mesh()
    storage.create_group(url, GROUP, mesh, make_attrs())
    ids = ["e0", "e1", "e2"]
    storage.reserve(url, GROUP, ids, make_params(ids))
    storage.write_experiment(url, GROUP, "e1", make_result("e1", mesh.n_inner, mesh.n_tread),
                             make_info("e1"))
    storage.write_failure(url, GROUP, "e2", "boom", {})
    assert storage.list_groups(url) == [GROUP]
    assert storage.statuses(url, GROUP) == {"e0": 0, "e1": 1, "e2": 2}
    ds = storage.done(storage.open_dataset(url, GROUP))
    assert ds["experiment"].values.tolist() == ["e1"]
    want = make_result("e1", mesh.n_inner, mesh.n_tread)["reaction_force"]
    np.testing.assert_array_equal(ds["reaction_force"].values[0], want)
    assert ds["reaction_force"].attrs["units"] == "N"


def test_storage_options_reach_fsspec(bucket, s3_endpoint, monkeypatch):
    monkeypatch.delenv("AWS_ENDPOINT_URL")
    store = storage.open_store(
        f"s3://{bucket}/opts.zarr",
        storage_options={"key": "testing", "secret": "testing",
                         "client_kwargs": {"endpoint_url": s3_endpoint}},
    )
    mesh = make_mesh()
    storage.create_group(store, GROUP, mesh, make_attrs())
    storage.reserve(store, GROUP, ["e0", "e1"], make_params(["e0", "e1"]))
    # A Dask worker gets its own unpickled copy of the store, options included.
    copy = pickle.loads(pickle.dumps(store))
    storage.write_experiment(copy, GROUP, "e1", make_result("e1", mesh.n_inner, mesh.n_tread),
                             make_info("e1"))
    assert storage.status_counts(store, GROUP) == {"pending": 1, "done": 1, "failed": 0}


def test_a_missing_store_url_is_not_a_store(bucket):
    with pytest.raises(NotAStoreError, match=f"no Zarr v3 store at s3://{bucket}/nothing"):
        storage.open_dataset(f"s3://{bucket}/nothing.zarr", GROUP)
