"""A recording process killed with SIGKILL loses at most the last second of samples, and
its run is marked interrupted at the next start-up."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from daq.store import Store
from tests.store.helpers import make_samples, new_run

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.mark.slow  # a recording subprocess killed for real: the slow lane
def test_sigkill_mid_recording_loses_at_most_one_second(db_url: str) -> None:
    child = subprocess.Popen(
        [sys.executable, "-m", "tests.store.record_child", db_url],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        header = child.stdout.readline().split()
        assert header[:1] == ["run"], child.stderr.read()
        run_id = header[1]
        last_put = -1
        deadline = time.monotonic() + 30
        while last_put < 250 and time.monotonic() < deadline:  # ≈ 2.5 s at 100 Hz
            line = child.stdout.readline()
            assert line, child.stderr.read()
            last_put = int(line.split()[1])
        os.kill(child.pid, signal.SIGKILL)
        child.wait(timeout=10)  # reaped: its pid is no longer alive
        for line in child.stdout:  # lines printed before the kill
            last_put = int(line.split()[1])
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    assert child.returncode == -signal.SIGKILL

    with Store(db_url) as store:
        assert store.get_run(run_id).status == "running"
        assert store.recover_interrupted() == [run_id]
        run = store.get_run(run_id)
        table = store.samples(run_id)
        assert run.status == "interrupted"
        assert "ended without finishing" in run.reason
        np.testing.assert_array_equal(table.seq, np.arange(len(table)))  # no holes
        missing = last_put + 1 - len(table)
        assert 0 <= missing <= 100, f"{missing} samples lost (100 Hz: at most 1 s allowed)"
        assert len(table) >= 150
        assert run.stopped_at.timestamp() == pytest.approx(table.t_wall[-1], abs=1e-6)
        assert store.integrity_check() == "ok"
        (event,) = store.events(run_id)
        assert event.kind == "fault" and "interrupted" in event.message
        assert store.recover_interrupted() == []  # once only


def test_recover_leaves_live_runs_alone_unless_forced(store: Store) -> None:
    live = new_run(store)
    t0_wall = time.time()
    store.add_samples(live, make_samples(0, 30, t0_wall=t0_wall))
    empty = new_run(store)
    done = new_run(store)
    store.finish_run(done, "completed")

    assert store.recover_interrupted() == []  # this process owns them and is alive
    assert sorted(store.recover_interrupted(include_live_owners=True)) == sorted([live, empty])
    with_samples, without = store.get_run(live), store.get_run(empty)
    assert with_samples.status == without.status == "interrupted"
    assert with_samples.stopped_at.timestamp() == pytest.approx(t0_wall + 2.9)  # last sample
    assert without.stopped_at == without.started_at  # no samples: its start time
    assert store.get_run(done).status == "completed"
    assert {e.run_id for e in store.events()} == {live, empty}


def test_a_reused_pid_or_a_reboot_does_not_keep_a_dead_run_running(store: Store) -> None:
    """The owner is recorded as (boot id, pid, start time): a live process with the same
    pid but another start time, or the same pid after a reboot, is not the owner."""
    import sqlalchemy as sa

    from daq.store.schema import runs

    reused, rebooted, live = new_run(store), new_run(store), new_run(store)
    with store.transaction() as conn:
        conn.execute(
            sa.update(runs)
            .where(runs.c.uuid == reused)
            .values(owner_start_ticks=runs.c.owner_start_ticks - 1)
        )
        conn.execute(
            sa.update(runs).where(runs.c.uuid == rebooted).values(owner_boot_id="another-boot")
        )
    assert sorted(store.recover_interrupted()) == sorted([reused, rebooted])
    assert store.get_run(live).status == "running"


def test_a_run_of_another_host_is_interrupted_once_its_process_holds_no_lease(postgres_server):
    """PostgreSQL shared by two hosts: the pid of another host cannot be checked, but its
    lease can (``daq.rig_lock``): held → the run is left alone; gone → interrupted, naming
    the process. A run with a sample younger than the grace is left to its own process."""
    import sqlalchemy as sa

    from daq.rig_lock.holder import LockHolder
    from daq.rig_lock.postgres import PG_LOCK_CLASS, lease_holders
    from daq.store.recovery import OTHER_HOST_GRACE_S
    from daq.store.schema import runs
    from tests.support.waiting import read_until

    db_url = postgres_server.create_database()  # SQLite: one host only, its pids say it all
    with Store(db_url) as store:
        old, young = new_run(store), new_run(store)
        long_ago = time.time() - OTHER_HOST_GRACE_S - 60
        store.add_samples(young, make_samples(0, 3, t0_wall=time.time() - 1))
        with store.transaction() as conn:
            conn.execute(
                sa.update(runs)
                .where(runs.c.uuid.in_([old, young]))
                .values(owner_host="lab-pc-2", owner_pid=4242, owner_boot_id="its-boot")
            )
            conn.execute(sa.update(runs).where(runs.c.uuid == old).values(started_at=long_ago))
        # The other host's recording process, holding a device's advisory lock.
        other = LockHolder("rig serve", 4242, "lab-pc-2", time.time(), "tow 24.5 N")
        holder = sa.create_engine(db_url, poolclass=sa.pool.NullPool).connect()
        holder.execute(sa.text("SELECT set_config('application_name', :v, false)"),
                       {"v": other.to_pg_name()})  # fmt: skip
        holder.execute(sa.text("SELECT pg_advisory_lock(:a, 12345)"), {"a": PG_LOCK_CLASS})
        assert store.recover_interrupted() == []
        assert store.get_run(old).status == "running"

        holder.close()  # that process ended: the server drops its lock
        with store.engine.connect() as conn:
            read_until(lambda: lease_holders(conn), lambda h: not h, "its lock dropped")
        assert store.recover_interrupted() == [old]
        run = store.get_run(old)
        assert (run.status, run.reason) == (
            "interrupted",
            "recording process pid 4242 on host lab-pc-2 no longer holds the rig; "
            "it ended without finishing the run",
        )
        assert store.get_run(young).status == "running"  # its process may still end it
    postgres_server.drop_database(db_url)
