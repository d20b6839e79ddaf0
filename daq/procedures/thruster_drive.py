"""Thruster-driven spin: the calibrated inverse map turns a torque into commands.

Each thruster turns the vehicle with the sign ``ThrusterPort.yaw_signs()`` gives it,
at the rig file's ``yaw_lever_arm_m``; a pure torque τ asks every thruster for
``F = τ / (n·L)`` with the sign of its side, so the surge forces cancel. The inverse
map comes from the newest stored thrust calibration; reverse-running thrusters get the
larger reverse command.
"""

from __future__ import annotations

import asyncio
import time
from typing import Any

from daq.config import ThrusterPort
from daq.operator import OperatorAct
from daq.procedures.motion import SPIN, RunOutcome, check_ready, follow_motion
from daq.procedures.params import ParameterError, Progress, SpinParameters
from daq.procedures.recording import AbortSignal, ProgressCallback, RecordedRun
from daq.session import RigSession
from daq.store import Store


def latest_calibration(store: Store) -> dict[str, Any]:
    """The newest stored thrust calibration; ParameterError when there is none."""
    newest = store.latest_result("calibration")
    if newest is None:
        raise ParameterError(
            [("drive", "thrusters", "a thrust calibration first: run `rig calibrate-thrusters`")]
        )
    return newest.data | {"result_id": newest.id}


def thruster_commands(
    torque_nm: float, calibration: dict[str, Any], thrusters: ThrusterPort, max_command: float
) -> tuple[list[float], float]:
    """Commands (fractions) giving ``torque_nm`` and the force per thruster, N."""
    from estimation.thrust_curve import ThrustCurve

    curve = ThrustCurve.from_json(calibration["fit"])
    count, lever_arm_m = thrusters.count, thrusters.yaw_lever_arm_m
    per_thruster = torque_nm / (count * lever_arm_m)
    commands = []
    for sign in thrusters.yaw_signs():
        # Below the smallest thrust measured on that side the curve is extrapolated into the
        # dead band, where a small error means no thrust at all: refuse rather than guess.
        measured = [
            abs(r["thrust_per_thruster_n"])
            for r in calibration.get("table", [])
            if r["command"] * sign > 0 and r["thrust_per_thruster_n"] * sign > 0
        ]
        if measured and per_thruster < min(measured):
            side = "forward" if sign > 0 else "reverse"
            raise ParameterError(
                [
                    (
                        "torque_nm",
                        torque_nm,
                        f"at least {min(measured) * count * lever_arm_m:.3g} N·m: "
                        f"{per_thruster:.3g} N per thruster is below the smallest calibrated "
                        f"{side} thrust "
                        f"({min(measured):.3g} N); calibrate with smaller commands "
                        "(e.g. --commands 0,0.05,0.1,0.2,...)",
                    )
                ]
            )
        try:
            u = float(curve.command_for_force(sign * per_thruster))
        except ValueError as err:
            raise ParameterError(
                [("torque_nm", torque_nm, f"within the calibrated range: {err}")]
            ) from None
        if abs(u) > max_command:
            reach = min(abs(float(curve.force(max_command))), abs(float(curve.force(-max_command))))
            raise ParameterError(
                [
                    (
                        "torque_nm",
                        torque_nm,
                        f"allowed up to {reach * count * lever_arm_m:.3g} N·m with these thrusters "
                        f"(max_thruster_command {max_command:g})",
                    )
                ]
            )
        commands.append(u)
    return commands, per_thruster


async def run_thruster_spin(
    session: RigSession,
    params: SpinParameters,
    *,
    abort: AbortSignal | None = None,
    progress: ProgressCallback | None = None,
) -> RunOutcome:
    """Spin the free vehicle with a thruster couple; same lifecycle as a weight spin."""
    abort = abort or AbortSignal()
    report = progress or (lambda p: None)
    rig = session.rig
    calibration = await asyncio.to_thread(latest_calibration, session.store)
    commands, force = thruster_commands(
        params.torque_nm,
        calibration,
        rig.thrusters,
        max_command=rig.limits.max_thruster_command,
    )
    parameters = params.to_json() | {
        "commands": commands,
        "force_per_thruster_n": force,
        "calibration_result_id": calibration["result_id"],
    }
    async with session.locked(f"thruster spin {params.torque_nm:.4g} N·m"):
        op = session.operator
        report(Progress(0.0, "returning the vehicle to zero yaw"))
        await session.safe_state()
        await op.perform(
            OperatorAct("return_carriage", "Return the vehicle to zero yaw and let it settle")
        )
        await op.perform(
            OperatorAct("hang_spin_weight", "Remove any weight from the spin drum", 0.0)
        )
        await op.perform(
            OperatorAct(
                "unmount_thrust_stand", "Make sure the thrusters are free (not on the load cell)"
            )
        )
        start = await check_ready(session, SPIN, abort)
        rec = RecordedRun(session, kind="spin", parameters=parameters, abort=abort, progress=report)
        async with rec:
            try:
                await _spin_with_thrusters(session, rec, params, commands, start, report)
            finally:
                await session.disarm_thrusters()
            await rec.record_for(0.3)
        count = await asyncio.to_thread(session.store.sample_count, rec.run_id)
        report(Progress(1.0, f"run {rec.status}", state=rec.status or ""))
        assert rec.run_id and rec.status
        return RunOutcome(rec.run_id, rec.status, rec.reason, "spin", count)


async def _spin_with_thrusters(session, rec, params, commands, start, report) -> None:
    rig = session.rig
    await session.plc.write("spin_release", True)
    await session.arm_thrusters()
    await rec.event("operator", "spin brake released, thrusters armed")
    report(
        Progress(
            0.05, f"recording a {params.baseline_s:g} s baseline", extra={"run_id": rec.run_id}
        )
    )
    await rec.record_for(params.baseline_s)
    before = await session.apply_thrust(commands)
    after = time.monotonic()
    await rec.event(
        "operator",
        f"thrust on: commands {', '.join(f'{c:+.3f}' for c in commands)}",
        action="release",
        t_mono=(before + after) / 2,
        t_half_width=(after - before) / 2,
    )
    stop, sample, t_last_free = await follow_motion(
        rec, SPIN, start, params.max_angle_rad, params.max_time_s, report
    )
    session.set_thrust([0.0] * rig.thrusters.count)
    await session.thrusters.zero()
    await session.plc.write("spin_release", False)
    await rec.event(
        "limit",
        f"{stop}: thrust off, brake engaged",
        action="brake",
        seq=sample.seq,
        t_mono=time.monotonic(),
        t_last_free=t_last_free,
    )
