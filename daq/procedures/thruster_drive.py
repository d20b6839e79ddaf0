"""Thruster-driven tows and spins: one lifecycle (``run_thruster_test``) for both axes.

The drive becomes per-thruster commands through the newest thrust calibration
(``daq.procedures.thrust_commands``); the run is supervised and ended by
``daq.procedures.thruster_faults``. Both modules' public names are re-exported here.
"""

from __future__ import annotations

import asyncio
import logging

from daq.operator import OperatorAct
from daq.procedures.axis_steps import (
    SPIN,
    TOW,
    RunOutcome,
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
from daq.procedures.thrust_commands import (
    latest_calibration,
    law_commands,
    thruster_commands,
)
from daq.procedures.thruster_faults import (
    STALE_ZEROED,
    abort_on_thruster_fault,
    supervised_thrust,
)
from daq.session import RigSession
from daq.store.run_events import RunAction
from daq.vocabulary import DRIVE_FIELD

__all__ = [
    "STALE_ZEROED",
    "abort_on_thruster_fault",
    "latest_calibration",
    "law_commands",
    "run_thruster_spin",
    "run_thruster_test",
    "run_thruster_tow",
    "thruster_commands",
]

log = logging.getLogger(__name__)


async def _supply_now(session: RigSession) -> float | None:
    """The supply voltage read now (None: the rig has no such channel or it cannot be read)."""
    try:
        volts = float(await session.live_plc.read("supply_voltage"))
    except Exception as err:  # a rig without the channel, or a failed read
        log.info("supply voltage not read before the run: %s", err)
        return None
    return volts if volts > 0 else None


async def run_thruster_test(
    session: RigSession,
    params: TowParameters | SpinParameters,
    *,
    abort: AbortSignal | None = None,
    progress: ProgressCallback | None = None,
) -> RunOutcome:
    """Tow or spin the free vehicle with its thrusters; same lifecycle as a weight test.

    No weight is hung (the tow line is unhooked); after the baseline the thrust goes on
    (ramped at the slew limit), the motion is followed to end of travel / distance /
    angle / timeout, then the thrust goes to zero and the brake engages. The thrusters
    end zero and disarmed whatever happens. Every output change the controller confirmed
    is stored as the run's ``thrust_steps`` event, the drive the estimator rebuilds. If
    the thruster link is lost (``LINK_LOST_AFTER`` replies missing in a row) or the
    controller's watchdog zeroes the thrust mid-run, the run is aborted with that reason
    rather than recorded to the end without thrust; a disarm that fails at the end is
    stored as an event and never replaces the reason the run ended.
    """
    abort = abort or AbortSignal()
    report = progress or (lambda p: None)
    rig = session.rig
    tow = isinstance(params, TowParameters)
    axis = TOW if tow else SPIN
    drive = params.load
    unit = DRIVE_FIELD[axis.kind][1]
    calibration = await asyncio.to_thread(latest_calibration, session.store)
    imported = calibration.get("calibration_import_id")
    volts = None
    if imported is None:
        commands, force = thruster_commands(
            drive,
            calibration,
            rig.thruster_port(),
            max_command=rig.limits.max_thruster_command,
            kind=axis.kind,
        )
    else:  # an imported table's law, at the supply voltage measured now
        from daq.calibration_law import law_of

        law, _ = await asyncio.to_thread(law_of, session.store, "imported", imported)
        volts = await _supply_now(session)
        commands, force = law_commands(
            drive, law, volts, rig.thruster_port(), rig.limits.max_thruster_command, axis.kind
        )
    parameters = params.to_json() | {
        "commands": commands,
        "force_per_thruster_n": force,
        "calibration_result_id": calibration["result_id"],
    }
    if imported is not None:
        parameters["calibration_import_id"] = imported
        parameters["supply_voltage_at_start_v"] = volts
    async with session.locked(f"thruster {axis.kind} {drive:.4g} {unit}"):
        op = session.operator
        report(Progress(0.0, "returning the vehicle to the start"))
        await session.safe_state()
        await op.perform(return_act(params, rig))
        if tow:
            await op.perform(
                OperatorAct(
                    "hang_tow_weight", "Remove the weight and unhook the tow line (brake on)", 0.0
                )
            )
        else:
            await op.perform(
                OperatorAct("hang_spin_weight", "Remove any weight from the spin drum", 0.0)
            )
        await op.perform(
            OperatorAct(
                "unmount_thrust_stand", "Make sure the thrusters are free (not on the load cell)"
            )
        )
        start = await check_ready(session, axis, abort)
        check_room(params, start)
        rec = RecordedRun(
            session,
            kind=axis.kind,
            parameters=parameters,
            abort=abort,
            progress=report,
            thruster_telemetry=True,
        )
        try:
            async with rec:
                async with supervised_thrust(session, rec, abort, on_stale_zeroing=True) as armed:
                    await _drive_with_thrusters(
                        session, rec, axis, params, commands, start, report, armed
                    )
                await rec.record_for(0.3)
        except Exception:
            if rec.status is None:  # the run was never stored: nothing to report
                raise
            # Stored as aborted with the error as its reason; the caller gets the outcome.
            log.exception("thruster %s run %s ended by an error", axis.kind, rec.run_id)
        return await run_outcome(session, rec, axis.kind, report)


#: The same lifecycle under the names of the two tests.
run_thruster_spin = run_thruster_test
run_thruster_tow = run_thruster_test


async def _drive_with_thrusters(
    session, rec, axis, params, commands, start, report, armed: asyncio.Event
) -> None:
    await session.live_plc.write(axis.release, True)
    await session.arm_thrusters()
    armed.set()
    await rec.event("operator", f"{axis.release} set: brake released, thrusters armed")
    report(
        Progress(
            0.05, f"recording a {params.baseline_s:g} s baseline", extra={"run_id": rec.run_id}
        )
    )
    await rec.record_for(params.baseline_s)
    before, after = await session.apply_thrust(commands)
    await rec.event(
        "operator",
        f"thrust on: commands {', '.join(f'{c:+.3f}' for c in commands)}",
        action=RunAction.RELEASE,
        t_mono=(before + after) / 2,
        t_half_width=(after - before) / 2,
    )
    stop, sample, t_last_free = await follow_motion(rec, axis, start, params, report)
    session.set_thrust([0.0] * session.thruster_count)
    await session.live_thrusters.zero()
    await engage_and_log_stop(
        rec,
        axis.release,
        f"{stop}: thrust off, brake engaged",
        RunAction.BRAKE,
        sample,
        t_last_free,
    )
