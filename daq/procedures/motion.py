"""Tow and spin tests: one lifecycle on two axes.

Return the carriage (or yaw) to zero, hang the weight, check the vehicle is at
rest and the path clear, record a pre-trigger baseline, release the brake, record
until end of travel / distance / angle / timeout, brake, and mark the run.
"""

from __future__ import annotations

import logging

from daq.operator import OperatorAct
from daq.procedures.axis_steps import (
    SPIN,
    TOW,
    PreconditionFailed,
    RunOutcome,
    baseline_then_release,
    check_ready,
    check_room,
    engage_and_log_stop,
    follow_motion,
    return_act,
    run_outcome,
)
from daq.procedures.params import Progress
from daq.procedures.recording import AbortSignal, ProgressCallback, RecordedRun
from daq.procedures.requests import SpinRequest as SpinParameters
from daq.procedures.requests import TowRequest as TowParameters
from daq.procedures.thruster_drive import run_thruster_test
from daq.session import Aborted, RigSession
from daq.store.run_events import RunAction

log = logging.getLogger(__name__)


async def run_motion_test(
    session: RigSession,
    params: TowParameters | SpinParameters,
    *,
    abort: AbortSignal | None = None,
    progress: ProgressCallback | None = None,
) -> RunOutcome:
    """Run one tow or spin test under the rig lock; see the module docstring."""
    abort = abort or AbortSignal()
    report = progress or (lambda p: None)
    axis = TOW if isinstance(params, TowParameters) else SPIN
    if params.drive == "thrusters":
        return await run_thruster_test(session, params, abort=abort, progress=progress)
    async with session.locked(f"{axis.kind} {params.load:.4g} {params.load_unit}"):
        op = session.operator
        report(Progress(0.0, "returning the vehicle to the start"))
        await session.safe_state()
        await op.perform(return_act(params, session.rig))
        mass = params.hung_mass_kg or 0.0
        report(Progress(0.02, f"hanging {mass:.3f} kg"))
        await op.perform(_hang_act(axis, mass, params.reverse))
        start = await check_ready(session, axis, abort)
        check_room(params, start)
        rec = RecordedRun(
            session, kind=axis.kind, parameters=params.to_json(), abort=abort, progress=report
        )
        async with rec:
            await rec.event(
                "operator", f"{axis.weight_act.replace('_', ' ')}: {mass:.3f} kg", hung_mass_kg=mass
            )
            await baseline_then_release(session, rec, params.baseline_s, axis.release, report)
            stop, sample, t_last_free = await follow_motion(rec, axis, start, params, report)
            await engage_and_log_stop(
                rec, axis.release, f"{stop}: brake engaged", RunAction.BRAKE, sample, t_last_free
            )
            # A short tail after the brake shows the stop in the data.
            await rec.record_for(0.3)
        return await run_outcome(session, rec, axis.kind, report)


def _hang_act(axis, mass: float, reverse: bool) -> OperatorAct:
    """Hang the weight; a reverse test rigs it the other way first (far-end pulley, or the
    cord wound the other way round the drum)."""
    if axis is TOW:
        where = "the tow line led over the far-end pulley" if reverse else "the tow line"
    else:
        where = (
            "the spin-drum cord wound the other way round the drum"
            if reverse
            else "the spin-drum cord"
        )
    return OperatorAct(axis.weight_act, f"Hang {mass:.3f} kg on {where} (brake on)", mass, reverse)


__all__ = ["Aborted", "PreconditionFailed", "RunOutcome", "run_motion_test"]
