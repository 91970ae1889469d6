"""S3 end to end: a sweep, its status and an analysis on an object store (moto's server).

The endpoint is given in the study file (``[study.storage_options]``), never in the
environment: the client's storage calls and the workers' (which get the store pickled
into each task, options included) must all reach it from there. Credentials come from
the environment, as on a farm. Skips without s3fs or moto[server] (``pip install -e
'.[s3]'``).
"""

from __future__ import annotations

import json
import pickle
import uuid

import pytest
from conftest import study_text

import storage
from jobs.errors import StudyError
from jobs.study import load_study, parse_study

s3fs = pytest.importorskip("s3fs", reason="s3fs is not installed (pip install -e '.[s3]')")


@pytest.fixture
def bucket(s3_endpoint, monkeypatch):
    """A fresh bucket; credentials in the environment, no endpoint there."""
    for key, value in {"AWS_ACCESS_KEY_ID": "testing", "AWS_SECRET_ACCESS_KEY": "testing",
                       "AWS_DEFAULT_REGION": "us-east-1"}.items():
        monkeypatch.setenv(key, value)
    for key in ("AWS_ENDPOINT_URL", "AWS_ENDPOINT_URL_S3", "AWS_PROFILE"):
        monkeypatch.delenv(key, raising=False)
    name = f"farm-{uuid.uuid4().hex[:12]}"
    # skip_instance_cache: fsspec's cached filesystem of another module's (stopped) server
    fs = s3fs.S3FileSystem(endpoint_url=s3_endpoint, skip_instance_cache=True)
    fs.mkdir(name)
    return name


def s3_study(url: str, endpoint: str, deflections: str = "[10, 20, 30]") -> str:
    options = f'[study.storage_options]\nendpoint_url = "{endpoint}"\n\n'
    return study_text(url, deflections=deflections).replace("[model]\n", options + "[model]\n",
                                                           1)


def test_storage_options_open_the_url_with_them():
    study = parse_study(s3_study("s3://b/farm.zarr", "http://127.0.0.1:9"))
    assert study.location == "s3://b/farm.zarr"
    assert study.storage_options == {"endpoint_url": "http://127.0.0.1:9"}
    # what a Dask worker gets: a copy that still knows the endpoint
    copy = pickle.loads(pickle.dumps(study.store))
    assert copy.fs.storage_options["endpoint_url"] == "http://127.0.0.1:9"
    assert storage.open_store(study.store) is study.store


@pytest.mark.parametrize(("edit", "message"), [
    (("endpoint_url", "secret"), "study.storage_options.secret: credentials do not belong"),
    (("endpoint_url", "KEY"), "study.storage_options.KEY: credentials do not belong"),
    (('"http://127.0.0.1:9"', "[1, 2]"), "endpoint_url: must be a string, number, boolean"),
    (("s3://b/farm.zarr", "/tmp/farm.zarr"), "are for object-store URLs"),
    (('endpoint_url = "http://127.0.0.1:9"', "a.b.c.d = 1"), "nests deeper than 3"),
])
def test_bad_storage_options_are_one_line(edit, message):
    text = s3_study("s3://b/farm.zarr", "http://127.0.0.1:9").replace(*edit)
    with pytest.raises(StudyError, match=message):
        parse_study(text)


def test_a_study_without_options_keeps_its_store_text(tmp_path):
    study = parse_study(study_text(tmp_path / "s.zarr"))
    assert study.store == study.location == str(tmp_path / "s.zarr")
    assert study.storage_options is None


@pytest.mark.ccx
@pytest.mark.e2e  # end to end: run by .ci/run through `scripts/test.sh --e2e`
def test_sweep_status_and_pca_on_s3(bucket, s3_endpoint, tmp_path, capsys):
    from analysis import data
    from analysis.studies import crosscov
    from jobs.sweep import run_sweep
    from tyre_farm_cli import main

    url = f"s3://{bucket}/farm.zarr"
    path = tmp_path / "study.toml"
    path.write_text(s3_study(url, s3_endpoint))
    study = load_study(path)
    report = run_sweep(study, workers=2)
    assert report.ok, report.failed
    assert len(report.done) == 3

    # the store is on the server, not on a local path named like the URL
    fs = s3fs.S3FileSystem(endpoint_url=s3_endpoint, skip_instance_cache=True)
    assert fs.exists(f"{bucket}/farm.zarr/zarr.json")

    capsys.readouterr()
    try:
        main(["sweep", "status", str(path), "--json"])
    except SystemExit as e:
        assert e.code in (0, None)
    status = json.loads(capsys.readouterr().out)
    [group] = status["groups"]
    assert group["group"] == study.group_name
    assert group["counts"] == {"pending": 0, "done": 3, "failed": 0}
    assert status["store"] == url  # the URL the user gave, not the store object

    # the bare URL with the endpoint on the command line: the same counts
    try:
        main(["sweep", "status", url, "--storage-option", f"endpoint_url={s3_endpoint}",
              "--json"])
    except SystemExit as e:
        assert e.code in (0, None)
    [group] = json.loads(capsys.readouterr().out)["groups"]
    assert group["counts"] == {"pending": 0, "done": 3, "failed": 0}

    ds = data.load(study.store, study.group_name)
    assert sorted(ds["deflection"].values.tolist()) == [10.0, 20.0, 30.0]
    out = crosscov.run(ds, tmp_path / "pca").out
    assert (out / "singular_values.csv").stat().st_size > 0
    assert (out / "summary.md").exists()
