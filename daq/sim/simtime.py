"""Simulated time: an event loop whose clock jumps to the next timer when every task waits.

``SimTimeLoop`` is asyncio's selector loop with a virtual ``time()``. When nothing is
ready to run, no I/O is waiting to be read and no worker thread (``asyncio.to_thread``,
``run_in_executor``: the store's writes) is still busy, the loop moves its time straight
to the next timer instead of sleeping; while a worker thread is busy, time stands still
until it is done. So the plant, the simulated PLC and thruster controller, the
acquisition clock and the procedures all run on one clock, in process, as fast as the
CPU allows, in the same order for the same inputs::

    clock = SimClock.run(main())   # or, in a test on a SimTimeLoop: SimClock.of_running_loop()

Real sockets and ptys still work on this loop, but their peers run in real time: keep
simulated time for in-process devices (``daq.sim.inprocess``). A loop that serves someone
in real time (a rig service behind HTTP in a test) is paced: ``SimTimeLoop(pace=10)`` lets
its time run at most 10 times faster than the wall clock while it waits, so an idle rig
does not spin a core and a client's requests still arrive between its ticks. With
``idle_pace`` and ``busy`` it keeps that pace only while ``busy()`` (e.g. a job holds the
rig) and the slower ``idle_pace`` otherwise: an idle rig between a client's requests
needs its time to pass no faster than that, and each tick costs CPU.
"""

from __future__ import annotations

import asyncio
import selectors
import time
from collections.abc import Callable, Coroutine
from concurrent.futures import Executor
from typing import Any, TypeVar

T = TypeVar("T")

#: Simulated time starts here (s): the monotonic clock of a freshly booted host.
START_S = 1000.0
#: Epoch seconds at ``START_S`` (2026-01-01T00:00:00Z), so stored wall times are the same
#: on every run.
EPOCH_AT_START_S = 1_767_225_600.0
#: Longest real wait while a worker thread is busy, before looking again (s).
_THREAD_POLL_S = 0.05


class _SimSelector:
    """The loop's selector; when there is nothing to do but wait, time jumps instead."""

    def __init__(self, inner: selectors.BaseSelector, loop: SimTimeLoop) -> None:
        self._inner = inner
        self._loop = loop

    def select(self, timeout: float | None = None) -> list:
        if timeout is not None and timeout <= 0:
            return self._inner.select(0)
        if self._loop.busy_threads:
            wait = _THREAD_POLL_S if timeout is None else min(timeout, _THREAD_POLL_S)
            return self._inner.select(wait)  # time stands still while a thread works
        pace = self._loop.current_pace
        if pace is not None and timeout is not None:
            started = time.monotonic()
            events = self._inner.select(timeout / pace)
            if events:  # woken early: time moved on only as far as the pace allows
                self._loop.advance(min(timeout, (time.monotonic() - started) * pace))
                return events
            self._loop.advance_to_next_timer(timeout)
            return []
        events = self._inner.select(0)
        if events or timeout is None:
            return events or self._inner.select(None)
        self._loop.advance_to_next_timer(timeout)
        return []

    def __getattr__(self, name: str) -> Any:
        return getattr(self._inner, name)


class SimTimeLoop(asyncio.SelectorEventLoop):
    """An event loop on simulated time (see the module docstring)."""

    def __init__(
        self,
        start_s: float = START_S,
        *,
        pace: float | None = None,
        idle_pace: float | None = None,
        busy: Callable[[], bool] | None = None,
    ) -> None:
        super().__init__()
        for name, value in (("pace", pace), ("idle_pace", idle_pace)):
            if value is not None and not value > 0:
                raise ValueError(
                    f"{name}: must be > 0 (times faster than real time), got {value!r}"
                )
        if (idle_pace is None) != (busy is None) or (idle_pace is not None and pace is None):
            raise ValueError("idle_pace and busy: give both, with a pace, or neither")
        self._sim_now = start_s
        #: At most this many simulated seconds per real second while waiting (None: no limit).
        self.pace = pace
        #: The pace while ``busy()`` is false (None: always ``pace``).
        self.idle_pace = idle_pace
        self.busy = busy
        #: Worker-thread calls still running; time does not move while any is.
        self.busy_threads = 0
        inner: selectors.BaseSelector = self._selector  # type: ignore[has-type]
        self._selector = _SimSelector(inner, self)  # type: ignore[assignment]

    def time(self) -> float:
        return self._sim_now

    @property
    def current_pace(self) -> float | None:
        """The pace of a wait now: ``idle_pace`` while not ``busy()``, else ``pace``."""
        if self.busy is not None and not self.busy():
            return self.idle_pace
        return self.pace

    @property
    def clock(self) -> SimClock:
        """This loop's clock (``daq.clock.clock_of``)."""
        return SimClock(self)

    def advance(self, seconds: float) -> None:
        """Move simulated time forward (the loop does this itself when all wait)."""
        if seconds < 0:
            raise ValueError(f"seconds: time cannot go back, got {seconds!r}")
        self._sim_now += seconds

    def advance_to_next_timer(self, timeout: float) -> None:
        """Jump to the earliest timer (exactly its time: no rounding piles up), or by
        ``timeout`` when there is none."""
        scheduled = self._scheduled  # type: ignore[attr-defined]
        due = scheduled[0].when() if scheduled else self._sim_now + timeout
        self._sim_now = max(self._sim_now, due)

    def alone(self) -> bool:
        """Whether a task that yields now (``await asyncio.sleep(0)``) would be the next to
        run anyway: no other callback ready, no timer due, the loop not stopping. On this
        loop time stands still while anything is ready, so such a yield changes nothing
        (``daq.sim.inprocess`` skips it; only I/O from real sockets would be seen later)."""
        if self._ready or self._stopping:  # type: ignore[attr-defined]
            return False
        scheduled = self._scheduled  # type: ignore[attr-defined]
        return not scheduled or scheduled[0].when() > self._sim_now

    def run_in_executor(  # type: ignore[override]
        self, executor: Executor | None, func: Callable[..., T], *args: Any
    ) -> asyncio.Future[T]:
        future = super().run_in_executor(executor, func, *args)
        self.busy_threads += 1
        future.add_done_callback(self._thread_done)
        return future

    def _thread_done(self, _: asyncio.Future) -> None:
        self.busy_threads -= 1


class SimClock:
    """The ``daq.clock.Clock`` of a ``SimTimeLoop``: ``now()`` is the loop's time."""

    simulated = True

    def __init__(self, loop: SimTimeLoop) -> None:
        self.loop = loop

    @classmethod
    def of_running_loop(cls) -> SimClock:
        """The clock of the running loop, which must be a ``SimTimeLoop``."""
        loop = asyncio.get_running_loop()
        if not isinstance(loop, SimTimeLoop):
            raise RuntimeError(f"simulated time needs a SimTimeLoop, running on {loop!r}")
        return cls(loop)

    @staticmethod
    def run(main: Coroutine[Any, Any, T]) -> T:
        """Run ``main`` to completion on a new ``SimTimeLoop``."""
        with asyncio.Runner(loop_factory=SimTimeLoop) as runner:
            return runner.run(main)

    def now(self) -> float:
        return self.loop.time()

    def wall(self) -> float:
        return EPOCH_AT_START_S + (self.loop.time() - START_S)

    async def sleep(self, seconds: float) -> None:
        await asyncio.sleep(seconds)

    def stall(self, seconds: float) -> None:
        """Block for ``seconds`` as a blocking call on the loop would: time moves on and
        nothing else runs meanwhile (timers due by then run late, in order)."""
        self.loop.advance(seconds)

    async def sleep_until(self, deadline: float) -> None:
        await asyncio.sleep(max(0.0, deadline - self.now()))
