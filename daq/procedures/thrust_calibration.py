"""Thrust calibration: thrusters bolted to the load cell, command stepped over a
sweep (up and back down, to expose hysteresis; then the same in reverse).

At each step: command, wait for the thrust to settle, average N load-cell samples,
log the supply voltage and ask the controller for each thruster's RPM and motor current
(as a thrust stand logs them: electrical power P = V·I and efficiency |F|/P follow). The
whole time series is stored as a run; the table and the fitted curve (with its inverse
map) are stored as a ``calibration`` result.
"""

from __future__ import annotations

import asyncio
import logging
import math
import statistics
from collections.abc import Callable
from typing import Any

from daq.operator import OperatorAct
from daq.procedures.axis_steps import RunOutcome
from daq.procedures.params import Progress
from daq.procedures.recording import AbortSignal, ProgressCallback, RecordedRun
from daq.procedures.requests import CalibrationRequest as CalibrationParameters
from daq.procedures.thruster_faults import abort_on_thruster_fault
from daq.session import RigSession
from daq.store.run_events import RunAction, RunEvents
from estimation.thrust.calibration_import import efficiency_n_per_w
from estimation.thrust.curve import fit_thrust_curve
from estimation.thrust.response import largest_transient, measure_response_time
from thrusters.driver import ThrusterStatus

log = logging.getLogger(__name__)


def _mean_std(values: list[float]) -> tuple[float, float]:
    finite = [v for v in values if math.isfinite(v)]
    if not finite:
        return math.nan, math.nan
    return statistics.fmean(finite), statistics.stdev(finite) if len(finite) > 1 else 0.0


async def run_thrust_calibration(
    session: RigSession,
    params: CalibrationParameters,
    *,
    abort: AbortSignal | None = None,
    progress: ProgressCallback | None = None,
) -> tuple[RunOutcome, dict[str, Any] | None]:
    """Run the sweep; returns the run outcome and the stored calibration (or None if aborted)."""
    abort = abort or AbortSignal()
    report = progress or (lambda p: None)
    table: list[dict[str, Any]] = []
    tare = 0.0
    async with session.locked("thrust calibration"):
        await session.safe_state()
        await session.operator.perform(
            OperatorAct("mount_thrust_stand", "Bolt the thrusters to the load cell")
        )
        rec = RecordedRun(
            session,
            kind="thrust_calibration",
            parameters=params.to_json(),
            abort=abort,
            progress=report,
            thruster_telemetry=True,
        )
        armed = asyncio.Event()
        supervisor = asyncio.create_task(abort_on_thruster_fault(session, rec, abort, armed))
        try:
            async with rec:
                report(
                    Progress(
                        0.0,
                        f"taring the load cell ({params.tare_samples} samples)",
                        extra={"run_id": rec.run_id},
                    )
                )
                await session.arm_thrusters()
                armed.set()
                await rec.event("operator", "thrusters armed")
                table, tare = await _sweep(rec, session, params, abort, report)
        finally:
            supervisor.cancel()
            try:
                await session.disarm_thrusters()
            except Exception as err:  # the run is stored; its reason stays what it was
                log.error("thrusters not disarmed after the calibration: %s", err)
            await session.operator.perform(
                OperatorAct("unmount_thrust_stand", "Unbolt the thrusters from the load cell")
            )
        assert rec.run_id and rec.status
        calibration = None
        if rec.status == "completed":
            calibration = await asyncio.to_thread(
                _store_calibration, session, rec.run_id, table, tare
            )
        count = await asyncio.to_thread(session.store.sample_count, rec.run_id)
        report(Progress(1.0, f"calibration {rec.status}", state=rec.status))
        return RunOutcome(
            rec.run_id, rec.status, rec.reason, "thrust_calibration", count
        ), calibration


async def _sweep(
    rec: RecordedRun,
    session: RigSession,
    params: CalibrationParameters,
    abort: AbortSignal,
    report: ProgressCallback,
) -> tuple[list[dict[str, Any]], float]:
    """Tare the load cell, then step through the sweep (each step's row: thrust, supply,
    telemetry); the outputs the controller confirmed are stored as ``thrust_steps`` (the
    step responses the thrust lag is measured from). Returns the table and the tare, N."""
    n = session.rig.thruster_port().count
    sweep = params.sweep
    table: list[dict[str, Any]] = []
    tare_samples = await _collect(rec, params.tare_samples)
    tare, tare_std = _mean_std([s.channels["load_cell"] for s in tare_samples])
    await rec.event("info", f"load cell tare {tare:.3f} N (σ {tare_std:.3f} N)", tare_n=tare)
    with session.live_thrusters.recording_outputs() as steps:
        previous = 0.0
        for i, command in enumerate(sweep):
            abort.check()
            # +1 while the command rises, −1 while it falls (hysteresis), 0 when held.
            sweep_sign = (command > previous) - (command < previous)
            direction = {1: "up", -1: "down", 0: "hold"}[sweep_sign]
            previous = command
            report(
                Progress(
                    0.05 + 0.9 * i / len(sweep),
                    f"step {i + 1}/{len(sweep)}: command {command:+.2f}",
                )
            )
            got = await _measure_step(rec, session, params, i, [command] * n)
            thrust, thrust_std = _mean_std([s.channels["load_cell"] - tare for s in got])
            volts = (  # None: the rig has no supply-voltage channel
                _mean_std([s.channels["supply_voltage"] for s in got])[0]
                if session.rig.has("supply_voltage")
                else None
            )
            row = {
                "step": i,
                "command": command,
                "direction": direction,
                "sweep_sign": sweep_sign,
                "thrust_n": thrust,
                "thrust_std_n": thrust_std,
                "thrust_per_thruster_n": thrust / n,
                "supply_voltage_v": volts,
                "samples": len(got),
                "seq_first": got[0].seq if got else None,
                "seq_last": got[-1].seq if got else None,
            } | stand_reading(await session.live_thrusters.query(), thrust / n, volts)
            table.append(row)
            await rec.event(
                "info",
                f"step {i}: command {command:+.3f} → {thrust:+.3f} N"
                + (f" at {volts:.2f} V" if volts is not None else ""),
                **row,
            )
        session.set_thrust([0.0] * n)
        await rec.event(
            "thrusters",
            f"thruster outputs changed {len(steps)} times",
            action=RunAction.THRUST_STEPS,
            steps=[step.to_json() for step in steps],
        )
    return table, tare


#: A confirmed output within this of the command is the command (the protocol's ‰ step).
CONFIRM_TOLERANCE = 0.0011
#: Longest wait for the controller to confirm a step, s (the slew takes < 1 s per step).
CONFIRM_TIMEOUT_S = 10.0
#: Tries of one step when stale sensor data zeroes the thrusters during it.
STEP_ATTEMPTS = 3


class _ZeroedForSafety(Exception):
    """Stale or unread sensor data zeroed the thrusters during this step (session policy)."""


async def _measure_step(
    rec: RecordedRun,
    session: RigSession,
    params: CalibrationParameters,
    step: int,
    target: list[float],
) -> list:
    """Apply ``target``, wait for it to be confirmed and settle, and collect the step's
    samples. Stale sensor data zeroes the thrusters (``RigSession._supervise_thrusters``):
    samples spanning that are not this step's thrust, so the step is tried again once the
    data is good, up to ``STEP_ATTEMPTS`` times, each zeroing stored as a ``fault`` event."""
    for attempt in range(1, STEP_ATTEMPTS + 1):
        await _until_data_good(rec, session)
        zeroings = session.stale_zeroings
        session.set_thrust(target)
        try:
            await _until_confirmed(rec, session, target, zeroings)
            await rec.record_for(params.settle_s)
            got = await _collect(rec, params.samples_per_step)
            if session.stale_zeroings != zeroings:
                raise _ZeroedForSafety
            return got
        except _ZeroedForSafety:
            await rec.event(
                "fault",
                f"step {step}: sensor data stale or unread, the thrusters were zeroed for "
                f"safety (try {attempt} of {STEP_ATTEMPTS}); its samples are not used",
                step=step,
                attempt=attempt,
            )
    raise RuntimeError(
        f"step {step} (command {target}): sensor data went stale during each of "
        f"{STEP_ATTEMPTS} tries and the thrusters were zeroed for safety each time; check "
        "the PLC link and the host's load, then calibrate again"
    )


async def _record_until(
    rec: RecordedRun, done: Callable[[], bool], timed_out: Callable[[], str]
) -> None:
    """Record until ``done()``; RuntimeError(``timed_out()``) after ``CONFIRM_TIMEOUT_S``."""
    deadline = rec.session.clock.now() + CONFIRM_TIMEOUT_S
    while not done():
        if rec.session.clock.now() > deadline:
            raise RuntimeError(timed_out())
        await rec.record_for(0.05)


async def _until_data_good(rec: RecordedRun, session: RigSession) -> None:
    """Record until the thrusters are no longer held at zero for stale sensor data."""
    await _record_until(
        rec,
        lambda: session.live_thrusters.inhibited is None,
        lambda: (
            f"sensor data stayed stale or unread for {CONFIRM_TIMEOUT_S:g} s: the "
            "thrusters are held at zero"
        ),
    )


async def _until_confirmed(
    rec: RecordedRun, session: RigSession, target: list[float], zeroings: int
) -> None:
    """Record until the controller confirms ``target``: the settling time counts from the
    thrust actually applied, not from the request, even when a loaded host sends the ramp
    late. A step never confirmed is a fault of the run (the calibration would be wrong);
    one zeroed for stale data (``zeroings`` changed) raises ``_ZeroedForSafety``."""
    thrusters = session.live_thrusters

    def confirmed() -> bool:
        if session.stale_zeroings != zeroings:
            raise _ZeroedForSafety
        return all(
            abs(a - b) <= CONFIRM_TOLERANCE
            for a, b in zip(thrusters.confirmed, target, strict=True)
        )

    await _record_until(
        rec,
        confirmed,
        lambda: (
            f"thrusters did not confirm command {target} within {CONFIRM_TIMEOUT_S:g} s "
            f"(confirmed {list(thrusters.confirmed)})"
        ),
    )


async def _collect(rec: RecordedRun, count: int) -> list:
    got = []
    async for sample in rec.samples():
        got.append(sample)
        if len(got) >= count:
            break
    return got


def stand_reading(status: ThrusterStatus, thrust_n: float, volts: float | None) -> dict:
    """A step's RPM and motor current per thruster (the controller's telemetry, read once
    the thrust settled) and their means, with the electrical power per thruster P = V·I (W)
    and the efficiency |F|/P (N/W) when the supply voltage is known."""
    row: dict[str, Any] = {
        "rpm_per_thruster": list(status.rpm),
        "current_per_thruster_a": list(status.current_a),
        "rpm": statistics.fmean(status.rpm) if status.rpm else None,
        "current_a": statistics.fmean(status.current_a) if status.current_a else None,
    }
    if volts is not None and row["current_a"] is not None:
        row["power_w"] = volts * row["current_a"]
        efficiency = efficiency_n_per_w(row | {"thrust_per_thruster_n": thrust_n})
        if efficiency is not None:
            row["efficiency_n_per_w"] = efficiency
    return row


def _store_calibration(session: RigSession, run_id: str, table: list[dict], tare_n: float) -> dict:
    """Fit the thrust curve (per thruster), measure the thrust lag from the run's step
    responses (``estimation.thrust.response``), and store table + fit + response as a
    result."""

    store = session.store
    commands = [r["command"] for r in table]
    thrust = [r["thrust_per_thruster_n"] for r in table]
    fit = fit_thrust_curve(commands, thrust, [float(r["sweep_sign"]) for r in table])
    events = RunEvents.of(store.events(run_id))
    samples = store.samples(run_id)
    response = None
    if events.thrust_steps and "load_cell" in samples.channels:
        steps = [(s.t_mono, list(s.fractions)) for s in events.thrust_steps]
        load = samples.channels["load_cell"] - tare_n
        measured = measure_response_time(fit, steps, samples.t_mono, load)
        if measured is not None:
            tau = measured.time_constant_s
            example = largest_transient(fit, steps, samples.t_mono, load, tau)
            response = measured.to_json() | {"largest_step": example}
    data = {
        "run_id": run_id,
        "thrusters": session.rig.thruster_port().count,
        "table": table,
        "fit": fit.to_json(),
        "response": response,
    }
    data["result_id"] = store.add_result([run_id], "calibration", data)
    return data
