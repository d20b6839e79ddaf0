"""A run being recorded: the store record, the recorder task, the ending.

``RecordedRun`` is the one place that decides how a run ends: ``completed`` when
the body returns, ``aborted`` with the reason when it raises ``Aborted`` (or any
other error), and — whatever happened — the rig is put in its safe state and every
sample the clock produced is flushed before the status is written.

Storage failing (disk full, I/O error) is a fault like a lost PLC: the recorder sets the
abort signal, the run stops safely and ends ``aborted`` with a one-line reason naming
storage; samples the database did not take wait in a spill file (docs/storage.md).
Every sample the clock lost (late, missed, bad: ``daq.sample_losses``) is counted: each
gap is a ``samples_lost`` event, and a hole longer than the kind tolerates aborts the run
with a reason beginning ``samples lost``.
So is losing the lease on the rig's devices (``daq.rig_lock``): the session calls the
run's abort signal with a reason beginning ``rig lock lost``, and that is how the run ends
whatever else failed after the devices were released. A database that refuses the new run
raises :class:`daq.store.faults.StorageFault` (one line) before the run starts (the rig
left safe).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
from collections.abc import AsyncIterator, Callable
from typing import Any

from daq.collector import hold_full_collections
from daq.procedures.params import Progress
from daq.rig_lock import LOCK_LOST
from daq.safe_state import RELEASE_CHANNELS, SafeState
from daq.sample import Quality, Sample
from daq.sample_losses import SAMPLES_LOST, LossTracker, device_side, hole_text, loss_reason
from daq.session import NO_THRUSTERS, Aborted, RigSession
from daq.store import RunRecorder
from daq.store.faults import StorageFault, StorageUnavailable, one_line
from daq.store.run_events import Gap, RunAction
from daq.store.spill import write_back_later
from daq.vocabulary import AXES
from thrusters.driver import ThrusterError

log = logging.getLogger(__name__)

ProgressCallback = Callable[[Progress], None]

#: How the reason of a run aborted because the PLC stopped answering begins.
DEVICE_LOST = "device lost"

#: Clock periods the ending waits for a sample read after the safe state (its last state).
SAFE_SAMPLE_PERIODS = 3

#: How long the ending waits for the PLC to answer again when its safe state failed, s.
SAFE_RETRY_S = 2.0

#: Background write-backs of spill files (a reference keeps each task alive).
_WRITE_BACKS: set[asyncio.Task] = set()


class AbortSignal:
    """Set by an operator (CLI Ctrl-C, API abort) to stop the running procedure."""

    def __init__(self) -> None:
        self._event = asyncio.Event()
        self.reason = ""

    def set(self, reason: str = "operator abort") -> None:
        if not self._event.is_set():
            self.reason = reason
            self._event.set()

    def is_set(self) -> bool:
        return self._event.is_set()

    async def wait(self) -> None:
        await self._event.wait()

    def check(self) -> None:
        """Raise ``Aborted`` if set (a checkpoint)."""
        if self._event.is_set():
            raise Aborted(self.reason)


class RecordedRun:
    """Context manager around one stored run; yields samples to the procedure."""

    def __init__(
        self,
        session: RigSession,
        *,
        kind: str,
        parameters: dict[str, Any],
        abort: AbortSignal,
        progress: ProgressCallback | None = None,
        thruster_telemetry: bool = False,
    ) -> None:
        """``thruster_telemetry``: log each thruster's RPM and current as channels
        (``daq.thruster_supervisor``; a thruster-driven run or a calibration)."""
        self.session = session
        self.kind = kind
        self.parameters = parameters
        self.abort = abort
        self.progress = progress or (lambda p: None)
        self.run_id: str | None = None
        self.status: str | None = None
        self.reason: str | None = None
        self._recorder: RunRecorder | None = None
        self._recorder_task: asyncio.Task | None = None
        self._pump_task: asyncio.Task | None = None
        self._queue: asyncio.Queue[Sample] | None = None
        self._unlisten: Callable[[], None] | None = None
        self._telemetry = contextlib.ExitStack()
        terms = AXES.get(kind)
        #: The longest hole without a good sample this kind tolerates (s; None: any).
        self.loss_tolerance_s = None if terms is None else terms.loss_tolerance_s
        self._position = None if terms is None else terms.position_channel
        self._device_clock = any(c.name == "plc_clock" for c in session.rig.channels)
        self.losses = LossTracker()
        #: Set (the abort reason) once a hole beyond the tolerance ends the run.
        self.lost: str | None = None
        self._lost_since = math.inf  # host time the hole began, s
        if thruster_telemetry and session.telemetry is None:
            raise ThrusterError(NO_THRUSTERS)
        self._thruster_telemetry = thruster_telemetry

    @property
    def store(self):
        return self.session.store

    async def __aenter__(self) -> RecordedRun:
        s = self.session
        assert s.acquisition is not None
        channel_names = [
            c.name for c in s.rig.channels if c.kind in ("input", "holding") and not c.sim_only
        ]
        channel_names += [
            c.name for c in s.rig.channels if c.kind in ("coil", "discrete") and not c.sim_only
        ]
        if self._thruster_telemetry and s.telemetry is not None:
            channel_names += s.telemetry.names
        try:
            # Samples kept aside while storage had failed go back first; a database that
            # still cannot take them is still failing: no run is started on it.
            await asyncio.to_thread(self.store.replay_spills, database_errors=True)
            run_id: str = await asyncio.to_thread(
                self.store.create_run,
                kind=self.kind,
                parameters=self.parameters,
                channel_names=channel_names,
                rig_name=s.rig.rig.name,
                vehicle=s.rig.vehicle.name,
                rig_toml=s.source.rig_toml,
                scenario_toml=s.source.scenario_toml,
                metadata=s.run_metadata,
            )
        except (StorageUnavailable, OSError) as exc:  # no run, no release: one line
            await s.safe_state()
            raise StorageFault(
                f"storage failed: {one_line(exc)}; the run was not started"
            ) from None
        self.run_id = run_id
        # No full garbage collection while the run records (``daq.collector``): one started
        # by another thread holds the GIL the real-time clock needs.
        hold_full_collections(True, self._collections_held_for)
        # Losing the lease on the rig stops the run like a lost PLC (the session makes the
        # rig safe and releases it; the abort signal ends the run naming the lost lock).
        self._unlisten = s.add_fault_listener(self.abort.set)
        await s.note_run(run_id)
        # A storage fault stops the procedure like a lost PLC: the abort signal wakes every
        # wait (samples, operator prompts) and the ending below makes the rig safe.
        self._recorder = RunRecorder(
            self.store,
            run_id,
            flush_interval_s=s.rig.acquisition.flush_interval_s,
            on_fault=self.abort.set,
        )
        self._recorder_task = asyncio.create_task(
            self._recorder.run(), name=f"recorder-{run_id[:8]}"
        )
        if self._thruster_telemetry and s.telemetry is not None:
            self._telemetry.enter_context(s.telemetry.logging())
        # The recorder gets every sample: a queue big enough for a long fault, then drops.
        self._recorder_queue = s.acquisition.subscribe(maxsize=100_000, name="run-recorder")
        self._pump_task = asyncio.create_task(self._pump(self._recorder_queue), name="pump")
        self._queue = s.acquisition.subscribe(maxsize=1000, name="procedure")
        return self

    async def _pump(self, queue: asyncio.Queue[Sample]) -> None:
        assert self._recorder is not None
        while True:
            sample = await queue.get()
            try:
                self._count_loss(sample)
            except Exception:  # counting must never cost the recorder a sample
                log.exception("run %s: counting lost samples failed", self.run_id)
            self._recorder.put(sample)

    def _count_loss(self, sample: Sample) -> None:
        """Feed ``sample`` to the loss count: a gap it closes becomes an event, and a hole
        beyond the kind's tolerance aborts the run (once)."""
        value = sample.channels.get(self._position or "")
        nan = value is not None and math.isnan(value)
        reasons = loss_reason(sample.quality, nan, device_clock=self._device_clock)
        closed = self.losses.feed(sample.seq, sample.t_mono, reasons)
        if closed is not None:
            self._loss_event(closed)
        gap = closed or self.losses.open_gap
        hole = closed.hole_s if closed is not None else self.losses.hole_s(sample.t_mono)
        limit = self.loss_tolerance_s if gap is not None and device_side(gap) else None
        if gap is not None and limit is not None and hole > limit and self.lost is None:
            lost = (
                f"{SAMPLES_LOST}: {gap.count} in {hole_text(hole, limit)} at {gap.at_s:.1f} s "
                f"({gap.reason}); a {self.kind} tolerates at most {limit:g} s"
            )
            acq = self.session.acquisition
            if acq is not None and acq.device_lost.is_set():  # said as a lost device, too
                lost = f"{self._device_lost_reason()}; {lost}"
            self.lost = lost  # this run's ending; the operator's signal stays unset
            self._lost_since = gap.t_first if gap.t_before is None else gap.t_before

    def _fault_meanwhile(self) -> str | None:
        """What a device said went wrong since the hole that ends the run began (an abort
        signal's reason, or the thrusters' link or watchdog fault), if anything: a host
        stall that loses samples also trips the thrusters' watchdog, and that is said."""
        if self.abort.is_set():
            return self.abort.reason
        fault = getattr(self.session.thrusters, "fault", None)
        if fault is not None and fault.t_detected >= self._lost_since:
            return str(fault.reason)
        return None

    def _loss_event(self, gap: Gap) -> None:
        assert self._recorder is not None
        self._recorder.add_event("samples_lost", gap.describe(), gap.event_data())

    @property
    def _collections_held_for(self) -> str:
        """The reason this run holds full garbage collections off (``daq.collector``)."""
        return f"run {self.run_id} recording"

    async def __aexit__(self, exc_type, exc, tb) -> bool:
        try:
            return await self._end_run(exc)
        finally:  # the run is stored (or spilled): full collections may resume
            hold_full_collections(False, self._collections_held_for)

    async def _end_run(self, exc: BaseException | None) -> bool:
        s = self.session
        if exc is None:
            self.status, self.reason = "completed", None
        elif isinstance(exc, Aborted):
            self.status, self.reason = "aborted", exc.reason
            if exc.reason == self.lost and (said := self._fault_meanwhile()) is not None:
                self.reason = f"{said}; {self.lost}"  # the device's own words first
        elif isinstance(exc, asyncio.CancelledError):
            self.status, self.reason = "aborted", self.abort.reason or "cancelled"
        else:
            self.status, self.reason = "aborted", f"error: {one_line(exc)}"
        if s.lease_lost is not None:  # whatever failed after the devices were released
            self.status, self.reason = "aborted", s.lease_lost
        if self._unlisten is not None:
            self._unlisten()
        assert self._recorder is not None
        if self.status != "completed":
            lost = str(self.reason).startswith((DEVICE_LOST, LOCK_LOST)) or self.lost is not None
            fault = lost or self._recorder.fault is not None
            await self.event("fault" if fault else "operator", f"run {self.status}: {self.reason}")
        try:
            await self._end_safe()
        finally:
            self._telemetry.close()  # the thrusters' telemetry stops with the run's end
        assert s.acquisition is not None
        if self._queue is not None:
            s.acquisition.unsubscribe(self._queue)
        # Stop the pump (it never holds a sample across an await) and hand the recorder
        # whatever it had not taken yet; the final flush stores all of it.
        s.acquisition.unsubscribe(self._recorder_queue)
        assert self._pump_task and self._recorder_task
        self._pump_task.cancel()
        while not self._recorder_queue.empty():
            sample = self._recorder_queue.get_nowait()
            self._count_loss(sample)
            self._recorder.put(sample)
        if (open_gap := self.losses.finish()) is not None:  # the run ended in it
            self._loss_event(open_gap)
        # Flush the rest and write the end once (retried; a storage fault makes it
        # ``aborted`` naming storage; unstored samples wait in the spill file).
        self.status, self.reason = await self._recorder.end(self.status, self.reason)
        if self._recorder.spill.path.exists():  # the database did not take everything
            task = asyncio.create_task(write_back_later(self.store, self._recorder.spill.path))
            _WRITE_BACKS.add(task)
            task.add_done_callback(_WRITE_BACKS.discard)
        for task in (self._pump_task, self._recorder_task):
            with contextlib.suppress(BaseException):
                await task
        log.info(
            "run %s %s%s", self.run_id, self.status, f" ({self.reason})" if self.reason else ""
        )
        # Swallow Aborted (it is an ending, recorded above); let real errors propagate.
        return isinstance(exc, Aborted)

    async def _end_safe(self) -> None:
        """Every ending the same way: brakes engaged and thrusters zero, a ``safe`` event
        saying so (or what failed), and one sample read after it, so the run's last state
        shows the brake engaged (at most :data:`SAFE_SAMPLE_PERIODS` clock periods). A safe
        state the PLC did not take (a stall) is made again at its next good read, within
        :data:`SAFE_RETRY_S`."""
        s = self.session
        safe = await s.safe_state()
        if safe is not None and self._unbraked(safe) and await self._plc_answers():
            safe = await s.safe_state()  # the brakes the stalled PLC did not take, now
        done = s.clock.now()
        if safe is None:  # the session made the rig safe itself as it released the devices
            await self.event("safe", "safe state: made as the devices were released")
            return
        await self.event(
            "safe",
            safe.describe(),
            action=RunAction.SAFE_STATE,
            t_mono=done,
            brakes_engaged=list(safe.brakes_engaged),
            thrusters_zero=safe.thrusters_zero,
            errors=list(safe.errors),
        )
        if self._queue is None or not safe.brakes_engaged:
            return
        period = 1.0 / s.rig.acquisition.rate_hz
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(SAFE_SAMPLE_PERIODS * period):
                while (await self._queue.get()).t_mono <= done:
                    pass

    def _unbraked(self, safe: SafeState) -> bool:
        """A brake of the rig the safe state did not engage (its PLC write failed)."""
        rig = self.session.rig
        return any(rig.has(n) and n not in safe.brakes_engaged for n in RELEASE_CHANNELS)

    async def _plc_answers(self) -> bool:
        """Whether the PLC gives a good read within :data:`SAFE_RETRY_S`."""
        if self._queue is None:
            return False
        try:
            async with asyncio.timeout(SAFE_RETRY_S):
                while (await self._queue.get()).quality & Quality.ERROR:
                    pass
        except TimeoutError:
            return False
        return True

    @property
    def samples_stored(self) -> int:
        """Samples of this run the recorder has stored so far."""
        return 0 if self._recorder is None else self._recorder.stats.samples_stored

    async def event(self, kind: str, message: str, **data: Any) -> None:
        """Log an event on this run (operator acts, faults, limit trips), stamped now and
        stored with the recorder's next flush: the procedure never waits on the database."""
        assert self._recorder is not None
        self._recorder.add_event(kind, message, data or None)

    async def samples(self, *, timeout_s: float = 2.0) -> AsyncIterator[Sample]:
        """Samples of this run, checking abort, device loss and the emergency stop."""
        assert self._queue is not None and self.session.acquisition is not None
        acq = self.session.acquisition
        while True:
            if self.session.lease_lost is not None:
                raise Aborted(self.session.lease_lost)
            self.abort.check()
            get = asyncio.ensure_future(self._queue.get())
            stop = asyncio.ensure_future(self.abort.wait())
            done, _ = await asyncio.wait(
                {get, stop}, timeout=timeout_s, return_when=asyncio.FIRST_COMPLETED
            )
            stop.cancel()
            if get not in done:
                get.cancel()
                self.abort.check()
                if acq.device_lost.is_set():
                    raise Aborted(self._device_lost_reason())
                continue
            sample = get.result()
            if self.lost is not None:  # a hole beyond the tolerance (named, device lost too)
                raise Aborted(self.lost)
            if acq.device_lost.is_set():
                raise Aborted(self._device_lost_reason())
            if sample.channels.get("estop", 0.0) and not math.isnan(
                sample.channels.get("estop", 0.0)
            ):
                raise Aborted("emergency stop")
            yield sample

    def _device_lost_reason(self) -> str:
        acq = self.session.acquisition
        plc = self.session.plc
        assert acq is not None and plc is not None
        return (
            f"{DEVICE_LOST}: PLC at {plc.endpoint} unreadable for over "
            f"{acq.device_lost_after_s:g} s"
        )

    async def record_for(self, seconds: float, *, message: str = "") -> list[Sample]:
        """Collect samples for ``seconds`` (baseline, settling) and return them."""
        end = self.session.clock.now() + seconds
        got: list[Sample] = []
        if seconds <= 0:
            return got
        async for sample in self.samples():
            if not sample.quality & Quality.ERROR:
                got.append(sample)
            if sample.t_mono >= end:
                break
        return got
