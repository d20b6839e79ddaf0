"""Thrust calibration on the simulated load cell, then a thruster-driven spin using it (in
process, simulated time)."""

from __future__ import annotations

import asyncio

import numpy as np
import pytest

from daq.procedures.motion import run_motion_test
from daq.procedures.params import ParameterError
from daq.procedures.requests import calibration_parameters, spin_parameters
from daq.procedures.thrust_calibration import run_thrust_calibration
from daq.sample import Quality
from tests.procedures.conftest import until_thrust_on
from tests.support.channel_readings import good
from tests.support.waiting import until
from thrusters.driver import LINK_LOST_AFTER

pytestmark = pytest.mark.simtime


@pytest.mark.slow
async def test_calibration_then_thruster_spin(session, store):
    params = calibration_parameters(
        {
            "commands": [0.0, 0.1, 0.2, 0.4, 0.8],
            "settle_s": 0.6,
            "samples_per_step": 3,
            "tare_samples": 5,
        },
        session.rig,
    )
    # No calibration yet: a thruster spin is refused before anything moves.
    with pytest.raises(ParameterError, match="calibrate-thrusters"):
        await run_motion_test(
            session, spin_parameters({"torque_nm": 1.0, "drive": "thrusters"}, session.rig)
        )

    outcome, calibration = await run_thrust_calibration(session, params)
    assert outcome.status == "completed"
    table = calibration["table"]
    assert [r["command"] for r in table] == params.sweep
    by_command: dict[float, list[float]] = {}
    for row in table:
        by_command.setdefault(row["command"], []).append(row["thrust_per_thruster_n"])
    forward = [sum(by_command[c]) / len(by_command[c]) for c in (0.1, 0.2, 0.4, 0.8)]
    reverse = [sum(by_command[-c]) / len(by_command[-c]) for c in (0.1, 0.2, 0.4, 0.8)]
    assert forward == sorted(forward) and forward[0] > 0
    assert reverse == sorted(reverse, reverse=True) and reverse[0] < 0
    ratio = -reverse[-1] / forward[-1]
    assert ratio == pytest.approx(0.78, abs=0.06)  # the simulated thrusters' asymmetry
    assert abs(sum(by_command[0.0]) / len(by_command[0.0])) < 0.3  # tared load cell
    assert all(r["supply_voltage_v"] > 10 for r in table)
    stored = store.results(outcome.run_id, kind="calibration")
    assert stored and stored[0].data["fit"]["rmse_n"] < 1.0
    assert session.thrusters.state == "DISARMED"
    assert await session.plc.read("sim_thrust_stand") == 0  # unmounted again

    # Below the smallest calibrated thrust the curve would be extrapolated into the dead band.
    with pytest.raises(ParameterError, match="below the smallest calibrated"):
        await run_motion_test(
            session, spin_parameters({"torque_nm": 0.3, "drive": "thrusters"}, session.rig)
        )
    spin = spin_parameters(
        {"torque_nm": 2.0, "drive": "thrusters", "max_time_s": 2.0, "baseline_s": 0.3}, session.rig
    )
    result = await run_motion_test(session, spin)
    assert result.status == "completed"
    run = store.get_run(result.run_id)
    commands = run.parameters["commands"]
    assert commands[0] > 0 > commands[1] and abs(commands[1]) > commands[0]  # reverse needs more
    yaw = good(store.samples(result.run_id).channels["yaw_angle"])
    assert yaw[-1] > 0.1
    assert session.thrusters.state == "DISARMED"
    assert session.sim.thrusters.outputs == [0.0, 0.0]
    assert await session.plc.read("spin_release") == 0
    # The estimator's view: torque from the calibration, ramping at the slew limit.
    from daq.run_data import load_run_data

    data = load_run_data(store, result.run_id)
    after = (data.t > data.t_release + 1.0) & (data.t < data.t_end - 0.05)
    assert data.drive[after] == pytest.approx(2.0, rel=0.02)
    # No thrust before the first output was sent. A sample's drive is its mean over the
    # interval to the next sample, and the release instant is the middle of the first
    # send's bracket: every interval ending 3σ of it before the release holds zero.
    ends = np.append(data.t[1:], np.inf)
    assert data.drive[ends < data.t_release - 3 * data.t_release_std].max() == 0.0


async def test_controller_silent_mid_calibration_aborts_it_and_the_thrust_ends(session, store):
    """The thruster link supervision covers the calibration too: the controller stops
    answering mid-sweep, the run ends aborted naming the lost link, nothing is fitted, and
    the controller's outputs are zero by its own watchdog (it hears nothing, the host's zero
    included), all in simulated time: each unanswered frame costs the reply timeout."""
    params = calibration_parameters(
        {
            "commands": [0.0, 0.2, 0.4, 0.6],
            "settle_s": 2.0,
            "samples_per_step": 3,
            "tare_samples": 5,
        },
        session.rig,
    )
    task = asyncio.create_task(run_thrust_calibration(session, params))
    await until_thrust_on(session, timeout_s=10)
    emulator = session.sim.thrusters
    emulator.silent = True
    muted = session.clock.now()
    outcome, calibration = await asyncio.wait_for(task, 10)
    assert emulator.outputs == [0.0, 0.0] and emulator.stats.watchdog_trips == 1
    emulator.silent = False
    assert outcome.status == "aborted" and calibration is None
    assert outcome.reason.startswith(f"thruster link lost: {LINK_LOST_AFTER} consecutive replies")
    assert store.get_run(outcome.run_id).reason == outcome.reason
    # Seen within one heartbeat (10 Hz) and LINK_LOST_AFTER reply timeouts of simulated
    # time (thrusters/driver.py, LINK_LOST_AFTER): the loop ran on while replies were awaited.
    (fault,) = [e.data for e in store.events(outcome.run_id) if e.kind == "fault"]
    bound = 0.1 + LINK_LOST_AFTER * session.rig.thrusters.ack_timeout_s
    assert 0 < fault["t_detected"] - muted <= bound + 1e-9
    # Waiting for replies never held up the clock: no slot skipped, none late.
    seqs = store.samples(outcome.run_id).seq
    assert list(seqs) == list(range(seqs[0], seqs[0] + len(seqs)))
    assert not any(store.samples(outcome.run_id).quality & Quality.OVERRUN)


@pytest.mark.slow
async def test_stale_data_mid_step_zeroes_the_thrust_and_the_step_is_measured_again(session, store):
    """One PLC poll is lost while a calibration step's thrust is on: the session zeroes
    the thrusters (safety), that step's samples are not used, and once the data is good the
    step is applied and measured again; the zeroing is stored as a fault event."""
    params = calibration_parameters(
        {
            "commands": [0.0, 0.1, 0.2, 0.3, 0.4],  # the fit needs 4 points each way
            "settle_s": 0.5,
            "samples_per_step": 3,
            "tare_samples": 5,
        },
        session.rig,
    )
    task = asyncio.create_task(run_thrust_calibration(session, params))
    emulator = session.sim.thrusters
    await until(lambda: emulator.outputs == [0.4, 0.4] or task.done(), "the top step confirmed")
    session.sim.call(lambda s: setattr(s.plc.faults, "drop_next", 1))
    await until(lambda: session.stale_zeroings == 1, "the stale-data zeroing")
    outcome, calibration = await asyncio.wait_for(task, 60)
    assert outcome.status == "completed", outcome.reason
    rows = [r for r in calibration["table"] if r["command"] == 0.4]
    assert len(rows) == 1
    # measured with the thrust on, not the zeroed interval: as large as the reverse step's
    reverse = next(r for r in calibration["table"] if r["command"] == -0.4)
    assert rows[0]["thrust_per_thruster_n"] > 0.5 * abs(reverse["thrust_per_thruster_n"]) > 0
    faults = [e for e in store.events(outcome.run_id) if "zeroed for safety" in e.message]
    assert len(faults) == 1 and faults[0].kind == "fault"
