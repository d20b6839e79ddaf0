"""The acquisition clock against a real Modbus server on a real socket."""

from __future__ import annotations

import asyncio
import itertools
import math
import os
import time

import pytest

from daq.acquisition import Acquisition
from daq.sample import Quality, Sample
from tests.waiting import until


@pytest.fixture
def plc_modbus() -> dict:
    """Short timeouts: a failed poll ends well inside a slot, a reconnect comes soon."""
    return {"timeout_s": 0.1, "reconnect_min_s": 0.05, "reconnect_max_s": 0.2}


async def _collect(q: asyncio.Queue[Sample], n: int, timeout_s: float = 10.0) -> list[Sample]:
    out = []
    async with asyncio.timeout(timeout_s):
        while len(out) < n:
            out.append(await q.get())
    return out


async def test_absolute_deadlines_do_not_drift_at_100_hz(plc):
    acq = Acquisition(plc, rate_hz=100.0)
    q = acq.subscribe(maxsize=1000)
    runner = asyncio.create_task(acq.run())
    samples = await _collect(q, 201)
    acq.stop()
    await runner
    first, last = samples[0], samples[-1]
    # Slot k is due at t0 + k/100 s: elapsed time matches the slot count (each sample's
    # time is its read, so allow a little jitter). A relative clock (sleep one period
    # after each ~1 ms read) would be ~0.2 s behind after 200 ticks.
    assert last.t_mono - first.t_mono == pytest.approx((last.seq - first.seq) / 100.0, abs=0.02)
    seqs = [s.seq for s in samples]
    assert seqs == sorted(set(seqs))
    # Every slot is either served or counted as skipped. How many a loaded machine skips is
    # the machine's, not the clock's: bench/clock_lateness.py measures it (0 when idle).
    assert acq.stats.skipped_slots == last.seq - 200
    # No burst: a slot more than half a period overdue is skipped, never run late.
    assert max(acq.stats.lateness_s) <= 0.005
    assert all(s.quality in (Quality.OK, Quality.OVERRUN) for s in samples)
    assert acq.stats.lateness_percentiles()["p50_s"] < 0.002
    assert min(acq.stats.lateness_s) >= 0
    assert math.isclose(samples[5].channels["tow_position"], 0.0)
    assert acq.latest is not None and acq.latest.seq >= 200


async def test_an_overrun_skips_slots_and_never_bursts(server, plc):
    acq = Acquisition(plc, rate_hz=100.0)
    q = acq.subscribe(maxsize=1000)
    runner = asyncio.create_task(acq.run())
    await _collect(q, 10)
    server.delay_s = 0.02  # each of the 3 requests answers after 20 ms: a tick takes ~60 ms
    slow = await _collect(q, 8)
    server.delay_s = 0.0
    await _collect(q, 3)  # drain the tick that was in flight
    after = await _collect(q, 20)
    acq.stop()
    await runner
    gaps = [b.seq - a.seq for a, b in itertools.pairwise(slow)]
    assert all(g >= 5 for g in gaps), gaps  # slots skipped, seq jumps
    assert all(s.quality & Quality.OVERRUN for s in slow[1:])
    times = [b.t_mono - a.t_mono for a, b in itertools.pairwise(slow)]
    assert min(times) > 0.04  # no catch-up burst of back-to-back ticks
    assert acq.stats.skipped_slots >= sum(g - 1 for g in gaps)
    assert acq.stats.overruns >= len(gaps)
    # Back on consecutive slots once the PLC answers promptly: on an idle machine every one
    # (bench/clock_lateness.py); a loaded one may skip some, but most gaps are one slot again
    # where every gap above was five or more.
    after_gaps = [b.seq - a.seq for a, b in itertools.pairwise(after)]
    assert sum(g == 1 for g in after_gaps) >= len(after_gaps) / 2, after_gaps
    assert sum(s.quality == Quality.OK for s in after) >= len(after) / 2


async def test_a_slow_subscriber_loses_its_own_oldest_samples_only(plc):
    acq = Acquisition(plc, rate_hz=100.0)
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
    assert acq.stats.lateness_percentiles()["p50_s"] < 0.002  # the clock stayed on time
    acq.unsubscribe(slow)
    assert acq.stats.dropped["slow"] > 0


async def test_plc_lost_mid_acquisition_then_back(server, plc):
    acq = Acquisition(plc, rate_hz=50.0, device_lost_after_s=0.1)
    q = acq.subscribe(maxsize=1000)
    runner = asyncio.create_task(acq.run())
    server.set("tow_position", 1.25)
    before = await _collect(q, 5)
    # The PLC answers: every reading good (a loaded host may still skip a slot: OVERRUN).
    assert not any(s.quality & (Quality.ERROR | Quality.STALE) for s in before), before
    assert not acq.device_lost.is_set()

    await server.stop()
    t_lost = time.monotonic()
    async with asyncio.timeout(2.0):
        await acq.device_lost.wait()
    assert 0.08 < time.monotonic() - t_lost < 0.5
    down = await _collect(q, 10)
    errors = [s for s in down if s.quality & Quality.ERROR]
    assert errors and all(math.isnan(v) for s in errors for v in s.channels.values())
    assert set(errors[0].channels) == set(plc.channel_names)

    await server.start()  # back on the same port
    async with asyncio.timeout(3.0):
        while True:
            s = await q.get()
            if s.quality == Quality.OK:
                break
    assert s.channels["tow_position"] == pytest.approx(1.25)
    assert not acq.device_lost.is_set()
    assert plc.stats.reconnects == 1
    acq.stop()
    await runner
    # The clock kept its slots through the outage: failed reads fail fast, no tick ran long
    # (a late wake-up of a loaded host is not the PLC's doing and is counted apart).
    assert acq.stats.overruns - acq.stats.late_wakeups == 0
    assert acq.stats.failed_polls >= 10


async def test_stop_wakes_a_sleeping_clock_promptly(plc):
    acq = Acquisition(plc, rate_hz=0.5)
    runner = asyncio.create_task(acq.run())
    await until(lambda: acq.stats.ticks == 1, "the first tick")  # then 2 s asleep
    t0 = time.monotonic()
    acq.stop()
    await asyncio.wait_for(runner, 1.0)
    assert time.monotonic() - t0 < 1.0  # the next tick is 2 s away: stop did not wait for it
    assert acq.stats.ticks == 1


def test_bad_arguments_name_the_value_and_range():
    with pytest.raises(ValueError, match=r"rate_hz must be in \(0, 10000\] Hz, got -5"):
        Acquisition(None, rate_hz=-5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="device_lost_after_s"):
        Acquisition(None, device_lost_after_s=0)  # type: ignore[arg-type]


async def test_realtime_clock_runs_and_restores_the_thread_scheduling(plc):
    before = (os.sched_getscheduler(0), os.getpriority(os.PRIO_PROCESS, 0))
    acq = Acquisition(plc, rate_hz=100.0, realtime=True)
    q = acq.subscribe()
    runner = asyncio.create_task(acq.run())
    samples = await _collect(q, 20)
    acq.stop()
    await runner
    assert [s.seq for s in samples] == sorted({s.seq for s in samples})
    assert (os.sched_getscheduler(0), os.getpriority(os.PRIO_PROCESS, 0)) == before


async def test_a_frozen_plc_scan_marks_samples_stale_by_name(server, plc):
    server.heartbeat_running = False  # the PLC answers but its scan (heartbeat, ms clock) stopped
    acq = Acquisition(plc, rate_hz=50.0)
    q = acq.subscribe()
    runner = asyncio.create_task(acq.run())
    samples = await _collect(q, 35)  # 0.7 s; freshness_s is 0.5 s
    acq.stop()
    await runner
    assert samples[0].quality == Quality.OK
    late = samples[-1]
    assert late.quality == Quality.STALE
    assert late.stale == ("heartbeat", "plc_clock")
    assert not math.isnan(late.channels["heartbeat"])  # stale values are still reported
    assert not acq.device_lost.is_set()
