"""The session's thruster supervisor, and the thrusters' telemetry as sample channels.

The supervisor (``supervise_thrusters``) runs every clock tick: while armed it re-sends the
thrust target as the controller's heartbeat; while a thruster-driven run or a calibration
records (``ThrusterTelemetry.logging``) it then asks the controller for each thruster's
propeller speed (rpm) and motor current (A) (the ``STA`` reply; the line carries no
temperature, ``docs/thruster-protocol.md``). The acquisition clock adds the latest answer
to every sample as ``thruster<i>_rpm`` and ``thruster<i>_current``: logged, stored and
exported with the PLC's channels at the sampling rate. A value is at most one tick older
than the sample that carries it; an answer older than ``MAX_AGE_PERIODS`` ticks (or a
failed query) is NaN, never a repeated old value. Outside such a run samples carry no
telemetry channels.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Protocol

from daq.device_protocols import Thrusters
from daq.sample import Quality, Sample
from daq.vocabulary import thruster_telemetry_channels
from thrusters.driver import ThrusterDriver, ThrusterError, ThrusterStatus

if TYPE_CHECKING:
    from daq.acquisition import Acquisition

log = logging.getLogger(__name__)

#: Clock periods after which the telemetry reads NaN in samples: it is queried once per
#: tick, so one answer missed is ridden out and two are not.
MAX_AGE_PERIODS = 2.5


class ThrusterTelemetry:
    """The latest telemetry of ``count`` thrusters on ``clock``, queried once per tick of a
    clock at ``rate_hz``; answers older than ``MAX_AGE_PERIODS`` ticks read as NaN."""

    def __init__(self, count: int, rate_hz: float, clock: Callable[[], float]) -> None:
        self.count = count
        self.max_age_s = MAX_AGE_PERIODS / rate_hz
        self.clock = clock
        self.names = thruster_telemetry_channels(count)
        self._latest: ThrusterStatus | None = None
        self._loggers = 0
        #: Queries that failed while logging (each leaves the channels NaN).
        self.failed_queries = 0

    @property
    def wanted(self) -> bool:
        """True while some run logs the telemetry."""
        return self._loggers > 0

    @contextlib.contextmanager
    def logging(self) -> Iterator[list[str]]:
        """Log the telemetry into samples while the block runs; yields the channel names."""
        self._loggers += 1
        try:
            yield self.names
        finally:
            self._loggers -= 1
            if not self._loggers:
                self._latest = None

    async def poll(self, thrusters: Thrusters) -> None:
        """Ask the controller for its telemetry now (a failed query leaves it unread)."""
        try:
            status = await thrusters.query()
        except ThrusterError as err:
            self.failed_queries += 1
            log.debug("thruster telemetry not read: %s", err)
            self._latest = None
            return
        self._latest = status

    def fresh(self) -> ThrusterStatus | None:
        """The latest answer while a run logs the telemetry and it is not older than
        ``max_age_s``, else None."""
        status = self._latest
        if not self._loggers or status is None or self.clock() - status.t_mono > self.max_age_s:
            return None
        return status

    def channels(self) -> dict[str, float]:
        """The channels to add to the sample read now ({} while no run logs them)."""
        if not self._loggers:
            return {}
        status = self.fresh()
        if status is None or len(status.rpm) != self.count:
            return dict.fromkeys(self.names, math.nan)
        return dict(zip(self.names, (*status.rpm, *status.current_a), strict=True))


class SupervisedSession(Protocol):
    """What the supervisor needs of a ``daq.session.RigSession``."""

    acquisition: Acquisition | None
    thrusters: ThrusterDriver | None
    telemetry: ThrusterTelemetry | None
    stale_zeroings: int
    stale_sample: Sample | None
    stale_zeroed: asyncio.Event

    @property
    def armed(self) -> bool: ...  # the thrust target is armed

    @property
    def thrust_fractions(self) -> list[float]: ...  # the thrust target

    def set_thrust(self, fractions: list[float]) -> None: ...

    @property
    def thruster_count(self) -> int: ...


async def supervise_thrusters(session: SupervisedSession) -> None:
    """Every clock tick: while armed, re-send the (slew-limited) thrust target as the
    controller's heartbeat, zero at once while the sample is stale or unread; while a run
    logs the telemetry, query it (``ThrusterTelemetry.poll``)."""
    acquisition, thrusters = session.acquisition, session.thrusters
    assert acquisition is not None and thrusters is not None
    queue: asyncio.Queue[Sample] = acquisition.subscribe(maxsize=4, name="thruster-supervisor")
    try:
        while True:
            sample = await queue.get()
            if session.armed:
                await _heartbeat(session, thrusters, sample)
            if session.telemetry is not None and session.telemetry.wanted:
                await session.telemetry.poll(thrusters)
    finally:
        acquisition.unsubscribe(queue)


async def _heartbeat(session: SupervisedSession, thrusters: ThrusterDriver, sample: Sample) -> None:
    """Re-send the thrust target (zero, held, while ``sample`` is stale or unread)."""
    stale = bool(sample.quality & (Quality.STALE | Quality.ERROR))
    try:
        if stale and thrusters.inhibited is None:
            session.stale_zeroings += 1
            session.stale_sample = sample
            session.stale_zeroed.set()
            session.set_thrust([0.0] * session.thruster_count)
        # Stale sensors: zero at once (no ramp) and hold until data is good again.
        await thrusters.zero_on_stale(stale, reason="sensor data stale or unread")
        await thrusters.command(session.thrust_fractions)
    except Exception as err:
        log.warning("thruster heartbeat failed: %s", err)
