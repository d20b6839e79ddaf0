"""The recorder when storage fails: a full database is a fault (one line, once), what it
could not store goes to the spill file and back into the database when a flush succeeds
again or the store is next opened; a held lock is retried, and the run's end is written
once, truthfully.

A real SQLite database is made "full" with ``PRAGMA max_page_count`` (SQLITE_FULL, as a
full disk gives), read-only, or locked by a second real connection.
"""

from __future__ import annotations

import asyncio
import sqlite3
import time

import numpy as np
import pytest
import sqlalchemy as sa

from daq.store import RunRecorder, Store
from daq.store.faults import StorageUnavailable, describe, one_line
from daq.store.recorder import STORE_RETRY_S
from daq.store.spill import read_spill
from tests.store.helpers import DbLimits, held_write_lock, make_samples, new_run, no_sql
from tests.support.waiting import until


@pytest.fixture
def sqlite_store(tmp_path):
    store = Store(f"sqlite:///{tmp_path / 'rig.db'}", spill_dir=tmp_path / "spill")
    yield store
    store.close()


def _recording(store: Store, **options) -> tuple[str, RunRecorder, list[str]]:
    """A new run in ``store``, its recorder (0.1 s flushes, ``options``) and the list of
    storage faults the recorder reports."""
    run_id = new_run(store)
    faults: list[str] = []
    recorder = RunRecorder(store, run_id, flush_interval_s=0.1, on_fault=faults.append, **options)
    return run_id, recorder, faults


def _put(recorder: RunRecorder, start: int, count: int) -> None:
    """Hand ``count`` samples from seq ``start`` to ``recorder`` (as the clock does)."""
    for sample in make_samples(start, count):
        recorder.put(sample)


async def test_a_full_database_is_one_fault_spilled_and_written_back_when_room_returns(
    sqlite_store: Store,
) -> None:
    limits = DbLimits(sqlite_store)
    run_id, recorder, faults = _recording(sqlite_store)
    _put(recorder, 0, 50)
    assert await recorder.flush() == 50

    limits.fill()
    _put(recorder, 50, 2000)
    assert await recorder.flush() == 0
    _put(recorder, 2050, 100)  # the clock keeps going while the rig stops
    assert await recorder.flush() == 0

    assert faults == ["storage failed: SQLite: database or disk is full"]  # once
    assert recorder.fault == faults[0]
    spilled = read_spill(recorder.spill.path)
    assert [s.seq for s in spilled.samples] == list(range(50, 2150))  # each sample once
    assert spilled.samples[7] == make_samples(57, 1)[0]  # exactly as acquired
    assert recorder.queued == 2100  # also kept in memory for the next flush

    limits.set()  # room again
    assert await recorder.flush() == 2100
    await recorder.close()
    assert not recorder.spill.path.exists()  # everything it held is stored
    np.testing.assert_array_equal(sqlite_store.samples(run_id).seq, np.arange(2150))


async def test_the_end_of_a_run_the_database_refuses_is_kept_and_written_on_the_next_open(
    sqlite_store: Store, tmp_path
) -> None:
    limits = DbLimits(sqlite_store)
    run_id, recorder, faults = _recording(sqlite_store)
    _put(recorder, 0, 30)
    await recorder.flush()
    limits.set(read_only=True)  # no write at all succeeds now, not even the run's end
    _put(recorder, 30, 500)
    recorder.add_event("limit", "end of travel: brake engaged", {"seq": 529})

    # The body "completed", but storage failed: the end is aborted, naming storage.
    status, reason = await recorder.end("completed", None)
    message = "storage failed: SQLite: attempt to write a readonly database"
    assert (status, reason) == ("aborted", message) and faults == [message]
    assert sqlite_store.get_run(run_id, as_stored=True).status == "running"  # not yet written
    pending = sqlite_store.get_run(run_id)  # ... but this process answers with the truth
    assert (pending.status, pending.reason) == (status, reason)
    assert [r.status for r in sqlite_store.list_runs()] == [status]
    assert read_spill(recorder.spill.path).end[:2] == (status, reason)

    with Store(sqlite_store.url, spill_dir=tmp_path / "spill") as reopened:
        run = reopened.get_run(run_id)
        assert (run.status, run.reason) == (status, reason)
        no_sql(run.reason)
        np.testing.assert_array_equal(reopened.samples(run_id).seq, np.arange(530))
        (event,) = reopened.events(run_id)
        assert event.message == "end of travel: brake engaged" and event.data == {"seq": 529}
    assert not recorder.spill.path.exists()


async def test_a_write_lock_held_across_the_end_is_waited_out_and_the_run_completes(
    sqlite_store: Store, tmp_path
) -> None:
    limits = DbLimits(sqlite_store)
    limits.set(busy_ms=50)  # each attempt gives up quickly: the retries are what is tested
    run_id, recorder, faults = _recording(sqlite_store)
    _put(recorder, 0, 341)
    recorder.add_event("limit", "max time 2 s: brake engaged")
    blocker = sqlite3.connect(tmp_path / "rig.db", isolation_level=None)
    blocker.execute("BEGIN EXCLUSIVE")
    ending = asyncio.create_task(recorder.end("completed", None))
    await until(  # the end is being retried against the lock
        lambda: recorder.stats.failed_flushes >= 3 or ending.done(), "3 failed flushes at the end"
    )
    assert not ending.done()
    blocker.execute("COMMIT")
    blocker.close()

    assert await asyncio.wait_for(ending, 30) == ("completed", None)
    assert faults == []
    run = sqlite_store.get_run(run_id)
    assert (run.status, run.reason, run.sample_count) == ("completed", None, 341)
    assert [e.message for e in sqlite_store.events(run_id)] == ["max time 2 s: brake engaged"]
    assert not recorder.spill.path.exists()


async def test_a_lock_on_the_finish_alone_never_turns_a_stored_run_into_aborted(
    sqlite_store: Store, tmp_path
) -> None:
    limits = DbLimits(sqlite_store)
    limits.set(busy_ms=50)
    run_id, recorder, _ = _recording(sqlite_store)
    _put(recorder, 0, 100)
    await recorder.close()  # every sample stored
    blocker = sqlite3.connect(tmp_path / "rig.db", isolation_level=None)
    blocker.execute("BEGIN EXCLUSIVE")
    ending = asyncio.create_task(recorder.end("completed", None))
    await until(lambda: recorder.stats.last_error, "a flush failing on the lock")
    assert "database is locked" in recorder.stats.last_error
    no_sql(recorder.stats.last_error)
    blocker.execute("COMMIT")
    blocker.close()
    assert await asyncio.wait_for(ending, 30) == ("completed", None)
    assert sqlite_store.get_run(run_id).status == "completed"


def test_database_errors_read_as_one_line_and_say_whether_a_retry_helps(
    sqlite_store: Store, tmp_path
) -> None:
    limits = DbLimits(sqlite_store)
    run_id = new_run(sqlite_store)
    limits.fill()
    with pytest.raises(StorageUnavailable) as full:  # the store's boundary: one error
        sqlite_store.add_samples(run_id, make_samples(0, 500))
    assert isinstance(full.value, sa.exc.OperationalError)  # what retry rules look at
    # Not "(sqlite3.OperationalError) … [SQL: INSERT INTO samples …]": the database by name.
    assert str(full.value) == "database SQLite rig.db unavailable: SQLite: database or disk is full"
    assert describe(full.value).message == "SQLite: database or disk is full"
    assert not describe(full.value).retryable
    no_sql(one_line(full.value))

    limits.set(busy_ms=10)
    blocker = sqlite3.connect(tmp_path / "rig.db", isolation_level=None)
    blocker.execute("BEGIN EXCLUSIVE")
    try:
        with pytest.raises(sa.exc.OperationalError) as locked:
            sqlite_store.finish_run(run_id, "completed")
    finally:
        blocker.execute("ROLLBACK")
        blocker.close()
    assert describe(locked.value).message == "SQLite: database is locked"
    assert describe(locked.value).retryable
    assert one_line(ValueError("two\nlines")) == "two lines"


async def test_refused_writes_are_a_fault_and_a_held_lock_is_retried(store: Store, tmp_path):
    """Both backends: a lock is waited out (no fault), refused writes are one fault."""
    limits = DbLimits(store)
    limits.set(busy_ms=50)
    run_id, recorder, faults = _recording(store, spill_dir=tmp_path)
    with held_write_lock(store):
        _put(recorder, 0, 10)
        assert await recorder.flush() == 0
        assert recorder.stats.failed_flushes == 1 and faults == []
        no_sql(recorder.stats.last_error)
    assert await recorder.flush() == 10

    limits.set(read_only=True)
    _put(recorder, 10, 10)
    assert await recorder.flush() == 0
    (fault,) = faults
    assert fault.startswith("storage failed: ") and "read" in fault, fault
    no_sql(fault)
    assert [s.seq for s in read_spill(recorder.spill.path).samples] == list(range(10, 20))

    limits.set()  # writable again: the end stores everything (a procedure would have
    # been aborted by on_fault; the reason it passes is kept)
    assert await recorder.end("aborted", fault) == ("aborted", fault)
    run = store.get_run(run_id)
    assert (run.status, run.reason, run.sample_count) == ("aborted", fault, 20)
    assert not recorder.spill.path.exists()


async def test_only_events_refused_at_the_end_leave_a_completed_run_completed(
    sqlite_store: Store, tmp_path
) -> None:
    limits = DbLimits(sqlite_store)
    run_id, recorder, _ = _recording(sqlite_store)
    _put(recorder, 0, 40)
    await recorder.flush()  # every sample stored
    recorder.add_event("limit", "max time 4 s: brake engaged")
    limits.set(read_only=True)
    assert await recorder.end("completed", None) == ("completed", None)
    limits.set()
    assert sqlite_store.replay_spills() == [run_id]
    run = sqlite_store.get_run(run_id)
    assert (run.status, run.reason, run.sample_count) == ("completed", None, 40)
    assert [e.message for e in sqlite_store.events(run_id)] == ["max time 4 s: brake engaged"]


async def test_a_lock_held_past_the_retry_limit_delays_only_the_bookkeeping(
    sqlite_store: Store, tmp_path
) -> None:
    """The database locked across the end for longer than the recorder retries (1 s here,
    30 s by default; the same path): the run stays ``completed``, reads so at once, its
    samples and end wait in the spill file, and its stop time is when it ended, not when
    the database took it."""
    limits = DbLimits(sqlite_store)
    limits.set(busy_ms=50)
    run_id, recorder, faults = _recording(sqlite_store, retry_for_s=1.0)
    _put(recorder, 0, 341)
    recorder.add_event("limit", "max time 2 s: brake engaged")
    blocker = sqlite3.connect(tmp_path / "rig.db", isolation_level=None)
    blocker.execute("BEGIN EXCLUSIVE")
    ended_at = time.time()
    assert await asyncio.wait_for(recorder.end("completed", None), 30) == ("completed", None)
    assert faults == [] and recorder.stats.failed_flushes >= 2  # it tried, then spilled
    assert sqlite_store.get_run(run_id, as_stored=True).status == "running"
    shown = sqlite_store.get_run(run_id)  # the truth, while the database is still locked
    assert (shown.status, shown.reason) == ("completed", None)
    stopped_at = shown.stopped_at.timestamp()
    assert ended_at <= stopped_at < ended_at + 0.5
    kept = read_spill(recorder.spill.path)
    assert [s.seq for s in kept.samples] == list(range(341))
    assert kept.end is not None and kept.end[:2] == ("completed", None)
    assert kept.end[2] == pytest.approx(stopped_at, abs=1e-5)

    blocker.execute("COMMIT")
    blocker.close()
    taken_at = time.time()
    assert sqlite_store.replay_spills() == [run_id]
    run = sqlite_store.get_run(run_id, as_stored=True)
    assert (run.status, run.reason, run.sample_count) == ("completed", None, 341)
    assert run.stopped_at.timestamp() == pytest.approx(stopped_at, abs=1e-5)
    assert run.stopped_at.timestamp() < taken_at - 0.9  # not when the database took it
    assert [e.message for e in sqlite_store.events(run_id)] == ["max time 2 s: brake engaged"]
    assert len(sqlite_store.pending_ends) == 0 and not recorder.spill.path.exists()


def test_the_default_limits_are_the_documented_10_s_busy_wait_and_30_s_of_retries(
    sqlite_store: Store, tmp_path
) -> None:
    """docs/storage.md: the tests that hold a lock past these limits scale them down
    (``DbLimits``, ``Store.retry_for_s``); the shipped values are checked here."""
    assert RunRecorder(sqlite_store, new_run(sqlite_store)).retry_for_s == STORE_RETRY_S == 30.0
    with sqlite_store.engine.connect() as conn:
        assert conn.exec_driver_sql("PRAGMA busy_timeout").scalar() == 10_000
    with Store(f"sqlite:///{tmp_path / 'short.db'}") as short:
        short.retry_for_s = 2.5
        assert RunRecorder(short, new_run(short)).retry_for_s == 2.5  # the store's limit
        assert RunRecorder(short, new_run(short), retry_for_s=1.0).retry_for_s == 1.0


def _closed_port() -> int:
    """A local TCP port nothing listens on (bound, never listening)."""
    import socket

    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    port = sock.getsockname()[1]
    sock.close()
    return port


def test_a_database_that_cannot_be_opened_is_the_stores_own_error():
    """Callers catch the store's error, never SQLAlchemy's; its message is the driver's
    reason without the URL (a password never shows)."""
    from daq.store.faults import DatabaseNotOpened, StorageFault

    with pytest.raises(DatabaseNotOpened) as caught:
        Store(f"postgresql+psycopg://rig:secret@127.0.0.1:{_closed_port()}/rig")
    assert isinstance(caught.value, StorageFault)
    assert not isinstance(caught.value, sa.exc.SQLAlchemyError)
    assert "connection failed" in str(caught.value) and "secret" not in str(caught.value)
    assert "Background on this error" not in str(caught.value)
