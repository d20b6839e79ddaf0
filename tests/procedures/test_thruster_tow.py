"""Thruster-driven tow on the simulated rig (in process, simulated time): the calibrated
inverse map turns a surge force into commands; the thrusters end zero and disarmed however
the run ends."""

from __future__ import annotations

import asyncio

import numpy as np
import pytest

from daq.procedures.motion import run_motion_test
from daq.procedures.params import ParameterError
from daq.procedures.recording import AbortSignal
from daq.procedures.requests import calibration_parameters, tow_parameters
from daq.procedures.thrust_calibration import run_thrust_calibration
from daq.procedures.thruster_drive import STALE_ZEROED
from daq.run_data import load_run_data
from daq.sim.scenario import ThrusterModel
from estimation.thrust.curve import CalibratedThrust, ThrustCurve
from tests.procedures.conftest import QUICK_CALIBRATION, until_thrust_on
from tests.support.channel_readings import good
from thrusters.driver import LINK_LOST_AFTER

pytestmark = pytest.mark.simtime


async def _calibrate(session) -> dict:
    params = calibration_parameters(
        QUICK_CALIBRATION,
        session.rig,
    )
    outcome, calibration = await run_thrust_calibration(session, params)
    assert outcome.status == "completed"
    return calibration


async def _assert_thrusters_safe(session) -> None:
    assert session.thrusters.state == "DISARMED"
    assert session.sim.thrusters.outputs == [0.0] * session.rig.thrusters.count
    assert await session.plc.read("tow_release") == 0


async def test_thruster_tow_from_the_inverse_map_and_abort(session, store):
    with pytest.raises(ParameterError, match="calibrate-thrusters"):
        await run_motion_test(
            session, tow_parameters({"force_n": 20.0, "drive": "thrusters"}, session.rig)
        )
    calibration = await _calibrate(session)
    # Below the smallest calibrated thrust (command 0.1) the curve would be extrapolated.
    smallest = (
        min(r["thrust_per_thruster_n"] for r in calibration["table"] if r["command"] > 0)
        * session.rig.thrusters.count
    )
    with pytest.raises(ParameterError, match=r"force_n: .*below the smallest calibrated"):
        await run_motion_test(
            session,
            tow_parameters({"force_n": 0.8 * smallest, "drive": "thrusters"}, session.rig),
        )
    # Beyond what the thrusters give within the calibrated commands.
    with pytest.raises(ParameterError, match=r"force_n: 99\.0 is not allowed \(within the"):
        await run_motion_test(
            session, tow_parameters({"force_n": 99.0, "drive": "thrusters"}, session.rig)
        )
    await _assert_thrusters_safe(session)

    params = tow_parameters(
        {"force_n": 20.0, "drive": "thrusters", "max_time_s": 2.5, "baseline_s": 0.3},
        session.rig,
    )
    assert params.hung_mass_kg is None and params.force_n == 20.0
    outcome = await run_motion_test(session, params)
    assert outcome.status == "completed" and outcome.kind == "tow"
    run = store.get_run(outcome.run_id)
    assert run.parameters["drive"] == "thrusters"
    assert run.parameters["calibration_result_id"] == calibration["result_id"]
    curve = ThrustCurve.from_json(calibration["fit"])
    calibrated = CalibratedThrust.from_table(curve, calibration["table"])
    commands = run.parameters["commands"]
    assert len(commands) == session.rig.thrusters.count
    for u in commands:  # all push forward, each giving F/n as the load cell measured it
        assert u > 0
        assert float(calibrated.force(u)) == pytest.approx(10.0, rel=1e-6)
    assert await session.plc.read("sim_tow_weight") == 0  # no weight hung
    x = good(store.samples(outcome.run_id).channels["tow_position"])
    assert x[-1] > 0.2
    # The run keeps every output change the controller confirmed: the ramp up at the slew
    # limit (≤ 2.0/s × 0.1 s a step) to the commands, then zero, each bracketed in time.
    (steps,) = [
        e.data["steps"]
        for e in store.events(outcome.run_id)
        if (e.data or {}).get("action") == "thrust_steps"
    ]
    levels = [fractions[0] for _, _, fractions in steps]
    assert levels[-1] == 0.0 and max(levels) == pytest.approx(commands[0], abs=1e-3)
    assert all(b - a <= 0.2 + 1e-9 for a, b in zip([0.0, *levels[:-2]], levels[:-1], strict=True))
    assert all(0 <= acked - sent < 0.5 for sent, acked, _ in steps)
    await _assert_thrusters_safe(session)
    await _abort_leaves_the_thrusters_zero(session)
    await _watchdog_trip_aborts_the_run(session, store)
    await _silent_controller_aborts_the_run(session, store)
    await _lost_poll_zeroes_the_thrust_and_ends_the_run(session, store)

    # The estimator's view: the force from the calibration, ramping at the slew limit,
    # no pulley inertia (line unhooked), and drawn drives around it.
    data = load_run_data(store, outcome.run_id)
    assert data.axis == "surge" and data.drive_inertia == 0.0 and data.hung_mass_kg is None
    # The thrust lag the drive is rebuilt with is the one the calibration measured from its
    # step responses: the simulated controller's τ within 10 %.
    response = calibration["response"]
    assert response["time_constant_s"] == pytest.approx(ThrusterModel().time_constant_s, rel=0.1)
    assert response["std_s"] < 0.1 * response["time_constant_s"]
    assert "thrust lag τ = " in data.drive_law and "measured by the calibration" in data.drive_law
    # Once ramp and thrust lag (simulator: 0.15 s) are over: the force the inverse map aimed
    # at, to the command's per-mille resolution on the wire.
    # Within two standard deviations of the drive's own uncertainty (calibration and supply
    # readings: about 0.5 % here), not a fixed 0.3 %, which a run's voltage noise can exceed.
    after = (data.t > data.t_release + 1.5) & (data.t < data.t_end - 0.05)
    sigma = data.drive_draws[:, after].std(axis=0)
    assert np.all(np.abs(data.drive[after] - 20.0) < 2 * sigma), (data.drive[after], sigma)
    assert sigma.max() < 0.01 * 20.0
    # The thrust went off at the brake: the recorded outputs say so, the lag decays it.
    assert data.drive[-1] < 0.1 * data.drive[after][-1]
    assert 0 < data.drive[(data.t > data.t_release)][0] < 10.0  # still ramping up
    # No thrust before the first output was sent. A sample's drive is its mean over the
    # interval to the next sample, and the release instant is the middle of the first
    # send's bracket: every interval ending 3σ of it before the release holds zero.
    ends = np.append(data.t[1:], np.inf)
    assert data.drive[ends < data.t_release - 3 * data.t_release_std].max() == 0.0
    assert data.drive_draws is not None and data.drive_draws.shape[1] == data.t.size
    spread = data.drive_draws[:, after].std(axis=0)
    assert 0 < spread.max() < 0.2 * 20.0


async def _abort_leaves_the_thrusters_zero(session) -> None:
    abort = AbortSignal()
    params = tow_parameters(
        {"force_n": 15.0, "drive": "thrusters", "max_time_s": 30, "baseline_s": 0.3},
        session.rig,
    )
    task = await _thrust_on(session, params, abort)
    abort.set("operator abort (test)")
    outcome = await asyncio.wait_for(task, 5)
    assert outcome.status == "aborted"
    await _assert_thrusters_safe(session)


async def _thrust_on(session, params, abort: AbortSignal | None = None) -> asyncio.Task:
    """The motion run started in a task, once its thrust is on."""
    task = asyncio.create_task(run_motion_test(session, params, abort=abort))
    await until_thrust_on(session, timeout_s=5)
    return task


def _thrust_steps(store, run_id) -> list:
    (steps,) = [
        e.data["steps"]
        for e in store.events(run_id)
        if (e.data or {}).get("action") == "thrust_steps"
    ]
    return steps


async def _watchdog_trip_aborts_the_run(session, store) -> None:
    """The host stalls (its event loop blocked) for longer than the controller's watchdog:
    the thrust went to zero, so the run ends aborted with that reason, not recorded on
    without thrust."""
    params = tow_parameters(
        {"force_n": 15.0, "drive": "thrusters", "max_time_s": 30, "baseline_s": 0.3},
        session.rig,
    )
    task = await _thrust_on(session, params)
    emulator = session.sim.thrusters
    # The host's loop is blocked for a second (no heartbeats go out): simulated time moves
    # on without it, and the controller's watchdog trips before the loop runs again.
    session.clock.stall(1.0)
    outcome = await asyncio.wait_for(task, 5)
    assert outcome.status == "aborted"
    assert "watchdog tripped" in outcome.reason
    assert emulator.stats.watchdog_trips == 1
    await _assert_thrusters_safe(session)
    # The stored outputs end with the watchdog's zero, bracketed by the last ACK before it.
    sent, acked, fractions = _thrust_steps(store, outcome.run_id)[-1]
    assert fractions == [0.0] * session.rig.thrusters.count
    assert acked - sent >= emulator.watchdog_s


async def _silent_controller_aborts_the_run(session, store) -> None:
    """The controller stops answering: after LINK_LOST_AFTER missing replies the host
    declares the link lost, aborts with that reason and stores when thrust was last
    confirmed; the controller's own watchdog zeroes the outputs it can no longer hear."""
    params = tow_parameters(
        {"force_n": 15.0, "drive": "thrusters", "max_time_s": 30, "baseline_s": 0.3},
        session.rig,
    )
    task = await _thrust_on(session, params)
    emulator = session.sim.thrusters
    session.sim.call(lambda sim: setattr(sim.thrusters, "silent", True))
    muted = session.clock.now()
    outcome = await asyncio.wait_for(task, 10)
    session.sim.call(lambda sim: setattr(sim.thrusters, "silent", False))
    assert outcome.status == "aborted"
    assert outcome.reason.startswith(
        f"thruster link lost: {LINK_LOST_AFTER} consecutive replies missing "
        "(no reply within ack_timeout_s); thrust last confirmed"
    )
    assert emulator.stats.watchdog_trips >= 1 and emulator.outputs == [0.0, 0.0]
    (fault,) = [
        e.data
        for e in store.events(outcome.run_id)
        if (e.data or {}).get("action") == "thruster_fault"
    ]
    assert fault["fault"] == "link_lost"
    # The controller could not be disarmed either: stored, without replacing the reason.
    (disarm,) = [
        e for e in store.events(outcome.run_id) if (e.data or {}).get("action") == "disarm_failed"
    ]
    assert disarm.message.startswith("thrusters not disarmed at the end of the run: disarm:")
    assert muted - 0.2 < fault["t_thrust_confirmed"] <= muted + 0.1  # the last ACK before it
    assert fault["t_detected"] - muted < 0.5
    assert any(fault["confirmed_outputs"])
    assert _thrust_steps(store, outcome.run_id)  # the ramp the controller did confirm
    await session.disarm_thrusters()  # the link is back: the next run can go
    await _assert_thrusters_safe(session)


async def _lost_poll_zeroes_the_thrust_and_ends_the_run(session, store) -> None:
    """One PLC poll lost while the thrust is on: the session zeroes the thrusters (safety),
    and the run ends aborted saying so, rather than recording on at zero thrust as if the
    drive were the one asked for. The samples up to then are kept."""
    params = tow_parameters(
        {"force_n": 15.0, "drive": "thrusters", "max_time_s": 30, "baseline_s": 0.3},
        session.rig,
    )
    zeroings = session.stale_zeroings
    task = await _thrust_on(session, params)
    session.sim.call(lambda s: setattr(s.plc.faults, "drop_next", 1))
    outcome = await asyncio.wait_for(task, 10)
    assert session.stale_zeroings == zeroings + 1
    assert outcome.status == "aborted"
    assert outcome.reason.startswith(f"{STALE_ZEROED} (PLC at tcp "), outcome.reason
    assert "thrusters were zeroed for safety" in outcome.reason
    faults = [e.kind for e in store.events(outcome.run_id) if e.message == outcome.reason]
    assert faults == ["fault"]
    assert store.sample_count(outcome.run_id) > 0
    await _assert_thrusters_safe(session)
