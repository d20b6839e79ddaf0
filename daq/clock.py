"""The one injectable clock: what the acquisition clock, the procedures, the thruster
driver and the simulated rig ask for the time, and how they wait.

Production runs on ``REAL_CLOCK`` (``time.monotonic``, ``time.time``, the event loop's
own sleeps). Tests run on ``daq.sim.simtime.SimClock``: the same protocol over an event
loop whose time only moves when every task is waiting, so a 30 s tow takes well under a
second and the same seed gives the same samples (docs/acquisition.md, "Simulated time").

A clock's ``now()`` is the time of the running event loop (``loop.time()``): timers
(``asyncio.sleep``, ``wait_for``, ``call_at``) and ``now()`` then agree on either clock.
"""

from __future__ import annotations

import asyncio
import time
from typing import Protocol


class Clock(Protocol):
    """Time for the rig: ``now()`` monotonic s (e.g. ``1234.5``), ``wall()`` epoch s."""

    #: True for a simulated clock: nothing needs to spin to be on time.
    simulated: bool

    def now(self) -> float: ...

    def wall(self) -> float: ...

    async def sleep(self, seconds: float) -> None: ...

    async def sleep_until(self, deadline: float) -> None: ...


class RealClock:
    """Wall time: ``time.monotonic`` (the default event loop's time) and ``time.time``."""

    simulated = False

    def now(self) -> float:
        return time.monotonic()

    def wall(self) -> float:
        return time.time()

    async def sleep(self, seconds: float) -> None:
        await asyncio.sleep(seconds)

    async def sleep_until(self, deadline: float) -> None:
        await asyncio.sleep(max(0.0, deadline - self.now()))


#: The clock of production: real time.
REAL_CLOCK = RealClock()


def clock_of(loop: asyncio.AbstractEventLoop) -> Clock:
    """The clock of ``loop``: its own (``SimTimeLoop.clock``) if it has one, else real time."""
    clock: Clock = getattr(loop, "clock", REAL_CLOCK)
    return clock
