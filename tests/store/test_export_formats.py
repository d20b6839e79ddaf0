"""Data out in the formats people use: CSV with units and compact numbers, NetCDF that
xarray opens with units and the run's metadata, Parquet that pandas opens with units,
and ``Store.load(id).to_pandas()/.to_xarray()`` for notebooks."""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
import xarray as xr

from daq.csv_to_store import import_csv
from daq.export_formats import FORMATS, write_export
from daq.run_data import load_run_data
from daq.sample import Quality, Sample
from daq.store import LoadedRun, Store, export_run_csv, export_run_json
from estimation.axis.tow_estimate import estimate
from estimation.data.csv_import import without_comments
from tests.estimation.synth import tow_set
from tests.store.helpers import BENBAM_TOML, benbam_tow_run

BENBAM = BENBAM_TOML
CHANNELS = ["tow_position", "load_cell", "tow_release", "heartbeat"]
#: Host monotonic time of the first sample: not a round number, as on a real host.
T0_MONO = 81234.567891234
T0_WALL = 1_795_000_000.123456
RELEASE_AFTER_S = 0.35


def recorded_tow(store: Store, count: int = 12, *, release: bool = True) -> str:
    """A completed tow on BENBAM's rig file: encoder counts of 10 µm (stored as doubles
    like 0.28500000000000003), a load cell in mN counts (24.016000000000002) with one
    unread sample, the release coil, an unwrapped heartbeat and (optionally) the
    recorded release event."""
    run_id = benbam_tow_run(store, CHANNELS)
    samples = []
    for i in range(count):
        t = i * 0.1
        samples.append(
            Sample(
                seq=i,
                t_mono=T0_MONO + t,
                t_wall=T0_WALL + t,
                channels={
                    "tow_position": (i * 28500) * 1e-5,  # in 10 µm counts: 0.28500000000000003
                    "load_cell": math.nan if i == 2 else (24016 + 3 * i) * 1e-3,  # mN counts
                    "tow_release": float(t >= RELEASE_AFTER_S),
                    "heartbeat": 65530.0 + i,  # unwrapped past 65535
                },
                quality=Quality.STALE if i == 2 else Quality.OK,
            )
        )
    store.add_samples(run_id, samples)
    if release:
        store.add_event(
            run_id,
            "operator",
            "tow_release set: brake released",
            {"action": "release", "t_mono": T0_MONO + RELEASE_AFTER_S, "t_half_width": 0.001},
        )
    store.finish_run(run_id, "completed")
    return run_id


def data_lines(text: str) -> list[str]:
    return [line for line in text.splitlines() if not line.startswith("#")]


def comments(text: str) -> dict[str, str]:
    found = {}
    for line in text.splitlines():
        if line.startswith("# ") and ": " in line:
            key, value = line[2:].split(": ", 1)
            found[key] = value
    return found


# ---- CSV ------------------------------------------------------------------------------
def test_csv_states_units_and_the_run_in_its_header_comments(store: Store) -> None:
    run_id = recorded_tow(store)
    out = io.StringIO()
    assert export_run_csv(store, run_id, out) == 12
    text = out.getvalue()
    header = comments(text)
    assert header["units"] == (
        "t=s, seq=1, t_mono=s, t_wall=s since 1970-01-01 00:00:00 UTC, quality=1, "
        "tow_position=m, load_cell=N, tow_release=1, heartbeat=count"
    )
    assert (header["run_id"], header["kind"], header["vehicle"]) == (run_id, "tow", "BENBAM")
    assert header["rig_name"] == "BENBAM tow tank" and header["drive"] == "weight"
    assert json.loads(header["parameters"])["force_n"] == 24.5
    assert header["release_t_s"] == "0.35"
    assert json.loads(header["events"])[0]["data"]["action"] == "release"
    assert "rig_toml" not in header  # the rig file's text stays out of a CSV
    assert data_lines(text)[0] == "t,seq,t_mono,t_wall,quality," + ",".join(CHANNELS)


def test_csv_numbers_are_the_shortest_text_at_the_channels_resolution(store: Store) -> None:
    run_id = recorded_tow(store)
    stored = store.samples(run_id)
    assert repr(float(stored.channels["tow_position"][1])) == "0.28500000000000003"
    assert repr(float(stored.channels["load_cell"][0])) == "24.016000000000002"
    out = io.StringIO()
    export_run_csv(store, run_id, out)
    rows = list(csv.DictReader(data_lines(out.getvalue())))
    assert [r["tow_position"] for r in rows[:4]] == ["0.0", "0.285", "0.57", "0.855"]
    assert [r["load_cell"] for r in rows[:4]] == ["24.016", "24.019", "", "24.025"]
    assert [r["tow_release"] for r in rows[2:5]] == ["0", "0", "1"]
    assert rows[-1]["heartbeat"] == "65541" and rows[2]["quality"] == "1"
    assert [r["t"] for r in rows[:3]] == ["0.0", "0.1", "0.2"]
    assert rows[0]["t_mono"] == "81234.567891" and rows[0]["t_wall"] == "1795000000.123456"
    for row in rows:  # every value equals the stored one at its resolution
        i = int(row["seq"])
        assert float(row["tow_position"]) == pytest.approx(
            stored.channels["tow_position"][i], abs=1e-12
        )
        assert float(row["t_mono"]) == pytest.approx(stored.t_mono[i], abs=5e-7)


def test_csv_export_reimports_and_exports_the_same_text(store: Store, tmp_path) -> None:
    run_id = recorded_tow(store)
    first = io.StringIO()
    export_run_csv(store, run_id, first)
    path = tmp_path / "run.csv"
    path.write_text(first.getvalue())
    again = import_csv(
        store, path, kind="tow", parameters={"force_n": 24.5}, rig_toml=BENBAM, vehicle="BENBAM"
    )
    original, copy = store.samples(run_id), store.samples(again)
    np.testing.assert_array_equal(copy.seq, original.seq)
    np.testing.assert_array_equal(copy.quality, original.quality)
    np.testing.assert_allclose(copy.t_mono, original.t_mono, rtol=0, atol=5e-7)
    for name in CHANNELS:
        np.testing.assert_allclose(copy.channels[name], original.channels[name], atol=1e-12)
    second = io.StringIO()
    export_run_csv(store, again, second)
    assert data_lines(second.getvalue()) == data_lines(first.getvalue())
    assert comments(second.getvalue())["units"] == comments(first.getvalue())["units"]


def test_an_imported_run_without_a_rig_file_knows_only_its_position_unit(
    store: Store, tmp_path
) -> None:
    path = tmp_path / "lab.csv"
    path.write_text("# from the lab's logger\nt,position,strain\n0,0.1,5\n0.1,0.2,6\n")
    run_id = import_csv(store, path, kind="tow", parameters={"force_n": 1.0})
    ds = store.load(run_id).to_xarray()
    assert ds["tow_position"].attrs["units"] == "m"
    assert ds["strain"].attrs["units"] == ""
    assert "unit unknown" in ds["strain"].attrs["long_name"]
    assert "t_from_release" not in ds.coords  # no release recorded or given


def test_json_export_carries_units_and_compact_numbers(store: Store) -> None:
    run_id = recorded_tow(store)
    out = io.StringIO()
    export_run_json(store, run_id, out)
    assert "0.28500000000000003" not in out.getvalue()
    document = json.loads(out.getvalue())
    assert document["units"]["tow_position"] == "m"
    assert document["samples"]["channels"]["tow_position"][1] == 0.285
    assert document["samples"]["channels"]["load_cell"][2] is None


# ---- NetCDF, Parquet, pandas, xarray ---------------------------------------------------
def test_netcdf_opens_with_xarray_with_units_coordinates_and_run_metadata(
    store: Store, tmp_path
) -> None:
    run_id = recorded_tow(store)
    path = write_export(store, run_id, "netcdf", tmp_path / "run.nc")
    stored = store.samples(run_id)
    with xr.open_dataset(path) as ds:
        assert ds["tow_position"].attrs == {"units": "m", "long_name": "tow position"}
        assert ds["load_cell"].attrs["units"] == "N"
        assert ds["tow_release"].attrs["units"] == "1"
        assert ds["t"].attrs["units"] == "s" and ds.sizes["t"] == 12
        np.testing.assert_array_equal(ds["tow_position"].values, stored.channels["tow_position"])
        assert np.isnan(ds["load_cell"].values[2])
        np.testing.assert_allclose(ds["t"].values, stored.t, atol=1e-12)
        np.testing.assert_allclose(ds["t_from_release"].values, stored.t - 0.35, atol=1e-9)
        assert ds["t_from_release"].attrs["units"] == "s"
        wall = ds["time"].values.astype("datetime64[us]").astype("int64") / 1e6
        np.testing.assert_allclose(wall, stored.t_wall, rtol=0, atol=1e-6)
        assert ds["seq"].dtype == np.int64 and int(ds["quality"][2]) == int(Quality.STALE)
        attrs = ds.attrs
        assert (attrs["run_id"], attrs["kind"], attrs["vehicle"]) == (run_id, "tow", "BENBAM")
        assert attrs["Conventions"].startswith("CF-") and attrs["drive"] == "weight"
        assert attrs["rig_name"] == "BENBAM tow tank" and attrs["rig_toml"] == BENBAM
        assert json.loads(attrs["parameters"]) == {
            "force_n": 24.5,
            "drive": "weight",
            "hung_mass_kg": 2.5,
        }
        assert json.loads(attrs["events"])[0]["message"] == "tow_release set: brake released"
        assert attrs["started_at"] == store.get_run(run_id).started_at.isoformat()
        assert attrs["release_t_s"] == pytest.approx(0.35)


def test_parquet_opens_with_pandas_with_units(store: Store, tmp_path) -> None:
    run_id = recorded_tow(store)
    path = write_export(store, run_id, "parquet", tmp_path / "run.parquet")
    frame = pd.read_parquet(path)
    stored = store.samples(run_id)
    assert frame.index.name == "t" and len(frame) == 12
    np.testing.assert_array_equal(frame["tow_position"].to_numpy(), stored.channels["tow_position"])
    assert frame.attrs["units"]["tow_position"] == "m"
    assert frame.attrs["units"]["load_cell"] == "N"
    assert frame.attrs["run_id"] == run_id and frame.attrs["vehicle"] == "BENBAM"
    schema = pq.read_schema(path)  # for arrow readers that know nothing of pandas
    assert schema.field("tow_position").metadata[b"units"] == b"m"
    assert schema.field("t_from_release").metadata[b"units"] == b"s"


def test_to_pandas_and_to_xarray_for_a_notebook(store: Store) -> None:
    run_id = recorded_tow(store, release=False)
    run = store.load(run_id[:8])
    frame = run.to_pandas()
    assert list(frame.columns) == ["seq", "t_mono", "t_wall", "quality", *CHANNELS]
    assert frame.attrs["units"]["t"] == "s"
    dataset = run.to_xarray()
    assert set(dataset.data_vars) == {"seq", "t_mono", "quality", *CHANNELS}
    assert "t_from_release" not in dataset.coords  # no release event
    assert float(dataset["tow_position"].sel(t=0.3, method="nearest")) == pytest.approx(0.855)


def test_the_runs_metadata_becomes_global_attributes(store: Store, tmp_path) -> None:
    run = store.load(recorded_tow(store))
    metadata = {
        "operator": "A. Lab",
        "water_temperature_c": 18.5,
        "tags": ["calm", "series 3"],
        "kind": "clashes with the run's kind",
    }
    with_metadata = LoadedRun(
        replace(run.info, metadata=metadata), run.samples, run.events, run.results
    )
    path = with_metadata.to_netcdf(tmp_path / "run.nc")
    with xr.open_dataset(path) as ds:
        assert ds.attrs["operator"] == "A. Lab"
        assert ds.attrs["water_temperature_c"] == 18.5
        assert json.loads(ds.attrs["tags"]) == ["calm", "series 3"]
        assert ds.attrs["kind"] == "tow"
        assert ds.attrs["metadata_kind"] == "clashes with the run's kind"
    frame = pd.read_parquet(with_metadata.to_parquet(tmp_path / "run.parquet"))
    assert frame.attrs["operator"] == "A. Lab"


def test_every_format_writes_a_file_and_an_unknown_one_is_refused(store: Store, tmp_path) -> None:
    run_id = recorded_tow(store)
    for name, spec in FORMATS.items():
        path = write_export(store, run_id, name, tmp_path / f"run{spec.suffix}")
        assert path.stat().st_size > 0
    with pytest.raises(ValueError, match="format: 'xlsx' is not allowed; use one of csv"):
        write_export(store, run_id, "xlsx", tmp_path / "run.xlsx")


# ---- export → import → estimate ---------------------------------------------------------
def _store_synthetic_tow(store: Store, data) -> str:
    """A synthetic weight-driven tow (true rig physics, 10 µm encoder) stored as recorded:
    host clock offset, the release coil, no events (the window comes from the coil)."""
    run_id = benbam_tow_run(
        store,
        ["tow_position", "tow_release"],
        {"force_n": float(data.drive), "hung_mass_kg": data.hung_mass_kg},
    )
    counts = np.round(data.position / 1e-5)
    store.add_samples(
        run_id,
        [
            Sample(
                seq=i,
                t_mono=T0_MONO + t,
                t_wall=T0_WALL + t,
                channels={
                    "tow_position": float(c) * 1e-5,
                    "tow_release": float(t >= data.t_release),
                },
            )
            for i, (t, c) in enumerate(zip(data.t, counts, strict=True))
        ],
    )
    store.finish_run(run_id, "completed")
    return run_id


def test_export_import_estimate_gives_the_same_coefficients(store: Store, tmp_path) -> None:
    originals, copies = [], []
    for data in tow_set(seed=3, quantum=1e-5, duration_s=8.0)[1:]:
        run_id = _store_synthetic_tow(store, data)
        path = tmp_path / f"{run_id}.csv"
        with open(path, "w", newline="") as f:
            export_run_csv(store, run_id, f)
        assert "0000000" not in "".join(data_lines(path.read_text()))  # no float noise
        params = {"force_n": float(data.drive), "hung_mass_kg": data.hung_mass_kg}
        copies.append(import_csv(store, path, kind="tow", parameters=params, rig_toml=BENBAM))
        originals.append(run_id)

    def coefficients(run_ids: list[str]) -> dict[str, float]:
        runs = [load_run_data(store, r) for r in run_ids]
        result = estimate(runs, search_effects=False, n_bootstrap=0)
        return {name: c.value for name, c in result.coefficients.items()}

    before, after = coefficients(originals), coefficients(copies)
    assert set(before) == {"inertia", "linear_damping", "quadratic_damping"}
    for name, value in before.items():
        assert after[name] == pytest.approx(value, rel=1e-6), name


def test_comment_lines_are_skipped_and_line_numbers_kept(store: Store, tmp_path) -> None:
    path = tmp_path / "bad.csv"
    path.write_text("# units: t=s\n# another\nt,position\n0,0\n0.1,abc\n")
    with pytest.raises(ValueError, match="line 5, column 'tow_position': 'abc' is not a number"):
        import_csv(store, path, kind="tow", parameters={"force_n": 1.0})
    rows = list(csv.reader(without_comments(io.StringIO("# a\nt,x\n1,2\n"))))
    assert rows == [["t", "x"], ["1", "2"]]
