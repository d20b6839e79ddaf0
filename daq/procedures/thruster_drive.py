"""Thruster-driven tows and spins: the calibrated inverse map turns a drive into commands.

Surge (tow without a weight): every thruster pushes forward with ``F = F_total / n``.
Yaw (spin): each thruster turns the vehicle with the sign ``ThrusterPort.yaw_signs()``
gives it, at the rig file's ``yaw_lever_arm_m``; a pure torque τ asks every thruster for
``F = τ / (n·L)`` with the sign of its side, so the surge forces cancel. The inverse map
comes from the newest stored thrust calibration; reverse-running thrusters get the
larger reverse command. Both axes share one lifecycle (``run_thruster_test``).

One module because the inverse map, the arming and the supervision of a thruster-driven run
share that run's calibration and driver state.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from typing import TYPE_CHECKING, Any, cast

from daq.operator import OperatorAct
from daq.procedures.current_cutoff import current_over_limit
from daq.procedures.params import ParameterError, Progress
from daq.procedures.recording import AbortSignal, ProgressCallback, RecordedRun
from daq.procedures.requests import SpinRequest as SpinParameters
from daq.procedures.requests import TowRequest as TowParameters
from daq.procedures.steps import (
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
from daq.sample import Quality, Sample
from daq.session import Aborted, RigSession
from daq.store import Store
from daq.store.run_events import RunAction
from daq.vocabulary import DRIVE_FIELD
from thrusters.config import ThrusterPort

if TYPE_CHECKING:
    from estimation.thrust.law import ThrustLaw

log = logging.getLogger(__name__)

#: The drive each run kind's thrusters give: (parameter, unit).


def latest_calibration(store: Store) -> dict[str, Any]:
    """The newest stored thrust calibration (``daq.calibration_catalog.latest``), measured
    (``result_id``) or imported (``calibration_import_id``; its curve and rows at its
    reference voltage, the highest it covers); ParameterError when there is none."""
    from daq.calibration_catalog import latest

    found = latest(store)
    if found is None:
        raise ParameterError(
            [
                (
                    "drive",
                    "thrusters",
                    "a thrust calibration first: run `rig calibrate-thrusters` "
                    "or `rig import-calibration FILE`",
                )
            ]
        )
    data = found["data"]
    if found["source"] == "run":
        return data | {"result_id": found["id"]}
    return {
        "fit": data["fit"],
        "table": data["reference_table"],
        "result_id": None,
        "calibration_import_id": found["id"],
    }


def thrust_layout(thrusters: ThrusterPort, kind: str) -> tuple[list[float], float]:
    """Per-thruster sign and arm (m; 1 for a force) that turn thruster forces into the drive
    of a ``"tow"`` (Σ F) or a ``"spin"`` (Σ sign·F·L)."""
    if kind == "tow":
        return [1.0] * thrusters.count, 1.0
    if kind == "spin":
        return thrusters.yaw_signs(), thrusters.yaw_lever_arm_m
    raise ValueError(f"kind: {kind!r} is not allowed; allowed 'tow' or 'spin'")


def _below_smallest_thrust(
    kind: str,
    drive: float,
    per_thruster: float,
    smallest: float,
    sign: float,
    gain: float,
    advice: str,
    where: str = "",
) -> ParameterError:
    """The refusal of a drive whose thrust per thruster is below the smallest one calibrated
    on that side (the curve below it is a guess inside the dead band). ``gain``: thrusters ×
    arm, from thrust per thruster to the drive."""
    name, unit = DRIVE_FIELD[kind]
    side = "forward" if sign > 0 else "reverse"
    return ParameterError(
        [
            (
                name,
                drive,
                f"|{name}| at least {smallest * gain:.3g} {unit}: {per_thruster:.3g} N per "
                f"thruster is below the smallest calibrated {side} thrust ({smallest:.3g} N"
                f"{where}); {advice}",
            )
        ]
    )


def thruster_commands(
    drive: float,
    calibration: dict[str, Any],
    thrusters: ThrusterPort,
    max_command: float,
    kind: str = "spin",
) -> tuple[list[float], float]:
    """Commands (fractions) giving ``drive`` (N for a tow, N·m for a spin) and the force per
    thruster, N, through the calibration: the fitted curve corrected by the thrusts the
    load cell measured (``CalibratedThrust``, the same the estimator rebuilds the drive
    with). Refuses (ParameterError) below the smallest calibrated thrust and beyond the
    thrusters' reach at ``max_command``."""
    from estimation.thrust.curve import CalibratedThrust, ThrustCurve

    name, unit = DRIVE_FIELD[kind]
    curve = ThrustCurve.from_json(calibration["fit"])
    calibrated = CalibratedThrust.from_table(curve, calibration.get("table", []))
    signs, arm = thrust_layout(thrusters, kind)
    count = thrusters.count
    per_thruster = drive / (count * arm)
    # A negative drive (a reverse test) turns every thruster round: each pushes |F| the
    # other way, and the side it then runs on decides which calibration applies.
    reverse = -1.0 if per_thruster < 0 else 1.0
    size = abs(per_thruster)
    commands = []
    for sign in (s * reverse for s in signs):
        # Below the smallest thrust measured on that side the curve is extrapolated into the
        # dead band, where a small error means no thrust at all: refuse rather than guess.
        measured = [
            abs(r["thrust_per_thruster_n"])
            for r in calibration.get("table", [])
            if r["command"] * sign > 0 and r["thrust_per_thruster_n"] * sign > 0
        ]
        if measured and size < min(measured):
            raise _below_smallest_thrust(
                kind, drive, size, min(measured), sign, count * arm,
                "calibrate with smaller commands (e.g. --commands 0,0.05,0.1,0.2,...)",
            )  # fmt: skip
        try:
            u = calibrated.command_for_force(sign * size)
        except ValueError as err:
            raise ParameterError([(name, drive, f"within the calibrated range: {err}")]) from None
        if abs(u) > max_command:
            reach = min(abs(float(calibrated.force(c))) for c in (max_command, -max_command))
            raise ParameterError(
                [
                    (
                        name,
                        drive,
                        f"allowed up to {reach * count * arm:.3g} {unit} with these thrusters "
                        f"(max_thruster_command {max_command:g})",
                    )
                ]
            )
        commands.append(u)
    return commands, per_thruster


async def _supply_now(session: RigSession) -> float | None:
    """The supply voltage read now (None: the rig has no such channel or it cannot be read)."""
    try:
        volts = float(await session.live_plc.read("supply_voltage"))
    except Exception as err:  # a rig without the channel, or a failed read
        log.info("supply voltage not read before the run: %s", err)
        return None
    return volts if volts > 0 else None


def law_commands(
    drive: float,
    law: ThrustLaw,
    volts: float | None,
    thrusters: ThrusterPort,
    max_command: float,
    kind: str,
) -> tuple[list[float], float]:
    """Commands giving ``drive`` through an identified thrust law at supply ``volts`` (None:
    the law's reference voltage) and the force per thruster, N. Refuses (ParameterError)
    beyond what the thrusters deliver at that voltage within ``max_command``, and below
    the smallest thrust calibrated there (``ThrustLaw.min_force``)."""
    name, unit = DRIVE_FIELD[kind]
    signs, arm = thrust_layout(thrusters, kind)
    count = thrusters.count
    per_thruster = drive / (count * arm)
    reverse = -1.0 if per_thruster < 0 else 1.0  # a reverse test turns every thruster round
    size = abs(per_thruster)
    at = law.reference_voltage if volts is None else volts
    commands = []
    for sign in (s * reverse for s in signs):
        reach = min(abs(law.max_force(at, sign)), abs(float(law.force(sign * max_command, at))))
        if size > reach:
            raise ParameterError(
                [
                    (
                        name,
                        drive,
                        f"allowed up to {reach * count * arm:.3g} {unit} with these thrusters "
                        f"at the supply voltage now ({at:.3g} V; max_thruster_command "
                        f"{max_command:g})",
                    )
                ]
            )
        floor = law.min_force(at, sign)
        if floor is not None and 0 < size < abs(floor):
            raise _below_smallest_thrust(
                kind, drive, size, abs(floor), sign, count * arm, "calibrate smaller commands",
                where=f" at {at:.3g} V, command {law.smallest_command(sign, at):g}",
            )  # fmt: skip
        commands.append(law.command_for_force(sign * size, at).value)
    return commands, per_thruster


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
            session, kind=axis.kind, parameters=parameters, abort=abort, progress=report
        )
        try:
            async with rec:
                with session.live_thrusters.recording_outputs() as steps:
                    armed = asyncio.Event()
                    supervisor = asyncio.create_task(
                        abort_on_thruster_fault(session, rec, abort, armed, on_stale_zeroing=True)
                    )
                    try:
                        await _drive_with_thrusters(
                            session, rec, axis, params, commands, start, report, armed
                        )
                    except BaseException:
                        await _end_thrust(session, rec, steps, supervisor)
                        raise
                    failure = await _end_thrust(session, rec, steps, supervisor)
                    if failure:
                        raise Aborted(failure)
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


async def _end_thrust(
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
