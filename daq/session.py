"""One open rig: its devices, its clock, its lock.

``RigSession`` owns the PLC client, the acquisition clock, the thruster driver
and (for a simulated rig) the simulator thread. Opening it first takes the lease on the
rig's devices (``daq.rig_lock``: one process drives a device, whatever its database),
before any device is touched, and closing it gives the lease back after the rig is left
safe; procedures borrow the session under its in-process lock (one procedure at a time),
which also tells anyone refused what the holder is doing. It also runs the thruster
supervisor: every clock tick while armed it re-sends the (slew-limited) target as the
controller's heartbeat, and commands zero as soon as the sensor data goes stale.
Losing the lease while open is a fault like a lost PLC (``daq.lease_fault``).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
from collections.abc import AsyncIterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from daq.acquisition import Acquisition
from daq.clock import REAL_CLOCK, Clock
from daq.collector import hold_full_collections, release_all_full_collections
from daq.config import DEFAULT_RIG_FILE, RigConfig, load_rig
from daq.device_protocols import open_thruster_driver
from daq.lease_fault import LeaseFault
from daq.operator import Operator, PromptOperator, SimulatedOperator, console_ask
from daq.plc import PlcClient
from daq.priority import (
    WORKER_PRIORITY,
    Scheduling,
    WorkerThreads,
    restore_scheduling,
    scheduling,
    set_realtime,
    thruster_link_realtime,
    worker_threads,
)
from daq.rig_lock import RigLease, rig_lock
from daq.safe_state import RELEASE_CHANNELS, SafeState, engage_brake
from daq.sample import Sample
from daq.store import Store
from daq.thruster_supervisor import ThrusterTelemetry, supervise_thrusters
from thrusters.driver import ThrusterDriver, ThrusterError

if TYPE_CHECKING:
    from daq.device_protocols import DeviceFactory, RigDevices, Thrusters
    from daq.sim.scenario import Scenario
    from daq.sim.simulated_rig import SimulatedRigThread

log = logging.getLogger(__name__)


NO_THRUSTERS = "this rig has no thrusters (its rig file has no [thrusters] section)"


class RigBusy(RuntimeError):
    """The rig lock is held by another procedure."""

    def __init__(self, holder: str) -> None:
        self.holder = holder
        super().__init__(f"rig is busy: {holder} holds the rig lock")


class Aborted(RuntimeError):
    """A procedure was stopped before it finished; ``reason`` says why."""

    def __init__(self, reason: str) -> None:
        self.reason = reason
        super().__init__(reason)


@dataclass
class RigSource:
    """Where a session's configuration came from, kept with every run."""

    rig: RigConfig
    rig_toml: str
    scenario_toml: str | None = None
    scenario: Scenario | None = None

    @classmethod
    def load(
        cls, rig_file: str | Path | None = None, scenario_file: str | Path | None = None
    ) -> RigSource:
        """Read and validate the rig file (default BENBAM) and an optional scenario."""
        path = Path(rig_file) if rig_file else DEFAULT_RIG_FILE
        rig = load_rig(path)
        scenario = scenario_toml = None
        if scenario_file:
            from daq.sim.scenario import load_scenario

            scenario = load_scenario(scenario_file)
            scenario_toml = Path(scenario_file).read_text(encoding="utf-8")
        return cls(
            rig=rig,
            rig_toml=path.read_text(encoding="utf-8"),
            scenario_toml=scenario_toml,
            scenario=scenario,
        )


@dataclass
class ThrustTarget:
    """What the procedure wants the thrusters to do (fractions of full scale)."""

    fractions: list[float] = field(default_factory=list)
    armed: bool = False


class RigSession:
    """Open the devices of one rig and keep the clock running until ``close``.

    ``clock`` is the time of the acquisition clock, the supervisor and the procedures
    (``daq.clock``; real time by default). ``devices`` makes the PLC client and thruster
    driver instead of the rig file's own (``daq.device_protocols.DeviceFactory``; tests pass
    ``daq.sim.inprocess.open_inprocess_rig`` with a simulated clock); what it returns is
    kept as ``sim`` and closed with the session. ``realtime``: while open, the thread that
    opened it (the clock's loop) runs SCHED_FIFO (``daq.priority``; quietly normal where the
    OS refuses); the in-process simulated rig's thread raises itself just below it.
    """

    def __init__(
        self,
        source: RigSource,
        store: Store,
        *,
        operator: Operator | None = None,
        rate_hz: float | None = None,
        owner: str | None = None,
        clock: Clock = REAL_CLOCK,
        devices: DeviceFactory | None = None,
        realtime: bool = False,
    ) -> None:
        self.source = source
        self.realtime = realtime
        #: Whether the OS granted real-time scheduling at ``open`` (with ``realtime``).
        self.realtime_active = False
        self._scheduling: Scheduling | None = None
        self._workers: WorkerThreads | None = None
        self.clock = clock
        self._devices = devices
        self.rig = source.rig
        self.store = store
        self.simulated = self.rig.rig.mode == "simulated"
        self._operator = operator
        self._rate_hz = rate_hz or self.rig.acquisition.rate_hz
        self.sim: SimulatedRigThread | RigDevices | None = None
        self.plc: PlcClient | None = None
        self.acquisition: Acquisition | None = None
        self.thrusters: ThrusterDriver | None = None
        #: The thrusters' RPM and current as sample channels while a run logs them.
        self.telemetry: ThrusterTelemetry | None = None
        self._tasks: list[asyncio.Task] = []
        self._lock_holder: str | None = None
        #: The lease on the rig's devices; ``owner`` names this program to whoever is refused.
        self.rig_lock: RigLease = rig_lock(store.url, self.rig, owner)
        self._has_rig = False
        self._closing: asyncio.Future[None] | None = None
        self._shutting = False
        self.lease_fault = LeaseFault()
        #: ``listener(reason)`` is called if the lease is lost; returns its remover.
        self.add_fault_listener = self.lease_fault.add_listener
        self.thrust = ThrustTarget()
        self.stale_zeroings = 0
        #: Set at each of those zeroings (a thruster-driven run waits on it to end itself),
        #: with the sample that caused the last one.
        self.stale_zeroed = asyncio.Event()
        self.stale_sample: Sample | None = None
        #: Metadata (operator, water temperature, notes, tags, …) every run recorded from
        #: now on gets; set by whoever starts a procedure (API job, CLI), checked on store.
        self.run_metadata: dict | None = None

    # -- lifecycle -------------------------------------------------------------------------
    async def open(self, *, connect_timeout_s: float | None = None) -> None:
        """Take the rig (``RigInUse`` if another process drives it), start the simulator
        (simulated rig), connect the devices, start the clock. The PLC is retried for
        ``connect_timeout_s`` (default: the rig file's ``[modbus] connect_timeout_s``)."""
        self._closing = None
        self.lease_fault.arm(self.rig_lock, self._zero_target, self.close)
        if self.realtime:  # before the first asyncio.to_thread: its workers follow the clock
            self._workers = worker_threads(asyncio.get_running_loop())
        await asyncio.to_thread(self.rig_lock.acquire)
        self._has_rig = True
        conn = self.rig
        made = None
        if self._devices is not None:
            made = self.sim = self._devices(self.rig, self.source.scenario, self.clock)
        elif self.simulated:
            from daq.sim.simulated_rig import SimulatedRigThread

            # The thruster line on loopback TCP, not a pty: the kernel hands each frame
            # written to a pty to the other end from a worker thread at normal priority,
            # which a busy host left waiting 0.22 s while the simulator sat idle (two
            # heartbeats unanswered: the link declared lost). A loopback TCP write reaches
            # the simulator in the writer's own system call (docs/simulated-rig.md).
            sim = SimulatedRigThread(self.rig, self.source.scenario, thruster_transport="tcp")
            self.sim = sim
            await asyncio.to_thread(sim.__enter__)
            conn = sim.connection_rig()
        if self.realtime:
            self._scheduling = scheduling()
            self.realtime_active = set_realtime(warn=False)
            if self.realtime_active and self._workers is not None:
                # They share the GIL with the clock (daq.priority.WORKER_PRIORITY).
                self._workers.priority = WORKER_PRIORITY
        self.plc = made.plc_client if made else PlcClient(conn)
        if connect_timeout_s is None:
            connect_timeout_s = conn.modbus.connect_timeout_s
        await self.plc.connect(timeout_s=connect_timeout_s)
        if conn.thrusters is not None:
            self.telemetry = ThrusterTelemetry(conn.thrusters.count, self._rate_hz, self.clock.now)
        self.acquisition = Acquisition(
            self.plc,
            rate_hz=self._rate_hz,
            clock=self.clock,
            extra_channels=None if self.telemetry is None else self.telemetry.channels,
        )
        self._tasks.append(asyncio.create_task(self.acquisition.run(), name="acquisition"))
        if conn.thrusters is not None:  # a rig without [thrusters] opens no serial port
            driver = made.driver if made and made.driver else None
            driver = driver or open_thruster_driver(conn.thrusters, conn.limits)
            # The line's I/O thread follows the clock into real time, below the simulated rig.
            link_setup = thruster_link_realtime if self.realtime_active else None
            await driver.open(io_thread_setup=link_setup)
            self.thrusters = driver  # only an open driver is zeroed and closed later
            self._tasks.append(
                asyncio.create_task(supervise_thrusters(self), name="thruster-supervisor")
            )
        if self._operator is None:
            self._operator = (
                SimulatedOperator(self.plc) if self.simulated else PromptOperator(console_ask)
            )

    async def close(self) -> None:
        """Thrusters to zero, brakes on, clock stopped, devices closed, rig lock given
        back. Never raises; a session that never got the rig touches no device. Closing
        twice at once (the owner, and the lease's loss) closes once."""
        if self._closing is None:
            self._closing = asyncio.ensure_future(self._close())
        await asyncio.shield(self._closing)

    async def _close(self) -> None:
        if not self._has_rig:
            return
        with contextlib.suppress(Exception):
            await self.safe_state()
        self._shutting = True  # safe now; the devices are closing under any later caller
        if self.thrusters is not None:
            with contextlib.suppress(Exception):
                await self.thrusters.close()
        if self.acquisition is not None:
            self.acquisition.stop()
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(BaseException):
                await task
        self._tasks.clear()
        if self.plc is not None:
            with contextlib.suppress(Exception):
                await self.plc.close()
        if self.sim is not None:
            with contextlib.suppress(Exception):
                await asyncio.to_thread(self.sim.close)
            self.sim = None
        self._has_rig = self._shutting = False
        if self._scheduling is not None:
            restore_scheduling(self._scheduling)
            self._scheduling, self.realtime_active = None, False
        if self._workers is not None:
            self._workers.priority = None
        release_all_full_collections()
        await asyncio.to_thread(self.rig_lock.release)

    @property
    def lease_lost(self) -> str | None:
        """Why the lease on the rig was lost while open (``rig lock lost: …``), else None."""
        return self.lease_fault.reason

    @property
    def released(self) -> asyncio.Event:
        """Set once the devices were closed and the lease given back after its loss."""
        return self.lease_fault.released

    async def __aenter__(self) -> RigSession:
        try:
            await self.open()
        except BaseException:
            await self.close()
            raise
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    # -- the rig lock ----------------------------------------------------------------------
    @property
    def lock_holder(self) -> str | None:
        """Who holds the rig lock (``None`` when free)."""
        return self._lock_holder

    @contextlib.asynccontextmanager
    async def locked(self, holder: str) -> AsyncIterator[None]:
        """Hold the rig lock; raise ``RigBusy`` at once (never queue) when it is taken
        (``RigInUse`` if the cross-process lock was lost to another process)."""
        self.rig_lock.check()  # RigLockLost once the lease was lost
        if self._lock_holder is not None:
            raise RigBusy(self._lock_holder)
        self._lock_holder = holder
        try:
            await asyncio.to_thread(self.rig_lock.set_activity, holder)
            yield
        finally:
            self._lock_holder = None
            with contextlib.suppress(Exception):
                await asyncio.to_thread(self.rig_lock.set_activity, None)

    async def note_run(self, run_id: str) -> None:
        """Tell whoever is refused the rig which run the current procedure records."""
        activity = f"{self._lock_holder}, run {run_id[:8]}" if self._lock_holder else run_id
        await asyncio.to_thread(self.rig_lock.set_activity, activity)

    # -- devices -----------------------------------------------------------------------------
    @property
    def operator(self) -> Operator:
        assert self._operator is not None, "session not open"
        return self._operator

    @property
    def live_plc(self) -> PlcClient:
        """The PLC client of an open session."""
        assert self.plc is not None, "session not open"
        return self.plc

    @property
    def live_thrusters(self) -> Thrusters:
        """The thrusters of an open session."""
        assert self.thrusters is not None, "session not open"
        return self.thrusters

    async def safe_state(self) -> SafeState | None:
        """Brakes engaged and thrusters at zero (waits for the controller's ACK); says
        what it did. Nothing (``None``) once ``close`` has done it and is closing the
        devices."""
        if self._shutting:
            return None
        errors = []
        engaged = []
        self.thrust = ThrustTarget([0.0] * self.thruster_count, armed=self.thrust.armed)
        zero: bool | None = None if self.thrusters is None else True
        # Disarmed (or watchdog-latched) controllers already hold their outputs at zero.
        if self.thrusters is not None and self.thrusters.state not in ("DISARMED", "WDT"):
            try:
                await self.thrusters.zero()
            except Exception as err:  # keep going: the brakes matter too
                errors.append(f"thrusters: {err}")
                zero = False
        if self.plc is not None and self.plc.connected:
            for name in RELEASE_CHANNELS:
                if not self.rig.has(name):
                    continue
                failed = await engage_brake(self.plc, name, self.clock)  # retried
                if failed is None:
                    engaged.append(name)
                else:
                    errors.append(f"{name}: {failed}")
        if errors:
            log.warning("safe state incomplete: %s", "; ".join(errors))
        return SafeState(tuple(engaged), zero, tuple(errors))

    @property
    def thruster_count(self) -> int:
        """Thrusters of the rig file's ``[thrusters]`` section (0 without one)."""
        return self.rig.thrusters.count if self.rig.thrusters is not None else 0

    def _zero_target(self) -> None:
        self.thrust = ThrustTarget([0.0] * self.thruster_count, armed=self.thrust.armed)

    async def arm_thrusters(self) -> None:
        if self.thrusters is None:
            raise ThrusterError(NO_THRUSTERS)
        self.thrust = ThrustTarget([0.0] * self.thruster_count, armed=True)
        hold_full_collections(True)  # no 0.1-0.3 s full GC pass while thrust may flow
        try:
            await self.thrusters.arm()
        except BaseException:  # refused or unanswered: not armed, and never said to be
            self.thrust = ThrustTarget([0.0] * self.thruster_count, armed=False)
            hold_full_collections(False)
            raise

    async def disarm_thrusters(self) -> None:
        if self.thrusters is None:
            raise ThrusterError(NO_THRUSTERS)
        hold_full_collections(False)
        if self.lease_lost is not None and not self.thrusters.is_open:
            return  # zeroed, disarmed and closed when the lease was lost
        self.thrust = ThrustTarget([0.0] * self.thruster_count, armed=False)
        with contextlib.suppress(Exception):
            await self.thrusters.zero()
        await self.thrusters.disarm()

    async def apply_thrust(self, fractions: Sequence[float]) -> tuple[float, float]:
        """Set the thrust target and send its first (slew-limited) step now, not at the
        next tick; returns when that frame went out and its reply came back (thrust starts
        in between), as the thruster link timed them."""
        self.set_thrust(fractions)
        assert self.thrusters is not None
        await self.thrusters.command(self.thrust.fractions)
        return self.thrusters.last_bracket

    @property
    def armed(self) -> bool:
        """The thrust target is armed (the supervisor sends it every tick)."""
        return self.thrust.armed

    @property
    def thrust_fractions(self) -> list[float]:
        """The thrust target, fractions of full scale."""
        return self.thrust.fractions

    def set_thrust(self, fractions: Sequence[float]) -> None:
        """Ask for thruster outputs; the supervisor sends them, slew-limited, every tick."""
        values = [float(f) for f in fractions]
        if len(values) != self.thruster_count or not all(math.isfinite(v) for v in values):
            raise ValueError(
                f"thrust: need {self.thruster_count} finite fractions, got {list(fractions)!r}"
            )
        self.thrust = ThrustTarget(values, armed=self.thrust.armed)

    def latest(self) -> Sample | None:
        return self.acquisition.latest if self.acquisition else None
