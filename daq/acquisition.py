"""The acquisition clock: one fixed-rate clock with absolute deadlines.

Slot ``k`` is due at ``t0 + k / rate_hz`` (monotonic time), so the clock never
drifts however long each read takes. The clock sleeps on the event loop to about
``spin_s`` before the deadline, then yields in a tight loop until it is due,
which keeps lateness well under a millisecond on an idle loop. The spin is at most
``MAX_SPIN_SHARE`` of the period: a real-time clock spinning 2 ms of every 2 ms slot
(500 Hz) held a whole core of the 2-core rig PC above every normal process.

A tick that runs long, or a wake-up the OS delays, makes the clock skip every slot
whose deadline is more than half a period gone (``seq`` jumps, the next Sample
carries OVERRUN); it never bursts to catch up, so lateness stays under half a
period. Samples are handed off through per-consumer asyncio queues with
``put_nowait``: a full queue loses its own oldest sample (counted), so a slow
consumer cannot slow the clock. Nothing on the clock's path waits on a
database, HTTP or a fit.

A failed poll still produces a Sample on time: quality ERROR, the unread
channels NaN (never a repeated old value, which would look like a vehicle at
rest). The PLC client reconnects in the background; ``device_lost`` is set once
reads have failed for longer than ``device_lost_after_s`` and cleared on the next
good read.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
import math
import sys
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

from daq.clock import REAL_CLOCK, Clock
from daq.cpu_wait import ThreadCpuWait, no_cpu_wait
from daq.plc import Reading
from daq.priority import restore_scheduling, scheduling, set_realtime
from daq.sample import Quality, Sample

log = logging.getLogger(__name__)

#: The largest share of each period the clock spins before its deadline (module doc).
MAX_SPIN_SHARE = 0.05


class Sampler(Protocol):
    """What the clock polls: a PLC client (``daq.plc.PlcClient``) or anything alike."""

    @property
    def channel_names(self) -> tuple[str, ...]: ...

    async def read_all(self) -> dict[str, Reading]: ...


@dataclass
class ClockStats:
    """Counters of the clock; ``lateness_s`` keeps the last ``maxlen`` tick latenesses."""

    ticks: int = 0
    #: Slots skipped over, for either cause: a tick that ran long, or a late wake-up.
    overruns: int = 0
    #: Of those, the wake-ups over half a period late (the host was busy, not the device).
    late_wakeups: int = 0
    #: Of the others (ticks that ran long), those the host held up: the OS kept the clock's
    #: thread waiting for a CPU (``daq.cpu_wait``) so long that without that wait the tick
    #: would have ended in time. What is left, ``overruns - late_wakeups - host_stalls``,
    #: are ticks the device or this process made long.
    host_stalls: int = 0
    skipped_slots: int = 0
    failed_polls: int = 0
    dropped: dict[str, int] = field(default_factory=dict)
    lateness_s: deque[float] = field(default_factory=lambda: deque(maxlen=100_000))

    def lateness_percentiles(self) -> dict[str, float]:
        """Lateness (actual tick start minus its deadline) p50, p99 and max, in seconds."""
        if not self.lateness_s:
            return {"p50_s": math.nan, "p99_s": math.nan, "max_s": math.nan}
        ordered = sorted(self.lateness_s)
        n = len(ordered)

        def pct(p: float) -> float:
            return ordered[min(n - 1, math.ceil(p / 100 * n) - 1)]

        return {"p50_s": pct(50), "p99_s": pct(99), "max_s": ordered[-1]}


@dataclass(eq=False)
class _Subscriber:
    name: str
    queue: asyncio.Queue[Sample]


class Acquisition:
    """Fixed-rate sampling of ``plc`` into Samples handed to subscribers' queues."""

    def __init__(
        self,
        plc: Sampler,
        *,
        rate_hz: float = 10.0,
        device_lost_after_s: float | None = None,
        spin_s: float = 0.002,
        realtime: bool = False,
        clock: Clock = REAL_CLOCK,
        extra_channels: Callable[[], dict[str, float]] | None = None,
        cpu_wait: Callable[[], float] | None = None,
    ) -> None:
        if not (math.isfinite(rate_hz) and 0 < rate_hz <= 10_000):
            raise ValueError(f"rate_hz must be in (0, 10000] Hz, got {rate_hz!r}")
        self.plc = plc
        self.rate_hz = rate_hz
        self.period_s = 1.0 / rate_hz
        #: Reads failing for this long set ``device_lost`` (default: 3 periods, at least 0.5 s).
        self.device_lost_after_s = (
            device_lost_after_s if device_lost_after_s is not None else max(3 * self.period_s, 0.5)
        )
        if self.device_lost_after_s <= 0:
            raise ValueError(f"device_lost_after_s must be > 0 s, got {self.device_lost_after_s!r}")
        #: Time and waiting (``daq.clock``); a simulated clock is on time without spinning.
        self.clock = clock
        self.spin_s = 0.0 if clock.simulated else min(spin_s, MAX_SPIN_SHARE * self.period_s)
        #: Ask the OS for real-time scheduling of the clock's thread (``daq.priority``).
        self.realtime = realtime
        #: Channels of other devices added to each sample as they stand at the read (the
        #: thrusters' telemetry, ``daq.thruster_supervisor``); never waited on, and never
        #: part of the device-lost or quality decision, which is the PLC's alone.
        self.extra_channels = extra_channels
        #: The clock thread's cumulative wait for a CPU, s (``daq.cpu_wait``): by default read
        #: from the OS on a real clock, none on a simulated one; tests pass their own.
        self.cpu_wait = cpu_wait
        self.stats = ClockStats()
        self.latest: Sample | None = None
        #: Set while the device has been unreadable for longer than ``device_lost_after_s``.
        self.device_lost = asyncio.Event()
        self._subscribers: dict[asyncio.Queue[Sample], _Subscriber] = {}
        self._stopping = False
        self._wake: asyncio.Future | None = None
        self._running = False

    # ---- consumers ------------------------------------------------------------------
    def subscribe(self, maxsize: int = 1000, *, name: str | None = None) -> asyncio.Queue[Sample]:
        """A new queue that receives every Sample; when full it loses its oldest one."""
        if maxsize < 1:
            raise ValueError(f"maxsize must be at least 1 sample, got {maxsize!r}")
        q: asyncio.Queue[Sample] = asyncio.Queue(maxsize=maxsize)
        sub = _Subscriber(name or f"consumer-{len(self.stats.dropped) + 1}", q)
        self._subscribers[q] = sub
        self.stats.dropped.setdefault(sub.name, 0)
        return q

    def unsubscribe(self, q: asyncio.Queue[Sample]) -> None:
        """Stop feeding ``q`` (its drop count stays in ``stats.dropped``)."""
        self._subscribers.pop(q, None)

    def _publish(self, sample: Sample) -> None:
        self.latest = sample
        for sub in self._subscribers.values():
            q = sub.queue
            if q.full():
                with contextlib.suppress(asyncio.QueueEmpty):
                    q.get_nowait()
                self.stats.dropped[sub.name] += 1
            q.put_nowait(sample)

    # ---- the clock ------------------------------------------------------------------
    def stop(self) -> None:
        """Ask ``run()`` to return after the tick in progress (wakes a sleeping clock)."""
        self._stopping = True
        if self._wake is not None and not self._wake.done():
            self._wake.set_result(None)

    async def _sleep_until(self, deadline: float) -> None:
        loop = asyncio.get_running_loop()
        coarse = deadline - self.spin_s
        if self.clock.now() < coarse:
            self._wake = loop.create_future()
            handle = loop.call_at(coarse, _resolve, self._wake)
            try:
                await self._wake
            finally:
                handle.cancel()
                self._wake = None
        if self.clock.simulated:  # woken at its deadline: simulated time only jumps to timers
            return
        while not self._stopping and self.clock.now() < deadline:
            await asyncio.sleep(0)

    async def run(self) -> None:
        """Tick until ``stop()``; seq counts slots from 0 at the start of this run."""
        if self._running:
            raise RuntimeError("this Acquisition is already running")
        self._running, self._stopping = True, False
        saved = scheduling() if self.realtime else None
        if self.realtime:
            set_realtime()
        period = self.period_s
        # A worker thread (the store's flush) may hold the GIL for a whole switch interval
        # (5 ms by default): more than a slot at high rates. Hand it back faster while running.
        switch_interval = sys.getswitchinterval()
        sys.setswitchinterval(min(switch_interval, max(period / 4, 0.0002)))
        # The OS's account of this thread (the one running the clock): made here.
        own_wait = None if self.cpu_wait or self.clock.simulated else ThreadCpuWait()
        waited = self.cpu_wait or own_wait or no_cpu_wait
        t0 = self.clock.now()
        last_good = t0
        slot = 0
        overrun = False
        waited_before = waited()
        try:
            while True:
                deadline = t0 + slot * period
                await self._sleep_until(deadline)
                if self._stopping:
                    return
                start = self.clock.now()
                waited_at_start = waited()
                due = math.ceil((start - t0) / period - 0.5)
                if due > slot:  # woke over half a period late (busy machine): skip, not burst
                    self.stats.overruns += 1
                    self.stats.late_wakeups += 1
                    self.stats.skipped_slots += due - slot
                    slot, overrun = due, True
                    waited_before = waited_at_start
                    continue
                self.stats.lateness_s.append(start - deadline)
                sample = await self._tick(slot, overrun)
                self.stats.ticks += 1
                if sample.quality & Quality.ERROR and not _any_read(sample):
                    if sample.t_mono - last_good >= self.device_lost_after_s:
                        if not self.device_lost.is_set():
                            down_s = sample.t_mono - last_good
                            log.warning("device lost: no good read for %.3f s", down_s)
                        self.device_lost.set()
                else:
                    last_good = sample.t_mono
                    self.device_lost.clear()
                if self.extra_channels is not None and (extra := self.extra_channels()):
                    sample = dataclasses.replace(sample, channels=sample.channels | extra)
                self._publish(sample)
                # Next slot: the first one not more than half a period overdue.
                end = self.clock.now()
                due = math.ceil((end - t0) / period - 0.5)
                next_slot = max(slot + 1, due)
                overrun = next_slot > slot + 1
                waited_now = waited()
                if overrun:
                    self.stats.overruns += 1
                    self.stats.skipped_slots += next_slot - slot - 1
                    # The CPU wait that held this slot back: before the wake-up (no more than
                    # the wake-up's lateness) and during the tick.
                    held = min(waited_at_start - waited_before, max(0.0, start - deadline))
                    held += waited_now - waited_at_start
                    if math.ceil((end - held - t0) / period - 0.5) <= slot + 1:
                        self.stats.host_stalls += 1
                slot, waited_before = next_slot, waited_now
        finally:
            if own_wait is not None:
                own_wait.close()
            self._running = False
            sys.setswitchinterval(switch_interval)
            if saved is not None:
                restore_scheduling(saved)

    async def _tick(self, seq: int, overrun: bool) -> Sample:
        quality = Quality.OVERRUN if overrun else Quality.OK
        try:
            readings = await self.plc.read_all()
        except Exception as err:  # DeviceError, or anything odd from the transport
            self.stats.failed_polls += 1
            log.debug("poll %d failed: %s", seq, err)
            t_mono, t_wall = self.clock.now(), self.clock.wall()
            lost = dict.fromkeys(self.plc.channel_names, math.nan)
            return Sample(seq, t_mono, t_wall, lost, quality | Quality.ERROR)
        t_mono, t_wall = self.clock.now(), self.clock.wall()
        channels: dict[str, float] = {}
        stale: list[str] = []
        for name, r in readings.items():
            flags = r.quality
            if not flags:  # OK: no flag arithmetic (each IntFlag operation makes a member)
                channels[name] = r.value
                continue
            quality |= flags
            channels[name] = math.nan if flags & Quality.ERROR else r.value
            if flags & Quality.STALE:
                stale.append(name)
        if quality & Quality.ERROR:
            self.stats.failed_polls += 1
        return Sample(seq, t_mono, t_wall, channels, quality, tuple(stale))


def _resolve(fut: asyncio.Future) -> None:
    if not fut.done():
        fut.set_result(None)


def _any_read(sample: Sample) -> bool:
    return any(not math.isnan(v) for v in sample.channels.values())
