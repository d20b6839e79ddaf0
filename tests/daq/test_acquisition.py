"""The acquisition clock's rules on simulated time (tests/conftest.py, ``simtime``): slots on
absolute deadlines, skipping instead of bursting, per-subscriber hand-off, a prompt stop.
A sampler whose reads take a set simulated time stands in for the PLC, so every time the
clock stamps is exact. Against a real Modbus server in real time: test_acquisition_wire.py."""

from __future__ import annotations

import asyncio
import itertools
import math

import pytest

from daq.acquisition import Acquisition
from daq.plc import Reading
from daq.sample import Quality, Sample
from daq.sim.simtime import SimClock
from tests.support.waiting import until

pytestmark = pytest.mark.simtime


class TimedSampler:
    """A PLC whose every poll takes ``read_s`` of simulated time; the position is its count."""

    channel_names = ("tow_position",)

    def __init__(self, clock: SimClock, read_s: float = 0.001) -> None:
        self.clock = clock
        self.read_s = read_s
        self.polls = 0

    async def read_all(self) -> dict[str, Reading]:
        await asyncio.sleep(self.read_s)
        self.polls += 1
        return {"tow_position": Reading(float(self.polls), self.clock.now())}


def _clock_and_sampler(read_s: float = 0.001) -> tuple[SimClock, TimedSampler]:
    clock = SimClock.of_running_loop()
    return clock, TimedSampler(clock, read_s)


async def _collect(q: asyncio.Queue[Sample], n: int, timeout_s: float = 10.0) -> list[Sample]:
    out = []
    async with asyncio.timeout(timeout_s):
        while len(out) < n:
            out.append(await q.get())
    return out


async def test_absolute_deadlines_do_not_drift_at_100_hz():
    clock, sampler = _clock_and_sampler(read_s=0.003)
    acq = Acquisition(sampler, rate_hz=100.0, clock=clock)
    q = acq.subscribe(maxsize=1000)
    runner = asyncio.create_task(acq.run())
    samples = await _collect(q, 201)
    acq.stop()
    await runner
    # Slot k starts at t0 + k/100 s and its sample is stamped when the 3 ms read is back. A
    # relative clock (sleep one period after each read) would be 0.6 s behind after 200 ticks.
    t0 = samples[0].t_mono - 0.003
    assert [s.seq for s in samples] == list(range(201))
    assert [s.t_mono for s in samples] == pytest.approx([t0 + k / 100 + 0.003 for k in range(201)])
    assert set(acq.stats.lateness_s) == {0.0} and acq.stats.skipped_slots == 0
    assert all(s.quality == Quality.OK for s in samples)
    assert samples[5].channels["tow_position"] == 6.0
    assert acq.latest is not None and acq.latest.seq >= 200


async def test_an_overrun_skips_slots_and_never_bursts():
    clock, sampler = _clock_and_sampler()
    acq = Acquisition(sampler, rate_hz=100.0, clock=clock)
    q = acq.subscribe(maxsize=1000)
    runner = asyncio.create_task(acq.run())
    await _collect(q, 10)
    sampler.read_s = 0.064  # a tick takes 64 ms: 6.4 slots
    slow = await _collect(q, 8)
    sampler.read_s = 0.001
    await _collect(q, 1)  # the tick that was in flight
    after = await _collect(q, 20)
    acq.stop()
    await runner
    # A 64 ms tick: the next slot is the first not over half a period (5 ms) overdue, run at
    # most that late (slot +6, 4 ms late), or skipped to (+7): never a burst to catch up.
    gaps = [b.seq - a.seq for a, b in itertools.pairwise(slow)]
    assert set(gaps) == {6, 7}
    assert all(s.quality & Quality.OVERRUN for s in slow[1:])
    times = [b.t_mono - a.t_mono for a, b in itertools.pairwise(slow)]
    assert min(times) >= 0.064 - 1e-9  # each tick starts after the last one's read
    assert max(acq.stats.lateness_s) == pytest.approx(0.004)
    assert acq.stats.overruns >= len(gaps)
    # Back on consecutive slots, every one, once the reads are quick again.
    assert [b.seq - a.seq for a, b in itertools.pairwise(after)] == [1] * 19
    assert all(s.quality == Quality.OK for s in after)


class HostHeldSampler(TimedSampler):
    """Its polls take ``read_s``, of which the OS kept the clock's thread waiting for a CPU
    ``held_s`` (``waited`` is the clock's ``cpu_wait``)."""

    def __init__(self, clock: SimClock, read_s: float, held_s: float) -> None:
        super().__init__(clock, read_s)
        self.held_s = held_s
        self.waited_s = 0.0

    def waited(self) -> float:
        return self.waited_s

    async def read_all(self) -> dict[str, Reading]:
        self.waited_s += self.held_s
        return await super().read_all()


@pytest.mark.parametrize(
    ("held_s", "host_held_it"),
    [(0.15, True), (0.02, False)],
    ids=["the-host-held-it", "the-tick-ran-long"],
)
async def test_a_tick_the_host_held_up_is_counted_apart_from_a_long_tick(held_s, host_held_it):
    # 10 Hz: a 0.2 s poll ends past 1.5 slots and skips one. Held 0.15 s by the host, it
    # would have ended at 0.05 s (in time); held 0.02 s, at 0.18 s (late anyway).
    sampler = HostHeldSampler(SimClock.of_running_loop(), read_s=0.2, held_s=held_s)
    acq = Acquisition(sampler, rate_hz=10.0, clock=sampler.clock, cpu_wait=sampler.waited)
    q = acq.subscribe()
    runner = asyncio.create_task(acq.run())
    samples = await _collect(q, 3)
    acq.stop()
    await runner
    assert [s.seq for s in samples] == [0, 2, 4]
    assert acq.stats.overruns >= 2 and acq.stats.late_wakeups == 0
    assert acq.stats.host_stalls == (acq.stats.overruns if host_held_it else 0)


async def test_a_slow_subscriber_loses_its_own_oldest_samples_only():
    clock, sampler = _clock_and_sampler()
    acq = Acquisition(sampler, rate_hz=100.0, clock=clock)
    slow = acq.subscribe(maxsize=5, name="slow")
    fast = acq.subscribe(maxsize=1000, name="fast")
    runner = asyncio.create_task(acq.run())
    got = await _collect(fast, 60)
    acq.stop()
    await runner
    got += [fast.get_nowait() for _ in range(fast.qsize())]
    assert len(got) == acq.stats.ticks  # the fast consumer lost nothing
    assert acq.stats.dropped["fast"] == 0
    assert acq.stats.dropped["slow"] == acq.stats.ticks - 5
    kept = [slow.get_nowait().seq for _ in range(slow.qsize())]
    assert kept == [s.seq for s in got[-5:]]  # the newest five
    assert acq.stats.skipped_slots == 0  # the slow consumer did not slow the clock
    acq.unsubscribe(slow)
    assert acq.stats.dropped["slow"] > 0


async def test_a_failed_poll_is_a_sample_on_time_with_nan_not_an_old_value():
    clock, sampler = _clock_and_sampler()
    acq = Acquisition(sampler, rate_hz=10.0, device_lost_after_s=0.25, clock=clock)
    q = acq.subscribe()
    runner = asyncio.create_task(acq.run())
    await _collect(q, 2)

    async def fail() -> dict[str, Reading]:
        raise ConnectionError("PLC gone")

    good_read, sampler.read_all = sampler.read_all, fail  # type: ignore[method-assign]
    down = await _collect(q, 4)
    assert [s.seq for s in down] == [2, 3, 4, 5]  # on their slots
    assert all(s.quality & Quality.ERROR and math.isnan(s.channels["tow_position"]) for s in down)
    # Lost once unread for longer than device_lost_after_s: at the third failed poll.
    assert acq.device_lost.is_set() and acq.stats.failed_polls == 4
    sampler.read_all = good_read  # type: ignore[method-assign]
    back = await _collect(q, 1)
    assert back[0].quality == Quality.OK and not acq.device_lost.is_set()
    acq.stop()
    await runner


async def test_stop_wakes_a_sleeping_clock_promptly():
    clock, sampler = _clock_and_sampler()
    acq = Acquisition(sampler, rate_hz=0.5, clock=clock)
    runner = asyncio.create_task(acq.run())
    await until(lambda: acq.stats.ticks == 1, "the first tick")  # then 2 s asleep
    t0 = clock.now()
    acq.stop()
    await runner
    assert clock.now() - t0 < 0.01  # the next tick is 2 s away: stop did not wait for it
    assert acq.stats.ticks == 1


def test_bad_arguments_name_the_value_and_range():
    with pytest.raises(ValueError, match=r"rate_hz must be in \(0, 10000\] Hz, got -5"):
        Acquisition(None, rate_hz=-5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="device_lost_after_s"):
        Acquisition(None, device_lost_after_s=0)  # type: ignore[arg-type]
