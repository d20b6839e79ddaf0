"""The rig service: one open ``RigSession`` on its own thread and event loop.

The HTTP server's event loop never runs rig code. ``RigService`` starts a dedicated
"rig thread" with its own asyncio loop, opens the session there (which starts the
acquisition clock and, for a simulated rig, the simulator), and exposes

* ``submit(coro)`` — run a coroutine on the rig loop (``run_coroutine_threadsafe``);
* ``call_soon(fn, *args)`` — poke rig-loop objects (abort signals, events) safely;
* ``snapshot()`` — a read-only status view computed on the caller's thread from
  attributes the clock publishes, so a status request never waits on the rig loop.

A forwarding task on the rig loop hands every sample to the ``Broadcaster`` (live
stream) through a small drop-oldest queue: HTTP clients never touch the clock.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import logging
import math
import sys
import threading
from collections.abc import Callable, Coroutine
from typing import Any, TypeVar

from api.core.stream import Broadcaster
from daq.clock import clock_of
from daq.collector import freeze_after_startup
from daq.device_protocols import DeviceFactory
from daq.operator import OperatorAct, PromptOperator
from daq.rig_lock import RigInUse
from daq.session import RigSession, RigSource
from daq.store import Store
from daq.thruster_supervisor import ThrusterTelemetry
from daq.vocabulary import thruster_telemetry_unit
from estimation.report_numbers import finite_or_none

log = logging.getLogger(__name__)
T = TypeVar("T")

#: The GIL switch interval while serving: a busy HTTP thread then delays the clock's
#: thread by at most ~0.5 ms instead of CPython's default 5 ms.
SWITCH_INTERVAL_S = 0.0005


def telemetry_units(telemetry: ThrusterTelemetry | None) -> dict[str, str]:
    """The unit of each thruster telemetry channel (``thruster1_rpm``: ``rpm``,
    ``thruster1_current``: ``A``); samples carry them while a run logs them (a calibration,
    a thruster-driven test, a manual thrust run). ``{}`` for a rig without thrusters."""
    if telemetry is None:
        return {}
    return {name: str(thruster_telemetry_unit(name)) for name in telemetry.names}


class RigUnavailable(RuntimeError):
    """The rig service is not running (not started, failed to open, or stopped)."""


class RigService:
    """Owns the rig thread, its event loop and the open session."""

    def __init__(
        self,
        source: RigSource,
        store_url: str | None = None,
        *,
        rate_hz: float | None = None,
        ask_operator: bool | None = None,
        broadcaster: Broadcaster | None = None,
        realtime: bool = False,
        owner: str | None = None,
        loop_factory: Callable[[], asyncio.AbstractEventLoop] = asyncio.new_event_loop,
        devices: DeviceFactory | None = None,
    ) -> None:
        """``loop_factory`` makes the rig thread's loop, whose clock the session runs on
        (``daq.clock.clock_of``: real time, or a test's ``SimTimeLoop``); ``devices`` makes
        the session's devices (``RigSession``'s ``devices``)."""
        self.source = source
        self._loop_factory = loop_factory
        self._devices = devices
        #: How this service is named to a process refused the rig (default ``rig <cmd>``).
        self.owner = owner
        self.store_url = store_url
        self.rate_hz = rate_hz
        #: Ask a person (API state ``waiting_for_operator``) instead of the simulated
        #: operator; default: only on a hardware rig.
        self.ask_operator = (
            source.rig.rig.mode != "simulated" if ask_operator is None else ask_operator
        )
        self.broadcaster = broadcaster or Broadcaster()
        #: Run the rig thread (clock, devices) SCHED_FIFO so a busy machine cannot
        #: delay a tick; falls back (with a warning) when the OS refuses.
        self.realtime = realtime
        self.realtime_active = False
        self.store: Store | None = None
        self.session: RigSession | None = None
        self.loop: asyncio.AbstractEventLoop | None = None
        self.error: str | None = None
        #: Set by the job runner: called on the rig loop for each operator act.
        self.operator_hook: Callable[[OperatorAct], Coroutine[Any, Any, None]] | None = None
        self._thread: threading.Thread | None = None
        self._ready = threading.Event()
        self._stop: asyncio.Event | None = None
        self._previous_switch = sys.getswitchinterval()

    # -- lifecycle -----------------------------------------------------------------------
    def start(self, *, timeout_s: float = 20.0) -> None:
        """Start the rig thread and wait until the session is open (or failed)."""
        if self._thread is not None:
            raise RuntimeError("RigService already started")
        self.store = Store(self.store_url)
        recovered = self.store.recover_interrupted()
        if recovered:
            log.warning("marked %d run(s) interrupted: %s", len(recovered), ", ".join(recovered))
        sys.setswitchinterval(SWITCH_INTERVAL_S)
        self._thread = threading.Thread(target=self._main, name="rig-thread", daemon=True)
        self._thread.start()
        if not self._ready.wait(timeout_s):
            raise RigUnavailable(f"the rig did not open within {timeout_s:g} s")
        if self.error is not None:
            self._thread.join(5)
            raise RigUnavailable(f"cannot open the rig: {self.error}")
        # Everything loaded so far (modules, the session) lives as long as the service: out
        # of the collector's reach, a full collection no longer walks it while holding the
        # GIL the clock's thread needs (~150 ms → < 1 ms on the 2-core box). While the
        # thrusters are armed the session holds full collections off (daq.collector).
        freeze_after_startup()

    def stop(self, *, timeout_s: float = 15.0) -> None:
        """Leave the rig safe, close the session and end the rig thread."""
        if self._thread is None:
            return
        loop, stop = self.loop, self._stop
        if loop is not None and stop is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):  # the loop already ended
                loop.call_soon_threadsafe(stop.set)
        self._thread.join(timeout_s)
        self._thread = None
        if self.store is not None:
            self.store.close()
        sys.setswitchinterval(self._previous_switch)

    def _main(self) -> None:
        loop = self._loop_factory()
        self.loop = loop
        try:
            loop.run_until_complete(self._run())
        except BaseException as err:  # reported to start(); the thread just ends
            self.error = self.error or f"{type(err).__name__}: {err}"
            log.exception("rig thread ended with an error")
        finally:
            self._ready.set()
            loop.close()

    async def _run(self) -> None:
        self._stop = asyncio.Event()
        operator = PromptOperator(self._ask) if self.ask_operator else None
        assert self.store is not None
        session = RigSession(
            self.source,
            self.store,
            operator=operator,
            rate_hz=self.rate_hz,
            owner=self.owner,
            clock=clock_of(asyncio.get_running_loop()),
            devices=self._devices,
            realtime=self.realtime,
        )
        try:
            await session.open()
        except BaseException as err:
            self.error = str(err) if isinstance(err, RigInUse) else f"{type(err).__name__}: {err}"
            await session.close()
            self._ready.set()
            return
        self.session = session
        self.realtime_active = session.realtime_active
        forward = asyncio.create_task(self._forward_samples(), name="stream-forward")
        self._ready.set()
        stop = asyncio.ensure_future(self._stop.wait())
        released = asyncio.ensure_future(session.released.wait())
        try:
            # Until stopped, or until the lease on the rig is lost (the session has then
            # made the rig safe, ended the run and released the devices): from then on the
            # service says why, and a new job fails in one line naming the lost lock.
            await asyncio.wait({stop, released}, return_when=asyncio.FIRST_COMPLETED)
            if session.lease_lost is not None:
                self.error = (
                    f"{session.lease_lost}; the devices were released (restart the service)"
                )
                log.error("%s", self.error)
        finally:
            stop.cancel()
            released.cancel()
            forward.cancel()
            await session.close()
            self.session = None
        if session.lease_lost is not None:
            await self._stop.wait()  # keep the loop for whoever is still finishing a job

    async def _ask(self, act: OperatorAct) -> None:
        if self.operator_hook is None:
            raise RuntimeError(f"no one to ask: {act.instruction}")
        await self.operator_hook(act)

    async def _forward_samples(self) -> None:
        session = self.session
        assert session is not None and session.acquisition is not None
        acq = session.acquisition
        queue = acq.subscribe(maxsize=8, name="api-stream")
        try:
            while True:
                sample = await queue.get()
                thr = session.thrusters
                self.broadcaster.publish_sample(sample, None if thr is None else thr.output)
        finally:
            acq.unsubscribe(queue)

    # -- crossing into the rig loop ------------------------------------------------------
    @property
    def started(self) -> bool:
        """``start()`` was called and ``stop()`` not yet."""
        return self._thread is not None

    @property
    def running(self) -> bool:
        return self.session is not None and self.loop is not None and not self.loop.is_closed()

    def require_session(self) -> RigSession:
        if not self.running or self.session is None:
            raise RigUnavailable(self.error or "the rig service is not running")
        return self.session

    def submit(self, coro: Coroutine[Any, Any, T]) -> concurrent.futures.Future[T]:
        """Schedule ``coro`` on the rig loop; returns a thread-safe future."""
        if not self.running:
            coro.close()
            raise RigUnavailable(self.error or "the rig service is not running")
        assert self.loop is not None
        return asyncio.run_coroutine_threadsafe(coro, self.loop)

    def run(self, coro: Coroutine[Any, Any, T], timeout_s: float = 10.0) -> T:
        """Run ``coro`` on the rig loop and wait for its result (from another thread)."""
        return self.submit(coro).result(timeout_s)

    def call_soon(self, fn: Callable[..., Any], *args: Any) -> None:
        """Call ``fn(*args)`` on the rig loop (for asyncio objects living there)."""
        if not self.running:
            raise RigUnavailable(self.error or "the rig service is not running")
        assert self.loop is not None
        self.loop.call_soon_threadsafe(fn, *args)

    # -- status ----------------------------------------------------------------------------
    def snapshot(self, *, lateness_window: int = 6000) -> dict[str, Any]:
        """Rig status from attributes the rig thread publishes (never blocks on it)."""
        session = self.session
        if session is None or session.acquisition is None:
            return {
                "running": False,
                "error": self.error,
                "simulated": self.source.rig.rig.mode == "simulated",
                "rig_name": self.source.rig.rig.name,
            }
        acq = session.acquisition
        latest = session.latest()
        stats = acq.stats
        for _ in range(3):  # a C-level copy; retried if the clock appended mid-copy
            try:
                lateness = sorted(list(stats.lateness_s)[-lateness_window:])
                break
            except RuntimeError:
                continue
        else:
            lateness = []

        def pct(p: float) -> float | None:
            if not lateness:
                return None
            return lateness[min(len(lateness) - 1, math.ceil(p / 100 * len(lateness)) - 1)]

        thr = session.thrusters
        link = thr.stats if thr is not None else None
        return {
            "running": True,
            "error": None,
            "simulated": session.simulated,
            "rig_name": session.rig.rig.name,
            "realtime": self.realtime_active,
            "vehicle": session.rig.vehicle.name,
            "connected": bool(session.plc is not None and session.plc.connected),
            "device_lost": acq.device_lost.is_set(),
            "lock_holder": session.lock_holder,
            "armed": session.thrust.armed,
            # the rig's channels, and the thrusters' telemetry a run logs into its samples
            "units": {c.name: c.unit for c in session.rig.channels if not c.sim_only}
            | telemetry_units(session.telemetry),
            "sample": None
            if latest is None
            else {
                "seq": latest.seq,
                "t_wall": latest.t_wall,
                "quality": int(latest.quality),
                "quality_flags": [f.name for f in type(latest.quality) if f in latest.quality],
                "stale_channels": list(latest.stale),
                "channels": {k: finite_or_none(v) for k, v in latest.channels.items()},
            },
            "stale_channels": list(latest.stale) if latest is not None else [],
            "clock": {
                "rate_hz": acq.rate_hz,
                "ticks": stats.ticks,
                "overruns": stats.overruns,
                "late_wakeups": stats.late_wakeups,
                "host_stalls": stats.host_stalls,
                "skipped_slots": stats.skipped_slots,
                "failed_polls": stats.failed_polls,
                "dropped": dict(stats.dropped),
                "lateness_p50_s": pct(50),
                "lateness_p99_s": pct(99),
                "lateness_max_s": lateness[-1] if lateness else None,
                "lateness_window": len(lateness),
            },
            "thrusters": {
                "state": thr.state if thr is not None else "absent",
                "output": list(thr.output) if thr is not None else [],
                "sent": link.sent if link else 0,
                "acked": link.acked if link else 0,
                "timeouts": link.timeouts if link else 0,
                "naks": dict(link.naks) if link else {},
                "stale_zeroings": session.stale_zeroings,
            },
        }
