"""Reverse tests on the simulated rig over Modbus: a negative force or torque moves the
vehicle the other way, rigged by the operator (far-end pulley, cord wound the other way)
or driven by the thrusters turned round."""

from __future__ import annotations

import numpy as np
import pytest

from daq.operator import OperatorAct, PromptOperator
from daq.procedures.axis_steps import PreconditionFailed
from daq.procedures.motion import run_motion_test
from daq.procedures.params import ParameterError
from daq.procedures.requests import calibration_parameters, spin_parameters, tow_parameters
from daq.procedures.thrust_calibration import run_thrust_calibration
from daq.run_data import load_run_data
from tests.procedures.conftest import QUICK_CALIBRATION
from tests.support.channel_readings import good

pytestmark = pytest.mark.simtime


async def test_reverse_tow_starts_at_the_far_end_and_moves_back(session, store):
    params = tow_parameters({"force_n": -24.5, "max_time_s": 2.5, "baseline_s": 0.3}, session.rig)
    assert params.reverse and params.force_n == pytest.approx(-24.5)
    assert params.hung_mass_kg == pytest.approx(2.5)  # the weight itself is positive
    far = session.rig.geometry.reverse_start
    assert params.max_distance_m == pytest.approx(session.rig.geometry.reverse_travel)
    outcome = await run_motion_test(session, params)
    assert outcome.status == "completed", outcome
    x = good(store.samples(outcome.run_id).channels["tow_position"])
    assert x[0] == pytest.approx(far, abs=1e-3)  # pushed to the far end, at rest
    assert x[-1] < far - 0.3  # pulled back toward the start
    assert await session.plc.read("sim_tow_reversed") == 1  # over the far-end pulley
    data = load_run_data(store, outcome.run_id)
    assert data.drive == pytest.approx(-24.5)
    assert data.t_release < data.t_end
    assert np.all(np.diff(data.position[data.t > data.t_release + 0.3]) <= 1e-4)

    # The next forward tow is rigged the normal way again (returning the carriage does it).
    forward = tow_parameters({"force_n": 24.5, "max_time_s": 2.5, "baseline_s": 0.3}, session.rig)
    outcome = await run_motion_test(session, forward)
    x = good(store.samples(outcome.run_id).channels["tow_position"])
    assert x[0] == pytest.approx(0.0, abs=1e-3) and x[-1] > 0.2
    assert await session.plc.read("sim_tow_reversed") == 0


async def test_reverse_spin_turns_the_vehicle_negative(session, store):
    params = spin_parameters(
        {"torque_nm": -0.907, "max_time_s": 2.0, "baseline_s": 0.3}, session.rig
    )
    assert params.reverse and params.hung_mass_kg == pytest.approx(0.999)
    outcome = await run_motion_test(session, params)
    assert outcome.status == "completed", outcome
    yaw = good(store.samples(outcome.run_id).channels["yaw_angle"])
    assert yaw[0] == pytest.approx(0.0, abs=1e-3) and yaw[-1] < -0.2
    assert await session.plc.read("sim_spin_reversed") == 1
    assert load_run_data(store, outcome.run_id).drive == pytest.approx(params.torque_nm)


async def test_reverse_rigging_is_asked_of_the_operator(session):
    acts: list[OperatorAct] = []
    played = session.operator

    async def ask(act: OperatorAct) -> None:
        acts.append(act)
        await played.perform(act)  # the simulated rig still needs the act done

    session._operator = PromptOperator(ask)
    params = tow_parameters({"weight_kg": -1.0, "max_time_s": 1.0, "baseline_s": 0.2}, session.rig)
    assert params.force_n == pytest.approx(-session.rig.rig.g)
    await run_motion_test(session, params)
    back, hang = acts[0], acts[1]
    assert back.name == "return_carriage" and "far end" in back.instruction
    assert back.value == pytest.approx(session.rig.geometry.reverse_start)
    assert hang.name == "hang_tow_weight" and hang.reverse and hang.value == pytest.approx(1.0)
    assert "far-end pulley" in hang.instruction

    acts.clear()
    spin = spin_parameters({"torque_nm": -0.5, "max_time_s": 0.5, "baseline_s": 0.2}, session.rig)
    await run_motion_test(session, spin)
    assert "wound the other way" in acts[1].instruction and acts[1].reverse


async def test_reverse_tow_refused_when_the_carriage_has_no_room(session, store):
    async def stay_at_start(act: OperatorAct) -> None:
        if act.name == "return_carriage":  # the operator leaves the carriage at 0 m
            act = OperatorAct("return_carriage", act.instruction)
        await played.perform(act)

    played = session.operator
    session._operator = PromptOperator(stay_at_start)
    params = tow_parameters({"force_n": -24.5, "max_time_s": 1.0}, session.rig)
    with pytest.raises(PreconditionFailed, match=r"carriage is at 0\.000 m: a reverse tow"):
        await run_motion_test(session, params)
    assert store.list_runs() == []  # nothing recorded


async def test_reverse_thruster_tow_turns_the_thrusters_round(session, store):
    cal_params = calibration_parameters(QUICK_CALIBRATION, session.rig)
    outcome, _ = await run_thrust_calibration(session, cal_params)
    assert outcome.status == "completed"
    params = tow_parameters(
        {"force_n": -15.0, "drive": "thrusters", "max_time_s": 2.0, "baseline_s": 0.3},
        session.rig,
    )
    outcome = await run_motion_test(session, params)
    assert outcome.status == "completed", outcome
    run = store.get_run(outcome.run_id)
    assert all(u < 0 for u in run.parameters["commands"])
    assert run.parameters["force_per_thruster_n"] == pytest.approx(-7.5)
    x = good(store.samples(outcome.run_id).channels["tow_position"])
    far = session.rig.geometry.reverse_start
    assert x[0] == pytest.approx(far, abs=1e-3) and x[-1] < far - 0.1
    assert session.sim.thrusters.outputs == [0.0] * session.rig.thrusters.count
    data = load_run_data(store, outcome.run_id)
    after = data.drive[data.t > data.t_release + 1.0]  # rebuilt from the thrust steps
    assert np.all(after < 0) and np.median(after) == pytest.approx(-15.0, rel=0.1)

    # A reverse thruster spin: every thruster turns the other way from a forward spin's.
    spin = spin_parameters(
        {"torque_nm": -2.0, "drive": "thrusters", "max_time_s": 2.0, "baseline_s": 0.3},
        session.rig,
    )
    outcome = await run_motion_test(session, spin)
    assert outcome.status == "completed", outcome
    commands = store.get_run(outcome.run_id).parameters["commands"]
    signs = session.rig.thrusters.yaw_signs()
    assert all(u * s < 0 for u, s in zip(commands, signs, strict=True))
    yaw = good(store.samples(outcome.run_id).channels["yaw_angle"])
    assert yaw[0] == pytest.approx(0.0, abs=1e-3) and yaw[-1] < -0.05


@pytest.mark.parametrize(
    ("raw", "message"),
    [
        ({"force_n": 0}, r"force_n: 0\.0 is not allowed \(allowed 0 < \|force_n\| ≤ 100 N"),
        ({"force_n": -100.5}, r"force_n: -100\.5 is not allowed \(allowed 0 < \|force_n\| ≤ 100"),
        ({"weight_kg": -20.0}, r"weight_kg: -20\.0 is not allowed \(allowed 0 < \|weight_kg\|"),
        (
            {"force_n": -24.5, "max_distance_m": 5.4},
            r"max_distance_m: 5\.4 is not allowed \(allowed 0 < max_distance_m ≤ 5\.3 m, "
            r"a reverse tow's room",
        ),
    ],
)
def test_tow_validation_of_signed_forces(source, raw, message):
    with pytest.raises(ParameterError, match=message) as err:
        tow_parameters(raw, source.rig)
    assert len(err.value.lines()) == 1


@pytest.mark.parametrize("torque", [0.0, -5.01, 5.01, float("nan")])
def test_spin_validation_refuses_zero_and_out_of_range(source, torque):
    with pytest.raises(ParameterError, match=r"torque_nm: .* \(allowed 0 < \|torque_nm\| ≤ 5 N·m"):
        spin_parameters({"torque_nm": torque}, source.rig)
