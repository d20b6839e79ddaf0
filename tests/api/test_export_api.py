"""GET /api/runs/{id}/export?format=…: CSV, JSON, NetCDF and Parquet with their media
types, files that xarray and pandas open with units, 422 naming ``format`` otherwise."""

from __future__ import annotations

import io
import json

import pandas as pd
import pytest
import xarray as xr

from tests.api.conftest import AUTH
from tests.store.test_export_formats import recorded_tow


@pytest.fixture(scope="module")
def run_id(service, client) -> str:
    """A tow written straight into the service's database (no rig time needed)."""
    return recorded_tow(service.store)


def _export(client, run_id: str, fmt: str):
    r = client.get(f"/api/runs/{run_id[:8]}/export?format={fmt}", headers=AUTH)
    assert r.status_code == 200, r.text
    return r


@pytest.mark.parametrize(
    ("fmt", "media_type", "suffix"),
    [
        ("csv", "text/csv", ".csv"),
        ("json", "application/json", ".json"),
        ("netcdf", "application/x-netcdf", ".nc"),
        ("parquet", "application/vnd.apache.parquet", ".parquet"),
    ],
)
def test_each_format_has_its_media_type_and_file_name(client, run_id, fmt, media_type, suffix):
    r = _export(client, run_id, fmt)
    assert r.headers["content-type"].split(";")[0] == media_type
    assert f'filename="run-{run_id[:8]}{suffix}"' in r.headers["content-disposition"]


def test_netcdf_download_opens_with_xarray_with_units_and_metadata(client, run_id, tmp_path):
    path = tmp_path / "run.nc"
    path.write_bytes(_export(client, run_id, "netcdf").content)
    with xr.open_dataset(path) as ds:
        assert ds["tow_position"].attrs["units"] == "m"
        assert float(ds["tow_position"][1]) == pytest.approx(0.285)
        assert ds.attrs["run_id"] == run_id and ds.attrs["vehicle"] == "BENBAM"
        assert json.loads(ds.attrs["parameters"])["force_n"] == 24.5


def test_parquet_download_opens_with_pandas_with_units(client, run_id):
    frame = pd.read_parquet(io.BytesIO(_export(client, run_id, "parquet").content))
    assert frame.attrs["units"]["load_cell"] == "N" and len(frame) == 12


def test_csv_and_json_downloads_carry_units(client, run_id):
    text = _export(client, run_id, "csv").text
    assert "tow_position=m" in next(line for line in text.splitlines() if "# units:" in line)
    assert ",0.285," in text and "0.28500000000000003" not in text
    assert _export(client, run_id, "json").json()["units"]["load_cell"] == "N"


def test_an_unknown_format_is_422_naming_the_field_and_the_allowed_ones(client, run_id):
    r = client.get(f"/api/runs/{run_id}/export?format=xlsx", headers=AUTH)
    assert r.status_code == 422
    problem = r.json()["errors"][0]
    assert problem["field"] == "format" and problem["value"] == "xlsx"
    assert "'csv', 'json', 'netcdf' or 'parquet'" in problem["allowed"]
    assert r.json()["detail"].startswith("format: 'xlsx' is not allowed")
