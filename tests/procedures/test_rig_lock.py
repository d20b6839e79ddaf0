"""The cross-process rig lock on SQLite and PostgreSQL: refused with the holder's name,
free again after release, and after its holder is killed with SIGKILL."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from daq.procedures.motion import run_motion_test
from daq.procedures.params import tow_parameters
from daq.rig_lock import FileRigLock, PostgresRigLock, ProcessRigLock, RigInUse, rig_lock
from daq.session import RigSession, RigSource
from daq.store import Store
from tests.waiting import read_until

ROOT = Path(__file__).resolve().parents[2]
RIG = "BENBAM tow tank"

HOLD = """
import sys
from daq.procedures.motion import run_motion_test
from daq.procedures.params import tow_parameters
from daq.rig_lock import rig_lock
lock = rig_lock(sys.argv[1], sys.argv[2], "holder-child")
lock.acquire()
lock.set_activity("tow 24.5 N, run 3f2a9c1b")
print("held", flush=True)
sys.stdin.read()
"""


def _wait_free(lock, timeout_s: float = 10.0) -> None:
    """Wait until nobody holds the rig (PostgreSQL ends a dead client's backend at once,
    but asynchronously)."""
    read_until(
        lock.holder,
        lambda holder: holder is None,
        "the rig freed",
        timeout_s=timeout_s,
        poll_s=0.02,
    )


def test_the_lock_kind_follows_the_database(tmp_path):
    assert isinstance(rig_lock(f"sqlite:///{tmp_path}/rig.db", RIG), FileRigLock)
    assert isinstance(rig_lock("sqlite://", RIG), ProcessRigLock)
    assert isinstance(rig_lock("postgresql+psycopg://u@h/db", RIG), PostgresRigLock)
    lock = rig_lock(f"sqlite:///{tmp_path}/rig.db", RIG)
    assert isinstance(lock, FileRigLock) and lock.path.parent == tmp_path  # beside the db


def test_second_holder_is_refused_with_the_first_ones_name(db_url):
    Store(db_url).close()  # the database exists, as it does for every session
    first = rig_lock(db_url, RIG, "rig serve")
    second = rig_lock(db_url, " benbam  TOW tank", "rig tow")  # same rig, other spelling
    other_rig = rig_lock(db_url, "spin rig", "rig spin")
    with first:
        first.set_activity("tow 24.5 N, run 3f2a9c1b")
        with pytest.raises(RigInUse) as refused:
            second.acquire()
        message = str(refused.value)
        assert message.startswith(
            f"rig ' benbam  TOW tank' is in use by `rig serve` pid {os.getpid()}"
        )
        assert f"on host {socket.gethostname()[:24]}" in message
        assert message.endswith("(tow 24.5 N, run 3f2a9c1b)") and "\n" not in message
        assert second.holder().pid == os.getpid()
        with other_rig:  # another rig in the same database is free
            pass
    assert second.holder() is None
    with second:
        assert first.holder().program == "rig tow"


async def test_a_sigkilled_holder_does_not_block_the_next_run(db_url):
    Store(db_url).close()
    child = subprocess.Popen(
        [sys.executable, "-c", HOLD, db_url, RIG],
        cwd=ROOT,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert child.stdout.readline().strip() == "held"
        lock = rig_lock(db_url, RIG, "rig tow")
        with pytest.raises(RigInUse, match=rf"`holder-child` pid {child.pid} .*\(tow 24.5 N"):
            lock.acquire()
        child.send_signal(signal.SIGKILL)
        child.wait(10)
        _wait_free(lock)
        with Store(db_url) as store:  # the next run takes the rig and completes
            async with RigSession(RigSource.load(), store) as session:
                params = tow_parameters(
                    {"force_n": 24.5, "max_time_s": 1.0, "baseline_s": 0.2}, session.rig
                )
                outcome = await run_motion_test(session, params)
            assert outcome.status == "completed"
    finally:
        if child.poll() is None:
            child.kill()
            child.wait(5)
