"""Manual thrust on the stand: one thruster held at a command for a bounded time, recorded
as a run of its own (load cell, supply voltage, each thruster's RPM and current).

A dead-man: the thruster goes back to zero when the time is up, and the ending every
thruster-driven run has (``daq.procedures.thruster_faults``) zeroes and disarms the
thrusters on abort, emergency stop, a lost link, a watchdog trip or a current over the
cut-off; the run's own ending (``daq.procedures.recording``) engages the brake. The thrust
stand is where the thrust is measured, so the brake stays on throughout.
"""

from __future__ import annotations

import asyncio
import logging

from daq.operator import OperatorAct
from daq.procedures.axis_steps import RunOutcome, run_outcome
from daq.procedures.params import Progress
from daq.procedures.recording import AbortSignal, ProgressCallback, RecordedRun
from daq.procedures.requests import ManualThrustRequest
from daq.procedures.thruster_faults import supervised_thrust
from daq.session import RigSession
from daq.store.run_events import RunAction

log = logging.getLogger(__name__)

#: How often the job's progress says how long the thrust still lasts, s.
PROGRESS_EVERY_S = 0.5
#: Recorded after the thrust went off, s: the propeller running down on the load cell.
TAIL_S = 0.3


async def run_manual_thrust(
    session: RigSession,
    params: ManualThrustRequest,
    *,
    abort: AbortSignal | None = None,
    progress: ProgressCallback | None = None,
) -> RunOutcome:
    """Hold thruster ``params.thruster`` at ``params.command`` for ``params.duration_s``
    under the rig lock; the thrusters end zero and disarmed and the brake engaged however
    the run ends (completed when the time is up, else aborted with the reason)."""
    abort = abort or AbortSignal()
    report = progress or (lambda p: None)
    kind = str(params.kind)
    async with session.locked(f"manual thrust: thruster {params.thruster}"):
        await session.safe_state()
        await session.operator.perform(
            OperatorAct("mount_thrust_stand", "Make sure the thrusters are bolted to the load cell")
        )
        rec = RecordedRun(
            session,
            kind=kind,
            parameters=params.to_json(),
            abort=abort,
            progress=report,
            thruster_telemetry=True,
        )
        try:
            async with rec:
                report(Progress(0.0, "arming the thrusters", extra={"run_id": rec.run_id}))
                async with supervised_thrust(session, rec, abort) as armed:
                    await _hold(session, rec, params, report, armed)
                await rec.record_for(TAIL_S)
        except Exception:
            if rec.status is None:  # the run was never stored: nothing to report
                raise
            log.exception("manual thrust run %s ended by an error", rec.run_id)
        return await run_outcome(session, rec, kind, report)


async def _hold(
    session: RigSession,
    rec: RecordedRun,
    params: ManualThrustRequest,
    report: ProgressCallback,
    armed: asyncio.Event,
) -> None:
    """Arm, put the command on (slew-limited), hold it for the duration, take it off."""
    n = session.thruster_count
    await session.arm_thrusters()
    armed.set()
    before, after = await session.apply_thrust(params.commands(n))
    await rec.event(
        "operator",
        f"thrust on: thruster {params.thruster} at {params.command:+.3f} "
        f"for {params.duration_s:g} s",
        action=RunAction.RELEASE,
        t_mono=(before + after) / 2,
        t_half_width=(after - before) / 2,
    )
    end = session.clock.now() + params.duration_s
    while (left := end - session.clock.now()) > 0:
        report(
            Progress(
                1.0 - left / params.duration_s,
                f"thruster {params.thruster} at {params.command:+.3f}: {left:.1f} s left",
            )
        )
        await rec.record_for(min(PROGRESS_EVERY_S, left))
    session.set_thrust([0.0] * n)
    await session.live_thrusters.zero()
    await rec.event("operator", f"time up after {params.duration_s:g} s: thrust off")
