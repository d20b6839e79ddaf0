"""Several writers at once: a recorder's batches, events of another run and a second
process-like Store creating and finishing runs never fail or lose rows."""

from __future__ import annotations

import asyncio
import logging
import multiprocessing
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest
import sqlalchemy as sa

from daq.store import RunRecorder, Store
from daq.store.migrate import create_engine, current_revision, head_revision
from tests.store.helpers import make_samples, new_run
from tests.support.waiting import until, wait_until


def open_store(url: str) -> None:
    """What a CLI or a service does first: open the store at ``url`` (it closes with the
    process)."""
    Store(url)


@pytest.mark.slow  # real processes racing: the slow lane
def test_processes_opening_one_new_database_at_once_all_open_it(tmp_path: Path) -> None:
    """A CLI and a service (or a test reading the run a `rig tow` creates) opening the same
    new SQLite file at once: the first makes the schema, the others wait for its lock and
    find it at head (before, some failed with "table results already exists"; the race
    needs the opens to overlap, so five new files get four processes each). Each open is a
    process of its own, forked from a server that imported the store once
    (``forkserver``): 20 interpreters importing it took 35 s of CPU, and forks overlap
    more tightly than interpreters that start up first."""
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(["daq.store", __name__])  # a new file needs no Alembic
    with ProcessPoolExecutor(4, mp_context=context, max_tasks_per_child=1) as processes:
        for n in range(5):
            url = f"sqlite:///{tmp_path / f'rig{n}.db'}"
            opens = [processes.submit(open_store, url) for _ in range(4)]
            errors = [repr(err) for done in opens if (err := done.exception(timeout=60))]
            assert errors == [], n
            assert current_revision(create_engine(url)) == head_revision()


def test_opening_waits_out_a_lock_held_past_the_busy_wait(tmp_path, monkeypatch, caplog) -> None:
    """Another process migrating a new file on a loaded machine can hold its lock past
    SQLite's busy wait (a rehearsal's "database is locked" at open): the open says so and
    waits it out (up to STORE_RETRY_S, as a run's writes do) instead of failing. The busy
    wait is shortened to 0.2 s so that the lock outlasts it at once."""
    import sqlite3

    from daq.store import migrate

    monkeypatch.setattr(migrate, "SQLITE_BUSY_MS", 200)
    caplog.set_level(logging.WARNING, logger="daq.store.database")
    path = tmp_path / "rig.db"
    blocker = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
    blocker.execute("BEGIN EXCLUSIVE")
    opened: list[Store | BaseException] = []

    def open_it() -> None:
        try:
            opened.append(Store(f"sqlite:///{path}"))
        except BaseException as err:  # shown by the assertion below
            opened.append(err)

    opener = threading.Thread(target=open_it)
    opener.start()
    try:
        wait_until(
            lambda: opened or any("locked by another" in r.getMessage() for r in caplog.records),
            "the open failing once on the lock",
            timeout_s=30,
        )
        time.sleep(1.0)  # the lock held on: several more attempts, not one more warning
        assert not opened, opened  # still waiting (without the retry: DatabaseNotOpened)
    finally:
        blocker.execute("COMMIT")
        blocker.close()
        opener.join(60)
    [store] = opened
    assert isinstance(store, Store), store
    said = [r.getMessage() for r in caplog.records if "locked by another" in r.getMessage()]
    assert len(said) == 1, said  # said once, however many attempts it waited
    assert current_revision(store.engine) == head_revision()
    store.close()


def test_concurrent_writers_do_not_fail(db_url: str) -> None:
    first, second = Store(db_url), Store(db_url)
    recorded, annotated = new_run(first), new_run(first)
    errors: list[str] = []
    counts = {"samples": 0, "events": 0, "runs": 0}
    stop = time.monotonic() + 1.0

    def guarded(name: str, step) -> None:
        while time.monotonic() < stop:
            try:
                step()
            except Exception as exc:  # collected: the assertion below shows them
                errors.append(f"{name}: {exc!r}")

    def add_batch() -> None:
        counts["samples"] += first.add_samples(recorded, make_samples(counts["samples"], 50))

    def add_event() -> None:
        first.add_event(annotated, "info", "tick")
        counts["events"] += 1

    def run_lifecycle() -> None:
        second.finish_run(new_run(second), "completed")
        counts["runs"] += 1

    threads = [
        threading.Thread(target=guarded, args=(name, step))
        for name, step in (("samples", add_batch), ("events", add_event), ("runs", run_lifecycle))
    ]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    assert min(counts.values()) > 0
    np.testing.assert_array_equal(first.samples(recorded).seq, np.arange(counts["samples"]))
    assert len(first.events(annotated)) == counts["events"]
    assert len(first.list_runs(status="completed", limit=10_000)) == counts["runs"]
    first.close()
    second.close()


async def test_postgres_connections_killed_mid_recording_lose_nothing(
    postgres_server, tmp_path
) -> None:
    """The server drops every connection of the database while the recorder runs, then
    refuses new ones for a while: failed flushes keep their samples and retry, and every
    sample is stored exactly once."""
    url = postgres_server.create_database()
    try:
        store = Store(url)
        run_id = new_run(store)
        recorder = RunRecorder(store, run_id, flush_interval_s=0.1)
        flusher = asyncio.create_task(recorder.run())
        samples = make_samples(0, 300)
        database = sa.make_url(url).database
        admin = sa.create_engine(postgres_server.admin_url, isolation_level="AUTOCOMMIT")
        others = f"FROM pg_stat_activity WHERE datname = '{database}' AND pid <> pg_backend_pid()"

        def recorder_connected() -> bool:
            with admin.connect() as conn:
                return conn.exec_driver_sql(f"SELECT count(*) {others}").scalar() >= 1

        for i, sample in enumerate(samples):
            recorder.put(sample)
            await asyncio.sleep(0.002)  # paced: the kills land while samples still arrive
            if i in (100, 150):
                # a loaded host may not have (re)connected the recorder yet: kill it once
                # it has a connection (a rehearsal beside a busy process killed none)
                await until(recorder_connected, "the recorder connected to the database")
                with admin.connect() as conn:
                    if i == 150:
                        conn.exec_driver_sql(f'ALTER DATABASE "{database}" ALLOW_CONNECTIONS false')
                    killed = conn.exec_driver_sql(
                        f"SELECT count(pg_terminate_backend(pid)) {others}"
                    ).scalar()
                assert killed >= 1
            if i == 250:
                await until(
                    lambda n=recorder.stats.failed_flushes: recorder.stats.failed_flushes >= n + 2,
                    "two more refused flushes",
                )
                with admin.connect() as conn:
                    conn.exec_driver_sql(f'ALTER DATABASE "{database}" ALLOW_CONNECTIONS true')
        await recorder.close()
        await flusher
        np.testing.assert_array_equal(store.samples(run_id).seq, np.arange(300))
        assert recorder.stats.failed_flushes >= 1  # the refused flushes were retried
        admin.dispose()
        store.close()
    finally:
        postgres_server.drop_database(url)
