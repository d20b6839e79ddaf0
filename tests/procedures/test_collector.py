"""No full garbage collection while the thrusters are armed (issue 19, item 4).

The mechanism, on the simulated rig: arming holds generation-2 collections off (young ones
go on), disarming gives the thresholds back and full collections resume under the same
load. The pause it saves is measured by ``bench/gc_pause.py``. And the real-time clock's
policy stays on its own thread (``set_realtime``'s docstring); a rig session opened real-time
(``rig serve``, every test command) raises the simulated PLC's thread too, and gives the
clock's thread its scheduling back when it closes.
"""

from __future__ import annotations

import asyncio
import gc
import os
import threading
from collections.abc import Iterator

import pytest

from daq.collector import HELD_THRESHOLD, full_collections_held
from daq.priority import (
    SIMULATOR_PRIORITY,
    THRUSTER_LINK_PRIORITY,
    WORKER_PRIORITY,
    set_realtime,
)
from daq.procedures.recording import AbortSignal, RecordedRun
from daq.session import RigSession, RigSource
from daq.sim.simulated_rig import SimulatedRigThread


def _survivors(rounds: int = 300) -> list[list[list[int]]]:
    """Allocate ``rounds`` × 1000 tracked objects that live on: the load that makes a full
    collection due (CPython: 10 young passes and 25 % more long-lived objects)."""
    return [[[] for _ in range(1000)] for _ in range(rounds)]


class _Collections:
    """Generations of the collections started while it is on."""

    def __init__(self) -> None:
        self.generations: list[int] = []

    def __call__(self, phase: str, info: dict) -> None:
        if phase == "start":
            self.generations.append(info["generation"])


@pytest.fixture
def collections() -> Iterator[_Collections]:
    seen = _Collections()
    gc.callbacks.append(seen)
    try:
        yield seen
    finally:
        gc.callbacks.remove(seen)


async def test_armed_thrusters_hold_full_collections_off_until_disarmed(session, collections):
    before = gc.get_threshold()
    assert not full_collections_held()
    await session.arm_thrusters()
    try:
        assert full_collections_held()
        assert gc.get_threshold() == (before[0], before[1], HELD_THRESHOLD)
        kept = _survivors()
        assert 0 in collections.generations  # the young ones still run
        assert 2 not in collections.generations, "a full collection ran while armed"
    finally:
        await session.disarm_thrusters()
    assert not full_collections_held() and gc.get_threshold() == before
    collections.generations.clear()
    kept += _survivors()
    assert 2 in collections.generations  # the same load: full collections are back
    del kept


async def test_a_recording_run_holds_full_collections_off_even_without_thrust(session):
    """A tow has no thrust, but its clock still needs the GIL: a full collection started by
    another thread (an HTTP request) under load held it 0.4 s and the tow lost 4 slots (the
    rehearsal of 6a050e9). Holds are counted by reason: disarming inside a run keeps the
    run's hold, and the run's end gives the thresholds back."""
    before = gc.get_threshold()
    run = RecordedRun(session, kind="tow", parameters={}, abort=AbortSignal())
    async with run:
        assert full_collections_held()
        await session.arm_thrusters()
        await session.disarm_thrusters()
        assert full_collections_held(), "disarming released the run's hold"
        assert gc.get_threshold() == (before[0], before[1], HELD_THRESHOLD)
    assert run.status == "completed"
    assert not full_collections_held() and gc.get_threshold() == before


async def test_closing_the_session_while_armed_gives_the_thresholds_back(source, store):
    from daq.session import RigSession

    before = gc.get_threshold()
    async with RigSession(source, store) as session:
        await session.arm_thrusters()
        assert full_collections_held()
    assert not full_collections_held() and gc.get_threshold() == before


def test_threads_a_real_time_thread_starts_run_at_normal_priority():
    seen: dict[str, object] = {}

    def child() -> None:
        seen["child"] = os.sched_getscheduler(0)

    def clock() -> None:
        seen["granted"] = set_realtime()
        seen["clock"] = os.sched_getscheduler(0) & ~getattr(os, "SCHED_RESET_ON_FORK", 0)
        thread = threading.Thread(target=child)
        thread.start()
        thread.join()

    thread = threading.Thread(target=clock)
    thread.start()
    thread.join()
    if seen["clock"] != os.SCHED_FIFO:
        pytest.skip("SCHED_FIFO refused here (needs CAP_SYS_NICE)")
    assert seen["child"] == os.SCHED_OTHER  # SCHED_RESET_ON_FORK: not inherited


@pytest.mark.slow  # the simulated rig's own thread over a real socket
async def test_a_real_time_session_raises_the_simulated_plc_and_gives_the_clock_back(store):
    """The simulated PLC stands in for a device with its own CPU: sharing the GIL at normal
    priority, a busy host starved its thread past the 50 ms read timeout (a `rig pendulum`
    aborted for 0.5 s of failed reads in CI). Open real-time, it runs SCHED_FIFO just below
    the clock; closed, the clock's thread runs as before."""
    before = (os.sched_getscheduler(0), os.getpriority(os.PRIO_PROCESS, 0))
    async with RigSession(RigSource.load(), store, realtime=True) as session:
        if not session.realtime_active:
            if os.environ.get("CI") == "true":
                pytest.fail("SCHED_FIFO refused under CI (it runs as root)")
            pytest.skip("SCHED_FIFO refused here (needs CAP_SYS_NICE)")
        sim = session.sim
        assert sim is not None
        # Its thruster line on loopback TCP: a frame on a pty waits for a kernel worker at
        # normal priority to carry it (0.22 s beside busy loops), whatever runs real-time.
        assert isinstance(sim, SimulatedRigThread)
        assert sim.endpoints.thruster_serial_port.startswith("socket://")
        policy = await asyncio.to_thread(sim.call, os.sched_getscheduler, 0)
        param = await asyncio.to_thread(sim.call, os.sched_getparam, 0)
        assert policy & ~getattr(os, "SCHED_RESET_ON_FORK", 0) == os.SCHED_FIFO
        assert param.sched_priority == SIMULATOR_PRIORITY
        assert os.sched_getscheduler(0) & ~getattr(os, "SCHED_RESET_ON_FORK", 0) == os.SCHED_FIFO
        # The thruster line's frames go out from the driver's I/O thread: real-time too, below
        # the simulated devices (at normal priority a loaded host held a heartbeat back 0.4 s).
        (link,) = [t for t in threading.enumerate() if t.name.startswith("thrusters")]
        assert link.native_id is not None
        link_policy = os.sched_getscheduler(link.native_id)
        link_param = os.sched_getparam(link.native_id)
        assert link_policy & ~getattr(os, "SCHED_RESET_ON_FORK", 0) == os.SCHED_FIFO
        assert link_param.sched_priority == THRUSTER_LINK_PRIORITY
        # The loop's worker threads (the store's writes) share the GIL with all of them: at
        # normal priority a busy host preempted one holding it and the clock slept in the
        # GIL's futex for up to 1.8 s. Real-time at the bottom while the session is open.
        policy, priority = await asyncio.to_thread(_own_scheduling)
        assert policy == os.SCHED_FIFO and priority == WORKER_PRIORITY
    assert (os.sched_getscheduler(0), os.getpriority(os.PRIO_PROCESS, 0)) == before
    assert await asyncio.to_thread(_own_scheduling) == (os.SCHED_OTHER, 0)


def _own_scheduling() -> tuple[int, int]:
    """The calling thread's policy (without SCHED_RESET_ON_FORK) and real-time priority."""
    policy = os.sched_getscheduler(0) & ~getattr(os, "SCHED_RESET_ON_FORK", 0)
    return policy, os.sched_getparam(0).sched_priority


def test_a_test_command_freezes_the_heap_once_the_rig_is_open(tmp_path, monkeypatch):
    """``rig tow`` (the CLI drives the rig itself) freezes what start-up loaded, as the
    service does, before the test begins."""
    from click.testing import CliRunner

    from api.cli import procedures
    from api.cli.main import main
    from daq import collector

    seen: list[tuple[int, bool]] = []

    def freeze() -> None:
        collector.freeze_after_startup()
        seen.append((gc.get_freeze_count(), full_collections_held()))

    monkeypatch.setattr(procedures, "freeze_after_startup", freeze)
    monkeypatch.setenv("RIG_SPILL_DIR", str(tmp_path / "spill"))
    db = f"sqlite:///{tmp_path / 'rig.db'}"
    args = ["tow", "--force", "24.5", "--max-time", "1", "--baseline", "0.3", "--db", db]
    try:
        result = CliRunner().invoke(main, [*args, "--json"])
    finally:
        gc.unfreeze()
    assert result.exit_code == 0, result.output
    ((frozen, held),) = seen  # once, with the rig open and nothing armed yet
    assert frozen > 10_000 and not held
