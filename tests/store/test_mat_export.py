"""The MATLAB export (``--format mat``): ``scipy.io.loadmat`` reads back every column as an
N×1 double equal to the stored samples, each unit from the rig file, and the run's
metadata; names MATLAB cannot take as field names are made into ones it can."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.io import loadmat

from daq.export_formats import write_export
from daq.store.mat_export import MAX_FIELD, matlab_field
from tests.store.test_export_formats import CHANNELS, recorded_tow


def test_mat_reads_back_with_channels_units_and_metadata_of_the_stored_run(store, tmp_path):
    run_id = recorded_tow(store)
    path = write_export(store, run_id, "mat", tmp_path / "run.mat")
    stored = store.load(run_id)

    raw = loadmat(path)  # as MATLAB sees it: 1×1 structs, N×1 columns
    for name in CHANNELS:
        assert raw["data"][name][0, 0].shape == (12, 1)
    mat = loadmat(path, simplify_cells=True)
    data, units, meta = mat["data"], mat["units"], mat["metadata"]

    # every channel, bit for bit, NaN where the sample was not read
    for name in CHANNELS:
        np.testing.assert_array_equal(data[name], stored.samples.channels[name])
    assert np.isnan(data["load_cell"][2]) and data["tow_position"][1] == 0.28500000000000003
    np.testing.assert_array_equal(data["t"], stored.samples.t)
    np.testing.assert_array_equal(data["t_wall"], stored.samples.t_wall)
    # the release event is known: t_from_release is t shifted by it (0.35 s in)
    np.testing.assert_allclose(data["t_from_release"], stored.samples.t - 0.35, atol=1e-9)

    # units and long names are the rig file's (BENBAM: encoder in m, load cell in N)
    assert units["tow_position"] == "m" and units["load_cell"] == "N" and units["t"] == "s"
    for name, info in stored.columns.items():
        if name in units:
            assert units[name] == info.units
            assert mat["long_names"][name] == info.long_name

    # the run's metadata: the same attributes as the NetCDF export
    assert meta["run_id"] == run_id and meta["kind"] == "tow" and meta["vehicle"] == "BENBAM"
    assert json.loads(meta["parameters"])["force_n"] == 24.5
    assert "brake released" in meta["events"]
    for key, value in stored.attributes().items():
        assert meta[key] == pytest.approx(value) if isinstance(value, float) else meta[key] == value


def test_names_matlab_cannot_take_become_distinct_field_names():
    taken: set[str] = set()
    assert matlab_field("tow_position", taken) == "tow_position"
    assert matlab_field("water-temp °C", taken) == "water_temp__C"
    assert matlab_field("2nd", taken) == "x2nd"
    assert matlab_field("_private", taken) == "x_private"
    assert matlab_field("water_temp__C", taken) == "water_temp__C_2"  # clash after the change
    long = matlab_field("a" * 80, taken)
    assert len(long) == MAX_FIELD and matlab_field("a" * 70, taken) == "a" * 61 + "_2"
