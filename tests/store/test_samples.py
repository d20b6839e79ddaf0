"""Sample ingest and read-back as numpy arrays; (run, seq) is unique."""

from __future__ import annotations

import math

import numpy as np
import pytest

from daq.sample import Quality, Sample
from daq.store import DuplicateSample, Store
from tests.store.helpers import make_samples, new_run


def test_samples_round_trip_as_numpy_columns(store: Store) -> None:
    run_id = new_run(store)
    sent = make_samples(0, 500)
    sent[7] = Sample(7, 100.7, 1.7e9 + 0.7, {"tow_position": 0.07}, Quality.STALE, ("load_cell",))
    assert store.add_samples(run_id, sent[:300]) == 300
    assert store.add_samples(run_id, sent[300:]) == 200
    assert store.add_samples(run_id, []) == 0

    table = store.samples(run_id)
    assert len(table) == 500 and store.sample_count(run_id) == 500
    assert table.seq.dtype == np.int64 and table.t_mono.dtype == np.float64
    np.testing.assert_array_equal(table.seq, np.arange(500))
    np.testing.assert_array_equal(table.t_wall, [s.t_wall for s in sent])
    expected_load = [s.channels.get("load_cell", math.nan) for s in sent]
    np.testing.assert_array_equal(table.channels["load_cell"], expected_load)  # NaN where unread
    assert math.isnan(table.channels["load_cell"][7])
    assert table.quality[7] == Quality.STALE and table.stale[7] == ("load_cell",)
    row = table.sample(7)
    assert (row.seq, row.t_wall, row.quality, row.stale) == (
        7,
        1.7e9 + 0.7,
        Quality.STALE,
        ("load_cell",),
    )
    assert row.channels["tow_position"] == 0.07 and math.isnan(row.channels["load_cell"])
    np.testing.assert_allclose(table.t, np.arange(500) * 0.1, atol=1e-9)

    page = store.samples(run_id, start_seq=450, limit=20)
    np.testing.assert_array_equal(page.seq, np.arange(450, 470))
    assert store.last_sample(run_id) == sent[-1]
    assert store.get_run(run_id).sample_count == 500
    json_columns = table.to_json()
    assert json_columns["channels"]["load_cell"][7] is None


def test_a_run_without_samples_reads_empty(store: Store) -> None:
    run_id = new_run(store)
    table = store.samples(run_id)
    assert len(table) == 0 and table.channels["tow_position"].shape == (0,)
    assert store.last_sample(run_id) is None and store.sample_count(run_id) == 0


def test_seq_is_unique_per_run_and_a_bad_batch_writes_nothing(store: Store) -> None:
    run_id, other = new_run(store), new_run(store)
    store.add_samples(run_id, make_samples(0, 10))
    store.add_samples(other, make_samples(0, 10))  # same seqs in another run are fine
    with pytest.raises(DuplicateSample, match=f"run {run_id}: a sample with seq in 8..12"):
        store.add_samples(run_id, make_samples(8, 5))
    assert store.sample_count(run_id) == 10  # seq 10, 11, 12 of that batch were not written
    assert store.get_run(run_id).sample_count == 10
    repeated_in_batch = make_samples(8, 5) + make_samples(12, 1)
    assert store.add_samples(run_id, repeated_in_batch, skip_existing=True) == 3  # 10, 11, 12
    np.testing.assert_array_equal(store.samples(run_id).seq, np.arange(13))
    assert store.get_run(run_id).sample_count == 13
    with pytest.raises(ValueError, match="sample channel 'load_cell': value 'x' is not a number"):
        store.add_samples(run_id, [Sample(20, 0.0, 0.0, {"tow_position": 1.0, "load_cell": "x"})])
    assert store.integrity_check() == "ok"


def test_other_channels_are_ignored_and_order_is_the_runs(store: Store) -> None:
    run_id = new_run(store, channel_names=["load_cell", "tow_position"])
    store.add_samples(
        run_id, [Sample(0, 0.0, 1.0, {"tow_position": 1.5, "load_cell": -2.0, "estop": 0.0})]
    )
    table = store.samples(run_id)
    assert list(table.channels) == ["load_cell", "tow_position"]
    assert table.channels["tow_position"][0] == 1.5 and table.channels["load_cell"][0] == -2.0
