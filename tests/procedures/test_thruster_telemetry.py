"""The thrusters' RPM and current as channels of thruster-driven runs and calibrations, on
the simulated rig in process (simulated time): every sample of the run carries them, they
are the simulated controller's own (its motor model, not a copy of the command), stored
with units and exported; weight-driven runs carry none."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

from daq.procedures.motion import run_motion_test
from daq.procedures.requests import calibration_parameters, tow_parameters
from daq.procedures.thrust_calibration import run_thrust_calibration
from daq.store import export_run_csv
from daq.store.channel_units import column_infos
from daq.vocabulary import thruster_telemetry_channels
from tests.procedures.conftest import QUICK_CALIBRATION

pytestmark = pytest.mark.simtime


def _telemetry(store, run_id: str, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t_mono, rpm per thruster as rows, current per thruster as rows) of a stored run."""
    table = store.samples(run_id)
    rpm = np.array([table.channels[f"thruster{i}_rpm"] for i in range(1, count + 1)])
    amps = np.array([table.channels[f"thruster{i}_current"] for i in range(1, count + 1)])
    return table.t_mono, rpm, amps


async def test_a_thruster_tow_logs_rpm_and_current_of_each_thruster_every_sample(session, store):
    count = session.rig.thrusters.count
    names = thruster_telemetry_channels(count)
    params = calibration_parameters(QUICK_CALIBRATION, session.rig)
    calibration_outcome, _ = await run_thrust_calibration(session, params)
    assert calibration_outcome.status == "completed"
    calibration_run = store.get_run(calibration_outcome.run_id)
    assert set(names) <= set(calibration_run.channel_names)
    _, cal_rpm, cal_amps = _telemetry(store, calibration_outcome.run_id, count)
    assert np.nanmax(cal_rpm) > 0 and np.nanmax(cal_amps) > 0  # the steps drew current

    tow = tow_parameters(
        {"force_n": 20.0, "drive": "thrusters", "max_time_s": 2.5, "baseline_s": 0.5},
        session.rig,
    )
    outcome = await run_motion_test(session, tow)
    assert outcome.status == "completed"
    run = store.get_run(outcome.run_id)
    assert set(names) <= set(run.channel_names)
    t, rpm, amps = _telemetry(store, outcome.run_id, count)
    # At the sampling rate: every sample carries a reading but the first (the telemetry is
    # the controller's answer read after the previous tick).
    unread = np.isnan(rpm).any(axis=0) | np.isnan(amps).any(axis=0)
    assert unread[1:].sum() == 0 and t.size > 20
    # Baseline (before the thrust goes on): propellers still (the simulated thrust's lag
    # leaves a few rpm after the calibration), no current at the line's 0.01 A.
    release = next(e for e in store.events(outcome.run_id) if e.message.startswith("thrust on"))
    before = (t < release.data["t_mono"]) & ~unread
    assert before.sum() >= 3
    model = session.sim.plant.scenario.thrusters
    assert np.abs(rpm[:, before]).max() < 0.01 * model.full_scale_rpm
    assert np.abs(amps[:, before]).max() < 0.01
    # Thrust on: each thruster ≈ 10 N. The simulated controller's motor model gives
    # rpm = rpm_fs·√(F/F_fs) and I = I_fs·(F/F_fs)^1.5, so the thrust the telemetry says
    # (F_fs·(rpm/rpm_fs)²) is the thrust asked for, and I = I_fs·(rpm/rpm_fs)³ holds per
    # sample (the channels are the controller's readings, not the command echoed).
    full_thrust = session.sim.plant.full_scale_thrust_n
    steady = rpm.min(axis=0) > 0.9 * np.nanmax(rpm)
    assert steady.sum() >= 5
    thrust_seen = full_thrust * (rpm[:, steady] / model.full_scale_rpm) ** 2
    per_thruster = run.parameters["force_per_thruster_n"]
    assert np.median(thrust_seen) == pytest.approx(per_thruster, rel=0.1)
    speed = np.abs(rpm[:, steady]) / model.full_scale_rpm
    expected_amps = model.full_scale_current_a * speed**3
    # The line carries current to 0.01 A and rpm as an integer.
    np.testing.assert_allclose(amps[:, steady], expected_amps, rtol=0.01, atol=0.02)

    infos = column_infos(run)
    assert {infos[n].units for n in names if n.endswith("_rpm")} == {"rpm"}
    assert {infos[n].units for n in names if n.endswith("_current")} == {"A"}
    text = io.StringIO()
    export_run_csv(store, outcome.run_id, text)
    lines = text.getvalue().splitlines()
    units = next(line for line in lines if line.startswith("# units:"))
    assert "thruster1_rpm=rpm" in units and f"thruster{count}_current=A" in units
    header = next(line for line in lines if not line.startswith("#")).split(",")
    assert set(names) <= set(header)


async def test_a_weight_driven_tow_carries_no_thruster_channels(session, store):
    params = tow_parameters({"weight_kg": 2.0, "max_time_s": 1.0}, session.rig)
    outcome = await run_motion_test(session, params)
    assert outcome.status == "completed"
    run = store.get_run(outcome.run_id)
    assert not any(name.startswith("thruster") for name in run.channel_names)
    table = store.samples(outcome.run_id)
    assert len(table) > 5 and not any(math.isnan(v) for v in table.channels["tow_position"])
