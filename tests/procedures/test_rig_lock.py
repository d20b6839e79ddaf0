"""The lease on a rig's devices: keyed on what the rig file points at (not the database,
not the rig's name), refused naming the holder whatever ``--db`` each process uses, kept
when its lock file is deleted, freed when its holder is killed with SIGKILL."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import uuid
from pathlib import Path

import pytest

from daq.config import load_rig
from daq.procedures.motion import run_motion_test
from daq.procedures.requests import tow_parameters
from daq.rig_lock import RigInUse, RigLockError, RigLockLost, rig_devices, rig_lock
from daq.session import RigSession, RigSource
from daq.store import Store
from tests.procedures.conftest import hardware_rig_file
from tests.support.cli import run_in_process
from tests.support.waiting import read_until

pytestmark = pytest.mark.slow  # real stack in real time: the slow lane (README, Tests)

ROOT = Path(__file__).resolve().parents[2]

HOLD = """
import sys
from daq.config import load_rig
from daq.rig_lock import rig_lock
lock = rig_lock(sys.argv[1], load_rig(sys.argv[2]), "holder-child")
lock.acquire()
lock.set_activity("tow 24.5 N, run 3f2a9c1b")
print(" ".join(str(h.path) for h in lock.host_locks), flush=True)
sys.stdin.read()
"""


@pytest.fixture(autouse=True)
def own_lock_dir(tmp_path, monkeypatch) -> Path:
    """This test's lock folder (children inherit it): its files can be looked at."""
    folder = tmp_path / "locks"
    monkeypatch.setenv("RIG_LOCK_DIR", str(folder))
    return folder


def _hardware_rig(folder: Path, host: str = "127.0.0.1", name: str | None = None) -> Path:
    """BENBAM as a hardware rig file whose PLC and thruster port are this test's alone (a
    port nothing listens on: taking the lease touches no device)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    path = hardware_rig_file(folder, port, f"/dev/towrig-test-{uuid.uuid4().hex[:8]}")
    text = path.read_text().replace('host = "127.0.0.1"', f'host = "{host}"')
    if name is not None:
        text = text.replace('name = "BENBAM tow tank"', f'name = "{name}"', 1)
    out = folder / f"{uuid.uuid4().hex[:6]}.toml"
    out.write_text(text)
    return out


def _hold(db_url: str, rig_file: Path) -> tuple[subprocess.Popen, list[Path]]:
    child = subprocess.Popen(
        [sys.executable, "-c", HOLD, db_url, str(rig_file)],
        cwd=ROOT,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    paths = child.stdout.readline().split()
    assert paths, "the child did not take the rig"
    return child, [Path(p) for p in paths]


def _end(child: subprocess.Popen) -> None:
    if child.poll() is None:
        child.kill()
        child.wait(5)


def test_the_lease_is_on_the_devices_the_rig_file_points_at(tmp_path):
    hw = load_rig(_hardware_rig(tmp_path))
    here = socket.gethostname()
    plc, thrusters = (str(d) for d in rig_devices(hw))
    assert plc == f"PLC tcp 127.0.0.1:{hw.modbus.port} unit 1 on host {here}"
    assert thrusters.startswith("thruster controller /dev/towrig-test-")
    # The same PLC by another name is the same device; the rig's name plays no part.
    renamed = hw.model_copy(
        update={
            "modbus": hw.modbus.model_copy(update={"host": "localhost"}),
            "rig": hw.rig.model_copy(update={"name": "Another name"}),
        }
    )
    assert [str(d) for d in rig_devices(renamed)] == [plc, thrusters]
    other_unit = hw.model_copy(update={"modbus": hw.modbus.model_copy(update={"unit_id": 2})})
    assert str(rig_devices(other_unit)[0]) != plc
    # A simulated rig's devices are its own simulator's: every session gets its own.
    simulated = load_rig(ROOT / "fixtures/rigs/benbam.toml")
    assert rig_devices(simulated) != rig_devices(simulated)


def test_another_database_is_refused_naming_the_holder(tmp_path):
    rig_file = _hardware_rig(tmp_path)
    first = rig_lock(f"sqlite:///{tmp_path}/a.db", load_rig(rig_file), "rig serve")
    # Another --db (and an in-memory one), another rig name: the same PLC and thrusters.
    renamed = load_rig(rig_file).model_copy(update={"rig": load_rig(rig_file).rig.model_copy(
        update={"name": "Renamed rig"})})  # fmt: skip
    second = rig_lock(f"sqlite:///{tmp_path}/b.db", renamed, "rig tow")
    third = rig_lock("sqlite://", load_rig(rig_file), "rig spin")
    with first:
        first.set_activity("tow 24.5 N, run 3f2a9c1b")
        for refused in (second, third):
            with pytest.raises(RigInUse) as err:
                refused.acquire()
            message = str(err.value)
            assert message.startswith(f"rig '{refused.rig_name}' (PLC tcp 127.0.0.1:")
            assert f"is in use by `rig serve` pid {os.getpid()} on host " in message
            assert message.endswith("(tow 24.5 N, run 3f2a9c1b)") and "\n" not in message
            assert not refused.held
        assert second.holder().program == "rig serve"
        other_rig = rig_lock(f"sqlite:///{tmp_path}/a.db", load_rig(_hardware_rig(tmp_path)))
        with other_rig:  # another rig's devices are free
            pass
    assert second.holder() is None
    with second:
        assert third.holder().program == "rig tow"


def test_deleting_the_lock_file_does_not_let_a_second_driver_in(tmp_path, own_lock_dir):
    rig_file = _hardware_rig(tmp_path)
    child, paths = _hold(f"sqlite:///{tmp_path}/a.db", rig_file)
    try:
        assert {p.parent for p in paths} == {own_lock_dir} and all(p.exists() for p in paths)
        for path in paths:
            path.unlink()
        lock = rig_lock(f"sqlite:///{tmp_path}/b.db", load_rig(rig_file), "rig tow")
        with pytest.raises(RigInUse, match="is in use by"):
            lock.acquire()
        # The holder's next renewal makes its file again, saying who holds the device.
        read_until(lambda: all(p.exists() for p in paths), bool, "lock files made again")
        with pytest.raises(RigInUse, match=rf"`holder-child` pid {child.pid} .*\(tow 24.5 N"):
            lock.acquire()
        # Even a folder emptied under everyone keeps the device.
        for path in own_lock_dir.iterdir():
            path.unlink()
        with pytest.raises(RigInUse):
            lock.acquire()
    finally:
        _end(child)


def test_deleting_the_lock_folder_keeps_the_lease_and_the_device(tmp_path, own_lock_dir):
    """``rm -rf "$RIG_LOCK_DIR"`` under a holder: no lost lease (the socket keeps the
    device), a second driver is refused, and the folder and file are made again; while
    the folder cannot be made (a file in its place) the lease still holds."""
    import shutil

    rig = load_rig(_hardware_rig(tmp_path))
    lease = rig_lock(f"sqlite:///{tmp_path}/a.db", rig, "rig serve")
    lost: list[str] = []
    lease.on_lost = lost.append
    with lease:
        path = lease.host_locks[0].path
        shutil.rmtree(own_lock_dir)
        read_until(lambda: path.exists(), bool, "the lock folder and file made again")
        own_lock_dir.rename(tmp_path / "gone")
        own_lock_dir.write_text("")  # the folder cannot be made while this is here
        # A renewal with no folder at all (the renewal thread's own ones too): still held.
        assert [lock.verify(lease.me) for lock in lease.host_locks] == [None, None]
        assert lease.held and lost == []
        second = rig_lock(f"sqlite:///{tmp_path}/b.db", rig, "rig tow")
        with pytest.raises(RigInUse, match="is in use by"):  # (no file says by whom)
            second.acquire()
        own_lock_dir.unlink()
        # made again and naming its holder (an empty file reads "it is just starting")
        read_until(
            lambda: path.read_text() if path.exists() else "", bool, "the lock file made again"
        )
        assert lease.held and lost == []
        with pytest.raises(RigInUse, match="is in use by `rig serve`"):
            second.acquire()
        lease.check()
    assert lost == []


async def test_a_sigkilled_holder_does_not_block_the_next_run(tmp_path):
    """The rig of a simulated session is its own simulator, so the holder here is on a
    hardware rig file's devices, and the next run on them is checked at the lease."""
    rig_file = _hardware_rig(tmp_path)
    child, _ = _hold(f"sqlite:///{tmp_path}/a.db", rig_file)
    try:
        lock = rig_lock(f"sqlite:///{tmp_path}/b.db", load_rig(rig_file), "rig tow")
        with pytest.raises(RigInUse, match=rf"`holder-child` pid {child.pid} .*\(tow 24.5 N"):
            lock.acquire()
        child.send_signal(signal.SIGKILL)
        child.wait(10)
        with lock:  # the kernel let go of the dead holder's locks at once
            assert lock.held
    finally:
        _end(child)
    with Store(f"sqlite:///{tmp_path}/b.db") as store:  # a simulated session works as ever
        async with RigSession(RigSource.load(), store) as session:
            params = tow_parameters(
                {"force_n": 24.5, "max_time_s": 1.0, "baseline_s": 0.2}, session.rig
            )
            outcome = await run_motion_test(session, params)
        assert outcome.status == "completed"


def test_postgres_holder_is_seen_by_a_second_host_lock_folder(tmp_path, postgres_server):
    """Two hosts share only the database: a holder whose host locks cannot be seen (another
    lock folder and another abstract-socket namespace stand in for the other host) is
    still refused by its advisory lock, naming it."""
    url = postgres_server.create_database()
    try:
        rig_file = _hardware_rig(tmp_path)
        first = rig_lock(url, load_rig(rig_file), "rig serve")
        second = rig_lock(url, load_rig(rig_file), "rig tow")
        second.prepare()
        with first:
            for lock in second.host_locks:  # what another host would see: nothing local
                lock.acquire = lambda holder: True  # type: ignore[method-assign]
                lock.release = lambda: None  # type: ignore[method-assign]
            with pytest.raises(RigInUse, match=rf"is in use by `rig serve` pid {os.getpid()}"):
                second.acquire()
            assert not second.held
    finally:
        postgres_server.drop_database(url)


def test_a_sigkilled_cli_tow_shows_interrupted_at_the_next_rig_runs(tmp_path):
    """Its run names the process that owned it; the next command that opens the database
    (here `rig runs`) marks it, not some later service start."""
    db = f"sqlite:///{tmp_path / 'rig.db'}"
    Store(db).close()  # made before the CLI opens it, so the test can read it meanwhile
    tow = subprocess.Popen(
        [sys.executable, "-m", "api.cli.main", "tow", "--force", "24.5", "--max-time", "30",
         "--db", db],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )  # fmt: skip
    try:

        def recording() -> list:
            assert tow.poll() is None, tow.stderr.read()
            with Store(db) as store:
                return [r for r in store.list_runs() if r.sample_count > 0]

        (run,) = read_until(recording, bool, "the CLI tow recording", timeout_s=60, poll_s=0.1)
        assert run.status == "running"
        tow.send_signal(signal.SIGKILL)
        tow.wait(10)
    finally:
        _end(tow)
    # `rig runs` opens the database as a fresh process would (tests/support/cli.py): in this one
    listed = run_in_process(["runs", "--db", db, "--json"], cwd=ROOT, env=dict(os.environ))
    assert listed.returncode == 0, listed.stderr
    (shown,) = json.loads(listed.stdout)
    assert shown["id"] == run.id and shown["status"] == "interrupted"
    host = socket.gethostname()
    assert shown["reason"] == (
        f"recording process pid {tow.pid} on host {host} ended without finishing the run"
    )
    assert "interrupted" in listed.stderr  # said once, on stderr


def test_a_lock_file_taken_over_under_the_holder_is_a_lost_lease(tmp_path):
    """A process that cannot see the holder's socket (another network namespace sharing
    the lock folder) replaces the lock file and locks it: two drivers, so the holder's next
    renewal reports the lease lost, naming the file."""
    import fcntl
    import threading

    lease = rig_lock(f"sqlite:///{tmp_path}/a.db", load_rig(_hardware_rig(tmp_path)))
    lost: list[str] = []
    reported = threading.Event()
    lease.on_lost = lambda reason: (lost.append(reason), reported.set())
    with lease:
        path = lease.host_locks[0].path
        intruder = os.open(path.with_suffix(".new"), os.O_RDWR | os.O_CREAT, 0o600)
        fcntl.flock(intruder, fcntl.LOCK_EX | fcntl.LOCK_NB)
        os.rename(path.with_suffix(".new"), path)  # atomically, between two renewals
        try:
            assert reported.wait(5), "the holder never noticed"
        finally:
            os.close(intruder)
        assert lost == [
            f"rig lock lost: {lease.devices[0]}: its lock file {path.name} (in the lock "
            "folder) was replaced and locked by another process"
        ]
        assert str(tmp_path) not in lost[0]  # no host path in a run's reason or /api/rig
        with pytest.raises(RigLockLost, match="was replaced and locked"):
            lease.check()  # a session's next procedure is refused too


def test_an_unusable_lock_folder_is_one_line(tmp_path, monkeypatch):
    (tmp_path / "file").write_text("")
    monkeypatch.setenv("RIG_LOCK_DIR", str(tmp_path / "file" / "locks"))
    lease = rig_lock("sqlite://", load_rig(_hardware_rig(tmp_path)))
    with pytest.raises(RigLockError, match=r"^cannot take the rig lock: .*RIG_LOCK_DIR") as err:
        lease.acquire()
    assert "\n" not in str(err.value) and not lease.held
