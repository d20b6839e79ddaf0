"""Tow and spin tests end to end: simulated rig → Modbus → clock → store."""

from __future__ import annotations

import asyncio

import numpy as np
import pytest

from daq.operator import OperatorAct, PromptOperator
from daq.procedures.axis_steps import PreconditionFailed
from daq.procedures.motion import run_motion_test
from daq.procedures.recording import AbortSignal
from daq.procedures.requests import spin_parameters, tow_parameters
from daq.run_data import load_run_data
from daq.session import RigBusy, RigSource
from daq.store import Store
from tests.procedures.conftest import short_rail
from tests.support.channel_readings import good
from tests.support.progress_log import ProgressLog
from tests.support.simrig import rig_session
from tests.support.waiting import next_samples, until

pytestmark = pytest.mark.simtime


async def test_tow_records_release_motion_and_brake(session, store):
    params = tow_parameters({"force_n": 44.1, "max_time_s": 2.5, "baseline_s": 0.5}, session.rig)
    progress = []
    outcome = await run_motion_test(session, params, progress=progress.append)

    assert outcome.status == "completed" and outcome.reason is None
    run = store.get_run(outcome.run_id)
    assert run.status == "completed" and run.parameters["hung_mass_kg"] == pytest.approx(4.5)
    table = store.samples(outcome.run_id)
    assert len(table) == outcome.samples >= 25
    seq = table.seq
    assert np.all(np.diff(seq) >= 1)  # one sample per clock slot, in order
    x = table.channels["tow_position"]
    assert x[0] == pytest.approx(0.0, abs=1e-3)  # at rest during the baseline
    assert x[-1] > 0.5  # 44.1 N moves the vehicle well over half a metre in 2.5 s
    actions = [e.data.get("action") for e in store.events(outcome.run_id) if e.data]
    assert actions.index("release") < actions.index("brake")
    # The procedure leaves the brake engaged and the carriage stops.
    assert await session.plc.read("tow_release") == 0
    settle = round(0.3 * session.acquisition.rate_hz)  # 0.3 s of clock ticks, then 0.3 s still
    ticks = await next_samples(session.acquisition, 2 * settle + 1)
    still = [s.channels["tow_position"] for s in ticks[settle:]]
    assert still == pytest.approx([still[0]] * len(still), abs=1e-4)
    assert progress[-1].fraction == 1.0 and progress[-1].state == "completed"
    # The estimator's view: release after the baseline, positions from the PLC clock.
    data = load_run_data(store, outcome.run_id)
    assert data.axis == "surge" and data.hung_mass_kg == pytest.approx(4.5)
    assert data.t[0] < data.t_release < data.t[-1]
    assert data.t_end is not None and data.t_release < data.t_end


async def test_tow_stops_at_end_of_travel(source, store):
    short = RigSource(rig=short_rail(source.rig), rig_toml=source.rig_toml)
    async with rig_session(short, store) as session:
        params = tow_parameters({"force_n": 83.3, "max_time_s": 10, "baseline_s": 0.3}, session.rig)
        outcome = await run_motion_test(session, params)
    assert outcome.status == "completed"
    brake = [e for e in store.events(outcome.run_id) if e.data and e.data.get("action") == "brake"]
    assert brake and brake[0].message.startswith("end of travel")
    x = good(store.samples(outcome.run_id).channels["tow_position"])
    assert x.max() == pytest.approx(0.5, abs=0.02)  # stopped by the switch, not by time


async def test_spin_records_yaw(session, store):
    params = spin_parameters(
        {"torque_nm": 2.269, "max_time_s": 2.0, "baseline_s": 0.3}, session.rig
    )
    outcome = await run_motion_test(session, params)
    assert outcome.status == "completed"
    run = store.get_run(outcome.run_id)
    assert run.kind == "spin" and run.parameters["hung_mass_kg"] == pytest.approx(2.5, rel=1e-3)
    yaw = good(store.samples(outcome.run_id).channels["yaw_angle"])
    assert yaw[-1] > 0.2
    assert await session.plc.read("spin_release") == 0


async def test_abort_ends_run_aborted_with_samples_kept(session, store):
    abort = AbortSignal()
    params = tow_parameters({"force_n": 24.5, "max_time_s": 30, "baseline_s": 0.3}, session.rig)
    progress = ProgressLog()
    task = asyncio.create_task(run_motion_test(session, params, abort=abort, progress=progress))
    await progress.wait(
        lambda p: p.message.startswith("tow:"), "10 samples moving", times=10, task=task
    )
    abort.set("operator abort (test)")
    outcome = await asyncio.wait_for(task, 5)
    assert outcome.status == "aborted" and outcome.reason == "operator abort (test)"
    assert store.get_run(outcome.run_id).status == "aborted"
    assert store.sample_count(outcome.run_id) >= 10
    assert await session.plc.read("tow_release") == 0
    # Every ending the same way: the safe state is an event, and the run's last stored
    # sample (read after it) shows the brake engaged.
    (safe,) = [e for e in store.events(outcome.run_id) if e.kind == "safe"]
    assert safe.message.startswith("safe state: brake engaged (tow_release")
    assert safe.data["action"] == "safe_state" and not safe.data["errors"]
    last = store.last_sample(outcome.run_id)
    assert last is not None and last.channels["tow_release"] == 0
    assert last.t_mono > safe.data["t_mono"]


async def test_second_procedure_while_busy_is_refused(session):
    params = tow_parameters({"force_n": 24.5, "max_time_s": 2, "baseline_s": 0.2}, session.rig)
    progress = ProgressLog()
    task = asyncio.create_task(run_motion_test(session, params, progress=progress))
    await progress.wait(lambda p: True, "the first tow starting", task=task)
    with pytest.raises(RigBusy, match=r"tow 24\.5 N"):
        await run_motion_test(session, params)
    assert (await task).status == "completed"


async def test_stale_sensor_data_zeroes_armed_thrusters_at_once(session):
    await session.plc.write("sim_thrust_stand", True)
    await session.arm_thrusters()
    session.set_thrust([0.4, 0.4])
    emulator = session.sim.thrusters
    await until(lambda: emulator.outputs == [0.4, 0.4], "the thrust at 0.4", timeout_s=3)
    session.sim.plc.faults.drop = True  # the PLC stops answering
    # the first unread tick (≤ 0.1 s + read timeout) zeroes them
    await until(lambda: emulator.outputs == [0.0, 0.0], "the thrust zeroed", timeout_s=0.5)
    assert emulator.state == "ARMED"  # zeroed by our driver, not by the controller's watchdog
    assert session.stale_zeroings == 1


async def test_a_tow_is_stored_the_same_on_sqlite_and_postgresql(db_url, source):
    with Store(db_url) as store:
        async with rig_session(source, store) as session:
            params = tow_parameters(
                {"force_n": 44.1, "max_time_s": 1.5, "baseline_s": 0.3}, session.rig
            )
            outcome = await run_motion_test(session, params)
        assert outcome.status == "completed"
        assert store.get_run(outcome.run_id).status == "completed"
        assert store.sample_count(outcome.run_id) == outcome.samples >= 15
        data = load_run_data(store, outcome.run_id)
        assert data.position[-1] > 0.1 and data.t_release_std < 0.01


async def test_a_tow_is_refused_while_its_end_switch_is_tripped(source, store):
    """The end switch of the tow's axis (``AxisTerms.end_switch``) still tripped at the start
    (the carriage left where the last tow stopped it) refuses the tow, recording nothing."""
    short = RigSource(rig=short_rail(source.rig), rig_toml=source.rig_toml)
    async with rig_session(short, store) as session:
        params = tow_parameters({"force_n": 83.3, "max_time_s": 10, "baseline_s": 0.3}, session.rig)
        assert (await run_motion_test(session, params)).status == "completed"  # to the switch
        played = session.operator

        async def left_on_the_switch(act: OperatorAct) -> None:
            if act.name != "return_carriage":  # the operator does not return the carriage
                await played.perform(act)

        session._operator = PromptOperator(left_on_the_switch)
        with pytest.raises(PreconditionFailed, match="the end-of-travel switch is tripped"):
            await run_motion_test(session, params)
    assert len(store.list_runs()) == 1  # the first tow's only
