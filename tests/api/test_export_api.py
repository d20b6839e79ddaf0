"""GET /api/runs/{id}/export?format=…: CSV, JSON, NetCDF, Parquet and MATLAB with their
media types, files that xarray, pandas and scipy open with units, 422 naming ``format``
otherwise; the route, its OpenAPI enum, ``GET /api/export-formats`` and ``rig export
--format`` list every format of ``daq.export_formats.FORMATS``."""

from __future__ import annotations

import io
import json

import click
import pandas as pd
import pytest
import xarray as xr
from scipy.io import loadmat

from api.cli.export import export as export_command
from daq.export_formats import FORMATS
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
        ("mat", "application/x-matlab-data", ".mat"),
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
    assert "'csv', 'json', 'netcdf', 'parquet' or 'mat'" in problem["allowed"]
    assert r.json()["detail"].startswith("format: 'xlsx' is not allowed")


def test_mat_download_opens_with_scipy_with_units_and_metadata(client, run_id, tmp_path):
    path = tmp_path / "run.mat"
    path.write_bytes(_export(client, run_id, "mat").content)
    mat = loadmat(path, simplify_cells=True)
    assert mat["units"]["tow_position"] == "m"
    assert mat["data"]["tow_position"][1] == pytest.approx(0.285)
    assert mat["metadata"]["run_id"] == run_id and len(mat["data"]["load_cell"]) == 12


def test_every_format_of_the_table_is_listed_by_the_api_and_the_cli(client):
    r = client.get("/api/export-formats", headers=AUTH)
    assert r.status_code == 200
    assert r.json() == [f.public() for f in FORMATS.values()]
    assert client.get("/api/export-formats").status_code == 401

    operation = client.get("/openapi.json").json()["paths"]["/api/runs/{run_id}/export"]["get"]
    query = next(p for p in operation["parameters"] if p["name"] == "format")
    assert query["schema"]["enum"] == list(FORMATS)
    assert set(operation["responses"]["200"]["content"]) == {f.media_type for f in FORMATS.values()}
    for spec in FORMATS.values():
        assert f"{spec.name}: {spec.help}" in query["description"]

    option = next(p for p in export_command.params if p.name == "format")
    assert isinstance(option.type, click.Choice) and list(option.type.choices) == list(FORMATS)
    for spec in FORMATS.values():
        assert f"{spec.name}: {spec.help}" in (option.help or "")
