"""An imported multi-voltage calibration (the published T200 table) drives a thruster tow on
the simulated rig without any calibration run, and the estimator rebuilds that run's drive
from the identified F(command, V) at the supply voltage the run recorded — not from the
rig file's exponent — and says so."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from daq.calibration_law import import_calibration, law_of
from daq.procedures.motion import run_motion_test
from daq.procedures.params import ParameterError
from daq.procedures.requests import tow_parameters
from daq.run_data import load_run_data
from daq.thruster_run_drive import thruster_drive
from estimation.thrust.calibration_import import CommandUnit, ImportSpec

pytestmark = pytest.mark.simtime

T200 = Path(__file__).resolve().parents[2] / "fixtures" / "calibrations" / "t200-bollard.csv"
SPEC = ImportSpec(
    "PWM (µs)", "Force (Kg f)", "kgf", CommandUnit("pwm_us", 1500, 400), "Voltage (V)"
)


async def test_a_tow_on_an_imported_calibration_rebuilds_its_drive_from_the_law(session, store):
    made = import_calibration(store, T200.read_bytes(), SPEC, "t200")
    params = tow_parameters(
        {"force_n": 20.0, "drive": "thrusters", "max_time_s": 2.5, "baseline_s": 0.3},
        session.rig,
    )
    outcome = await run_motion_test(session, params)
    assert outcome.status == "completed", outcome
    run = store.get_run(outcome.run_id)
    assert run.parameters["calibration_import_id"] == made["id"]
    assert run.parameters["calibration_result_id"] is None
    law, _ = law_of(store, "imported", made["id"])
    count = session.rig.thrusters.count
    # The inverse map aimed at F/n per thruster at the supply voltage read before the run.
    at_start = run.parameters["supply_voltage_at_start_v"]
    assert 10 < at_start < 20  # the simulated supply (16 V nominal)
    for u in run.parameters["commands"]:
        assert float(law.force(u, at_start)) == pytest.approx(20.0 / count, 1e-6)

    data = load_run_data(store, outcome.run_id)
    assert data.drive_law.startswith("identified from calibrations at 10, 12, 16, 18, 20 V")
    volts = store.samples(outcome.run_id).channels["supply_voltage"]
    assert 10 < np.mean(volts) < 20  # the simulated supply: below the reference 20 V
    after = (data.t > data.t_release + 1.5) & (data.t < data.t_end - 0.05)
    assert after.sum() >= 3
    u = run.parameters["commands"][0]
    # Within what the law gives over the voltages the run saw (a 3-sample mean of them).
    low, high = (count * float(law.force(u, v)) for v in (volts.min(), volts.max()))
    assert np.all((data.drive[after] > 0.995 * low) & (data.drive[after] < 1.005 * high))
    # The supply sags a little under load: the rebuilt drive is the 20 N aimed at, to it.
    assert data.drive[after] == pytest.approx(20.0, rel=0.02)
    assert data.drive_draws is not None and data.drive_draws.shape == (30, data.t.size)

    # Beyond what full (here: max_thruster_command) delivers at the voltage measured now.
    reach = count * float(law.force(session.rig.limits.max_thruster_command, at_start))
    with pytest.raises(ParameterError, match=r"force_n: .*allowed up to .* at the supply voltage"):
        await run_motion_test(
            session,
            tow_parameters({"force_n": min(reach * 1.1, 99.0), "drive": "thrusters"}, session.rig),
        )
    assert session.sim.thrusters.outputs == [0.0] * count

    # Below the smallest thrust the table calibrated at that voltage: refused, naming it.
    floor = count * float(law.min_force(at_start, 1.0))
    with pytest.raises(ParameterError, match=r"force_n: .*below the smallest calibrated forward"):
        await run_motion_test(
            session,
            tow_parameters({"force_n": 0.5 * floor, "drive": "thrusters"}, session.rig),
        )
    assert session.sim.thrusters.outputs == [0.0] * count


def test_the_drive_follows_the_law_at_each_instant_not_v15(session_free_rig):
    """The same outputs at 12 V and at 18 V: the drive's ratio is the law's, far from
    (18/12)^1.5."""
    from estimation.thrust.calibration_import import read_calibration_csv
    from estimation.thrust.law import identify_thrust_law

    law = identify_thrust_law(read_calibration_csv(T200.read_bytes(), SPEC))
    rig = session_free_rig
    t = np.arange(0.0, 3.0, 0.1)
    steps = [(0.05, [0.6] * rig.thrusters.count)]
    at = {
        v: thruster_drive(law, rig, "tow", [0.6], t, 0.05, steps, np.full(t.size, v))[-1]
        for v in (12.0, 18.0)
    }
    ratio = at[18.0] / at[12.0]
    assert ratio == pytest.approx(float(law.force(0.6, 18) / law.force(0.6, 12)), rel=1e-3)
    assert abs(ratio - 1.5**1.5) > 0.15


@pytest.fixture
def session_free_rig(source):
    return source.rig
