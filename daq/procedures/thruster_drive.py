"""Thruster-driven spin: the calibrated inverse map turns a torque into commands.

Thrusters with an even index (0, 2, …) turn the vehicle positive about the
vertical axis and odd ones negative, each at the rig file's ``yaw_lever_arm_m``;
a pure torque τ asks every thruster for ``F = τ / (n·L)`` with the sign of its
side, so the surge forces cancel. The inverse map comes from the newest stored
thrust calibration; reverse-running thrusters get the larger reverse command.
"""

from __future__ import annotations

import asyncio
import time
from typing import Any

from daq.operator import OperatorAct
from daq.procedures.motion import SPIN, RunOutcome, _check_ready
from daq.procedures.params import ParameterError, Progress, SpinParameters
from daq.procedures.recording import AbortSignal, ProgressCallback, RecordedRun
from daq.sample import Quality
from daq.session import RigSession
from daq.store import Store


def yaw_signs(count: int) -> list[float]:
    """+1 for thrusters that turn the vehicle positive (even index), −1 for the others."""
    return [1.0 if i % 2 == 0 else -1.0 for i in range(count)]


def latest_calibration(store: Store) -> dict[str, Any]:
    """The newest stored thrust calibration; ParameterError when there is none."""
    found = store.results(kind="calibration")
    if not found:
        raise ParameterError(
            [("drive", "thrusters", "a thrust calibration first: run `rig calibrate-thrusters`")]
        )
    newest = max(found, key=lambda r: r.created_at)
    return newest.data | {"result_id": newest.id}


def thruster_commands(
    torque_nm: float,
    calibration: dict[str, Any],
    *,
    count: int,
    lever_arm_m: float,
    max_command: float,
) -> tuple[list[float], float]:
    """Commands (fractions) giving ``torque_nm`` and the force per thruster, N."""
    from estimation.thrust_curve import ThrustCurve

    curve = ThrustCurve.from_json(calibration["fit"])
    per_thruster = torque_nm / (count * lever_arm_m)
    commands = []
    for sign in yaw_signs(count):
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
        count=rig.thrusters.count,
        lever_arm_m=rig.thrusters.yaw_lever_arm_m,
        max_command=rig.limits.max_thruster_command,
    )
    parameters = params.to_json() | {
        "commands": commands,
        "force_per_thruster_n": force,
        "yaw_lever_arm_m": rig.thrusters.yaw_lever_arm_m,
        "calibration_result_id": calibration["result_id"],
        "calibration_run_id": calibration["run_id"],
        "slew_per_s": rig.limits.max_command_slew_per_s,
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
        start = await _check_ready(session, SPIN, abort)
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
    t0 = None
    async for sample in rec.samples():
        if sample.quality & Quality.ERROR:
            continue
        t0 = t0 if t0 is not None else sample.t_mono
        elapsed = sample.t_mono - t0
        turned = abs(sample.channels["yaw_angle"] - start)
        done = max(elapsed / params.max_time_s, turned / params.max_angle_rad)
        report(Progress(0.05 + 0.9 * min(done, 1.0), f"spin: {turned:.2f} rad in {elapsed:.1f} s"))
        if turned >= params.max_angle_rad:
            stop = f"max angle {params.max_angle_rad:g} rad"
        elif elapsed >= params.max_time_s:
            stop = f"max time {params.max_time_s:g} s"
        else:
            continue
        session.set_thrust([0.0] * rig.thrusters.count)
        await session.thrusters.zero()
        await session.plc.write("spin_release", False)
        await rec.event(
            "limit",
            f"{stop}: thrust off, brake engaged",
            action="brake",
            t_mono=time.monotonic(),
            t_last_free=sample.t_mono,
        )
        return
