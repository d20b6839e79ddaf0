"""Simulated time: the loop's clock jumps only when every task waits, stands still while a
worker thread runs, keeps a pace when asked; a tow on it is fast and the same every time."""

from __future__ import annotations

import asyncio
import threading
import time

import numpy as np
import pytest

from daq.procedures.motion import run_motion_test
from daq.procedures.requests import tow_parameters
from daq.session import RigSource
from daq.sim.simtime import START_S, SimClock, SimTimeLoop
from daq.store import Store
from tests.support.simrig import rig_session

pytestmark = pytest.mark.simtime


async def test_time_jumps_to_each_timer_in_order_and_only_then():
    clock = SimClock.of_running_loop()
    assert clock.now() == START_S
    woke: list[tuple[str, float]] = []

    async def sleeper(name: str, seconds: float) -> None:
        await clock.sleep(seconds)
        woke.append((name, clock.now()))

    await asyncio.gather(sleeper("late", 30.0), sleeper("early", 0.25), sleeper("mid", 7.5))
    assert woke == [("early", START_S + 0.25), ("mid", START_S + 7.5), ("late", START_S + 30.0)]


async def test_time_stands_still_while_a_worker_thread_runs():
    clock = SimClock.of_running_loop()
    release = threading.Event()
    ticks = 0

    async def ticker() -> None:
        nonlocal ticks
        while True:
            await asyncio.sleep(0.1)
            ticks += 1

    task = asyncio.create_task(ticker())
    await asyncio.sleep(0.35)
    assert ticks == 3
    before = clock.now()
    worker = asyncio.ensure_future(asyncio.to_thread(release.wait, 5.0))
    threading.Timer(0.2, release.set).start()  # the thread works 0.2 s of real time
    await worker
    assert clock.now() == before and ticks == 3  # no tick ran while it worked
    task.cancel()


async def test_a_stall_moves_time_on_and_late_timers_run_in_order():
    clock = SimClock.of_running_loop()
    order: list[str] = []
    loop = asyncio.get_running_loop()
    done = asyncio.Event()
    loop.call_later(0.2, order.append, "b")
    loop.call_later(0.1, order.append, "a")
    loop.call_later(0.3, done.set)
    clock.stall(1.0)  # a blocking call on the loop: nothing ran meanwhile
    assert order == []
    await done.wait()
    assert order == ["a", "b"] and clock.now() == START_S + 1.0


async def test_a_task_is_alone_only_while_nothing_else_could_run_before_it():
    loop = asyncio.get_running_loop()
    assert isinstance(loop, SimTimeLoop)
    await asyncio.sleep(0)
    loop.call_later(1.0, lambda: None)  # a timer not yet due leaves it alone
    assert loop.alone()
    loop.call_soon(lambda: None)
    assert not loop.alone()  # a ready callback would run first
    await asyncio.sleep(0)
    assert loop.alone()
    loop.call_at(loop.time(), lambda: None)
    assert not loop.alone()  # a timer due now would run first
    await asyncio.sleep(0)
    assert not loop.alone()  # now ready: it runs after this task in this pass
    await asyncio.sleep(0)
    assert loop.alone()


def test_a_paced_loop_runs_at_most_that_many_times_faster_than_the_wall_clock():
    async def two_seconds() -> float:
        started = time.monotonic()
        await asyncio.sleep(2.0)
        return time.monotonic() - started

    with asyncio.Runner(loop_factory=lambda: SimTimeLoop(pace=10.0)) as runner:
        assert runner.run(two_seconds()) >= 0.2
    with pytest.raises(ValueError, match="pace"):
        SimTimeLoop(pace=0)


def test_a_loop_with_an_idle_pace_keeps_its_pace_only_while_busy():
    busy = False

    async def wall_of(seconds: float) -> float:
        started = time.monotonic()
        await asyncio.sleep(seconds)
        return time.monotonic() - started

    loop = SimTimeLoop(pace=100.0, idle_pace=2.0, busy=lambda: busy)
    with asyncio.Runner(loop_factory=lambda: loop) as runner:
        assert loop.current_pace == 2.0
        assert runner.run(wall_of(0.6)) >= 0.3  # idle: 0.6 s at 2x
        busy = True
        assert loop.current_pace == 100.0
        assert runner.run(wall_of(6.0)) >= 0.06  # busy: 6 s at 100x
    with pytest.raises(ValueError, match="idle_pace"):
        SimTimeLoop(pace=10.0, idle_pace=-1.0, busy=lambda: False)
    with pytest.raises(ValueError, match="give both"):
        SimTimeLoop(pace=10.0, idle_pace=1.0)


async def _tow(tmp_path, name: str) -> tuple[np.ndarray, np.ndarray, float]:
    """A 30 s tow on a fresh in-process rig; its sample times, positions and the wall time
    it took."""
    with Store(f"sqlite:///{tmp_path / name}") as store:
        async with rig_session(RigSource.load(), store) as session:
            params = tow_parameters(
                {"force_n": 4.9, "max_time_s": 30.0, "baseline_s": 0.5}, session.rig
            )
            started = time.monotonic()
            outcome = await run_motion_test(session, params)
            took = time.monotonic() - started
        assert outcome.status == "completed"
        table = store.samples(outcome.run_id)
        return table.t_mono, table.channels["tow_position"], took


def test_a_30_s_tow_is_quick_and_the_same_seed_gives_the_same_samples(tmp_path):
    """Each tow on a fresh loop (simulated time from START_S): the same samples, bit for bit."""
    t1, x1, took = SimClock.run(_tow(tmp_path, "first.db"))
    t2, x2, _ = SimClock.run(_tow(tmp_path, "second.db"))
    assert t1[-1] - t1[0] > 30.0  # baseline, 30 s free, the brake's tail
    print(f"a 30 s tow took {took:.2f} s of wall time")
    np.testing.assert_array_equal(t2, t1)
    np.testing.assert_array_equal(x2, x1)
    assert x1[-1] > 1.0
