"""Supervision of a thruster-driven run: abort it when the thruster link is lost, the
controller's watchdog trips, a thruster draws more than the current cut-off or stale sensor
data zeroes the thrust; and the ending that zeroes and disarms the thrusters and stores the
outputs the controller confirmed (the drive the estimator rebuilds).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import AsyncIterator
from typing import Any, cast

from daq.procedures.current_cutoff import current_over_limit
from daq.procedures.recording import AbortSignal, RecordedRun
from daq.sample import Quality, Sample
from daq.session import Aborted, RigSession
from daq.store.run_events import RunAction

log = logging.getLogger(__name__)


#: How the reason begins when stale sensor data zeroed a thruster tow's or spin's thrust.
STALE_ZEROED = "sensor data stale or unread"


def _plc_unread(session: RigSession, sample: Sample | None) -> str | None:
    """The PLC's endpoint when ``sample`` could not read it (quality ERROR), else None."""
    if sample is not None and sample.quality & Quality.ERROR and session.plc is not None:
        return session.plc.endpoint
    return None


def _stale_zeroed_reason(session: RigSession) -> str:
    """Why the run ends: which data went stale (the PLC unread, or the stale channels)."""
    cause = session.stale_sample
    if (plc := _plc_unread(session, cause)) is not None:
        what = f"PLC at {plc} unread"
    else:
        what = "stale: " + (", ".join(cause.stale) if cause and cause.stale else "?")
    return (
        f"{STALE_ZEROED} ({what}): the thrusters were zeroed for safety, so the drive is no "
        "longer the one asked for; run the test again"
    )


async def abort_on_thruster_fault(
    session: RigSession,
    rec: RecordedRun,
    abort: AbortSignal,
    armed: asyncio.Event,
    *,
    on_stale_zeroing: bool = False,
) -> None:
    """Once this run has armed the thrusters (a fault left from an earlier run does not
    count), abort it when the thruster link is lost or the controller's watchdog zeroes
    the outputs; the fault, with when thrust was last confirmed, is stored as a ``fault``
    event. ``on_stale_zeroing``: also when stale sensor data zeroes the thrusters (a tow or
    spin, whose drive must stay as asked; a calibration measures the step again instead)."""
    await armed.wait()
    session.stale_zeroed.clear()
    waits: set[asyncio.Future[object]] = {
        asyncio.ensure_future(session.live_thrusters.wait_fault())
    }
    if on_stale_zeroing:
        waits.add(asyncio.ensure_future(session.stale_zeroed.wait()))
    over_current = asyncio.ensure_future(current_over_limit(session))
    waits.add(cast("asyncio.Future[object]", over_current))
    try:
        await asyncio.wait(waits, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for w in waits:
            w.cancel()
    fault = session.live_thrusters.fault
    data: dict[str, Any]
    if over_current.done() and not over_current.cancelled() and fault is None:
        session.set_thrust([0.0] * session.thruster_count)  # at once, before the ending
        reason, data = over_current.result()
    elif fault is None:  # the stale-data zeroing
        reason = _stale_zeroed_reason(session)
        data = {"stale_zeroings": session.stale_zeroings}
    else:
        reason = fault.reason
        if (plc := _plc_unread(session, session.latest())) is not None:
            # Both devices gone at once (the rig's power, the simulator): name the PLC too.
            reason += f"; PLC at {plc} unreadable too"
        data = {"action": RunAction.THRUSTER_FAULT, **fault.to_json()}
    try:  # stored before the abort, so the run's ending cannot cancel it half-way
        await rec.event("fault", reason, **data)
    finally:
        abort.set(reason)


async def end_thrust(
    session: RigSession, rec: RecordedRun, steps: list, supervisor: asyncio.Task
) -> str | None:
    """Zero and disarm the thrusters (best effort) and store the confirmed outputs as
    ``thrust_steps``. Never raises: returns why the thrusters could not be disarmed, so a
    failure here is recorded without replacing the reason the run is already ending."""
    failure = None
    try:
        await session.disarm_thrusters()
    except Exception as err:
        failure = f"thrusters not disarmed at the end of the run: {err}"
        log.error("%s", failure)
    supervisor.cancel()
    with contextlib.suppress(asyncio.CancelledError):
        try:
            await supervisor
        except Exception:
            log.exception("thruster fault supervisor failed")
    with contextlib.suppress(Exception):
        if failure:
            await rec.event("fault", failure, action=RunAction.DISARM_FAILED)
    try:
        await rec.event(
            "thrusters",
            f"thruster outputs changed {len(steps)} times",
            action=RunAction.THRUST_STEPS,
            steps=[step.to_json() for step in steps],
        )
    except Exception as err:
        log.error("thrust_steps not stored: %s", err)
    return failure


@contextlib.asynccontextmanager
async def supervised_thrust(
    session: RigSession, rec: RecordedRun, abort: AbortSignal, *, on_stale_zeroing: bool = False
) -> AsyncIterator[asyncio.Event]:
    """The thrusters under a run's body: the outputs it confirms are recorded, a thruster
    fault aborts it (:func:`abort_on_thruster_fault`, ``on_stale_zeroing`` as there), and
    however the body ends the thrusters are zeroed and disarmed (:func:`end_thrust`); a
    body that ended well but left them armed is aborted with that reason. Yields the event
    the body sets once it has armed them."""
    with session.live_thrusters.recording_outputs() as steps:
        armed = asyncio.Event()
        supervisor = asyncio.create_task(
            abort_on_thruster_fault(session, rec, abort, armed, on_stale_zeroing=on_stale_zeroing)
        )
        try:
            yield armed
        except BaseException:
            await end_thrust(session, rec, steps, supervisor)
            raise
        failure = await end_thrust(session, rec, steps, supervisor)
        if failure:
            raise Aborted(failure)
