"""Samples stored in blocks (``sample_blocks``): every per-sample detail survives a block,
its merges and partial reads; a run's blocks never overlap; small batches are merged so a
long run is a few rows; databases of the one-row-per-sample schema are converted."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest
import sqlalchemy as sa

from daq.sample import Quality, Sample
from daq.store import DuplicateSample, Store
from daq.store.migrate import alembic_config, create_engine, current_revision, head_revision
from daq.store.samples import MERGE_FAN_IN
from tests.store.helpers import make_samples, new_run


def odd_sample(seq: int) -> Sample:
    """A sample whose quality, stale channels and NaN depend on its seq (seq % 3)."""
    kind = seq % 3
    return Sample(
        seq,
        100.0 + seq * 0.1,
        1.7e9 + seq * 0.1,
        {"tow_position": seq * 0.01} | ({} if kind == 1 else {"load_cell": -seq / 7}),
        (Quality.OK, Quality.STALE | Quality.ERROR, Quality.OVERRUN)[kind],
        ("load_cell",) if kind == 1 else (),
    )


def assert_reads_as(store: Store, run_id: str, sent: list[Sample], **page: int) -> None:
    """The stored samples (a page of them) are ``sent``, every field of every sample."""
    table = store.samples(run_id, **page)
    got = [table.sample(i) for i in range(len(table))]
    fields = [[(s.seq, s.t_mono, s.t_wall, s.quality, s.stale) for s in x] for x in (got, sent)]
    assert fields[0] == fields[1]
    for name, values in table.channels.items():  # NaN where a sample lacked the channel
        np.testing.assert_array_equal(values, [s.channels.get(name, math.nan) for s in sent])
    assert table.seq.dtype == np.int64 and table.quality.dtype == np.int64
    assert all(a.flags.writeable for a in (table.seq, table.t_mono, *table.channels.values()))


def test_single_sample_batches_keep_quality_stale_and_nan_through_merges(store: Store) -> None:
    run_id = new_run(store)
    sent = [odd_sample(seq) for seq in range(40)]
    for sample in sent:  # a batch of one, forty times
        assert store.add_samples(run_id, [sample]) == 1

    # 16 blocks of one sample became one of 16, twice; 8 batches wait for their turn
    assert store.stats()["sample_blocks"] == 2 + 40 - 2 * MERGE_FAN_IN
    assert store.stats()["samples"] == 40 == store.sample_count(run_id)
    assert_reads_as(store, run_id, sent)
    table = store.samples(run_id)
    assert math.isnan(table.channels["load_cell"][1]) and table.stale[1] == ("load_cell",)
    assert table.quality[4] == Quality.STALE | Quality.ERROR and table.stale[3] == ()
    assert store.last_sample(run_id) == sent[-1]


def test_long_runs_of_small_batches_are_a_few_blocks(store: Store) -> None:
    run_id = new_run(store)
    sent = make_samples(0, 5 * MERGE_FAN_IN**2)  # 256 flushes of 5 samples (10 Hz, 0.5 s)
    for start in range(0, len(sent), 5):
        store.add_samples(run_id, sent[start : start + 5])
    assert store.stats()["sample_blocks"] == 1  # merged twice: 16 × 16 × 5 samples
    assert_reads_as(store, run_id, sent)


def test_a_batch_larger_than_a_block_is_several_blocks(store: Store, monkeypatch) -> None:
    monkeypatch.setattr("daq.store.packing.BLOCK_MAX_SAMPLES", 100)
    monkeypatch.setattr("daq.store.samples.MERGE_FAN_IN", 2)
    run_id = new_run(store)
    sent = [odd_sample(seq) for seq in range(250)]
    store.add_samples(run_id, sent)
    assert store.stats()["sample_blocks"] == 3  # 100 + 100 + 50: none merged past 100
    assert_reads_as(store, run_id, sent)


@pytest.mark.parametrize(
    ("start_seq", "limit", "expected"),
    [
        (0, None, list(range(0, 60, 2))),
        (7, 5, [8, 10, 12, 14, 16]),  # starts inside a block, ends in the next
        (20, 1, [20]),
        (21, 3, [22, 24, 26]),
        (0, 0, []),
        (58, 10, [58]),
        (59, None, []),
    ],
)
def test_partial_reads_cut_blocks_where_asked(
    store: Store, start_seq: int, limit: int | None, expected: list[int]
) -> None:
    run_id = new_run(store)
    sent = [odd_sample(seq) for seq in range(0, 60, 2)]  # gaps: skipped clock slots
    for start in range(0, len(sent), 4):
        store.add_samples(run_id, sent[start : start + 4])
    page = {"start_seq": start_seq} | ({} if limit is None else {"limit": limit})
    assert_reads_as(store, run_id, [s for s in sent if s.seq in expected], **page)


def test_a_batch_between_stored_seqs_is_merged_in_order(store: Store) -> None:
    run_id = new_run(store)
    evens = [odd_sample(seq) for seq in range(0, 20, 2)]
    odds = [odd_sample(seq) for seq in range(1, 20, 2)]
    store.add_samples(run_id, evens[:5])
    store.add_samples(run_id, evens[5:])
    assert store.add_samples(run_id, list(reversed(odds))) == 10  # any order, between them
    assert_reads_as(store, run_id, [odd_sample(seq) for seq in range(20)])
    assert store.stats()["sample_blocks"] == 1 and store.get_run(run_id).sample_count == 20


def test_a_stored_seq_is_refused_by_name_or_left_out(store: Store) -> None:
    run_id = new_run(store)
    store.add_samples(run_id, [odd_sample(seq) for seq in range(0, 40, 2)])
    again = [odd_sample(seq) for seq in range(30, 41)]  # 30, 32, …, 40 stored; 31, … new
    with pytest.raises(
        DuplicateSample, match=r"seq in 30\.\.40 is already stored \(seq 30, 32, 34, 36, 38;"
    ):
        store.add_samples(run_id, again)
    assert store.sample_count(run_id) == 20
    assert store.add_samples(run_id, again + again[:2], skip_existing=True) == 6
    assert_reads_as(store, run_id, [odd_sample(s) for s in [*range(0, 30, 2), *range(30, 41)]])
    assert store.get_run(run_id).sample_count == 26


def test_writers_of_one_run_take_turns(store: Store) -> None:
    """Two stores writing the same seqs at once: one batch is stored, the other refused."""
    run_id = new_run(store)
    batch = make_samples(0, 2000)
    start = threading.Barrier(2)
    outcomes: list[object] = []

    def write() -> None:
        with Store(store.url) as other:
            start.wait()
            try:
                outcomes.append(other.add_samples(run_id, batch))
            except DuplicateSample as exc:
                outcomes.append(type(exc))

    threads = [threading.Thread(target=write) for _ in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert sorted(outcomes, key=str) == sorted([2000, DuplicateSample], key=str)
    assert store.sample_count(run_id) == 2000 == store.get_run(run_id).sample_count


def _old_run(conn: sa.Connection, uuid: str, channels: str) -> int:
    """A run row as revision 0006 stored it."""
    conn.execute(sa.text("INSERT INTO rigs (name) VALUES ('old') ON CONFLICT DO NOTHING"))
    conn.execute(sa.text("INSERT INTO vehicles (name) VALUES ('v') ON CONFLICT DO NOTHING"))
    return conn.execute(
        sa.text(
            "INSERT INTO runs (uuid, kind, status, parameters, rig_id, vehicle_id, started_at, "
            "channel_names, sample_count, software_version, rig_toml, source) VALUES (:uuid, "
            "'tow', 'completed', '{}', (SELECT id FROM rigs), (SELECT id FROM vehicles), 1.7e9, "
            ":channels, 0, '0.0.1', '', 'recorded') RETURNING id"
        ),
        {"uuid": uuid, "channels": channels},
    ).scalar_one()


def test_a_database_of_one_row_per_sample_is_converted_to_blocks(db_url: str) -> None:
    """Rows written with the old DDL (revision 0006: ``samples``, one row per sample, the
    channels one float64 BLOB) read back the same after the upgrade, and back again."""
    from alembic import command

    two = [odd_sample(seq) for seq in (0, 1, 2, 3, 5, 8)]
    one = [Sample(s, 7.0 + s, 1.7e9 + s, {"load_cell": s / 3}) for s in range(3)]
    engine = create_engine(db_url)
    with engine.begin() as conn:
        command.upgrade(alembic_config(conn), "0006")
        runs = {
            "0123abcd-0000-4000-8000-000000000001": (["tow_position", "load_cell"], two),
            "0123abcd-0000-4000-8000-000000000002": (["load_cell"], one),
        }
        for uuid, (names, samples) in runs.items():
            pk = _old_run(conn, uuid, str(names).replace("'", '"'))
            conn.execute(
                sa.text(
                    "INSERT INTO samples (run_id, seq, t_mono, t_wall, quality, stale, "
                    "channel_values) VALUES (:run, :seq, :t_mono, :t_wall, :quality, :stale, "
                    ":values)"
                ),
                [
                    {
                        "run": pk,
                        "seq": s.seq,
                        "t_mono": s.t_mono,
                        "t_wall": s.t_wall,
                        "quality": int(s.quality),
                        "stale": ",".join(s.stale) or None,
                        "values": np.array(
                            [s.channels.get(n, math.nan) for n in names], dtype="<f8"
                        ).tobytes(),
                    }
                    for s in samples
                ],
            )
    with Store(db_url) as store:
        assert current_revision(engine) == head_revision() != "0006"
        for uuid, (names, samples) in runs.items():
            expected = [
                Sample(s.seq, s.t_mono, s.t_wall, {n: s.channels.get(n, math.nan) for n in names},
                       s.quality, s.stale)
                for s in samples
            ]  # fmt: skip
            table = store.samples(uuid)
            assert len(table) == len(samples) and list(table.channels) == names
            for i, sample in enumerate(expected):
                got = table.sample(i)
                assert (got.seq, got.t_mono, got.t_wall, got.quality, got.stale) == (
                    sample.seq, sample.t_mono, sample.t_wall, sample.quality, sample.stale,
                )  # fmt: skip
                np.testing.assert_array_equal(
                    list(got.channels.values()), list(sample.channels.values())
                )
        assert store.stats()["sample_blocks"] == 2  # one block per run
        store.add_samples(uuid, [Sample(3, 10.0, 1.7e9 + 3, {"load_cell": 1.0})])
        with pytest.raises(DuplicateSample):  # converted seqs are known as stored
            store.add_samples(uuid, [Sample(2, 10.0, 1.7e9 + 3, {"load_cell": 1.0})])

    with engine.begin() as conn:  # and back: one row per sample again
        command.downgrade(alembic_config(conn), "0006")
        rows = conn.execute(sa.text("SELECT seq, stale FROM samples ORDER BY run_id, seq")).all()
    assert [tuple(r) for r in rows] == [
        (0, None), (1, "load_cell"), (2, None), (3, None), (5, None), (8, None),
        (0, None), (1, None), (2, None), (3, None),
    ]  # fmt: skip
    engine.dispose()
