"""The drive of a thruster-driven run, rebuilt from the outputs the controller confirmed."""

from __future__ import annotations

import numpy as np
import pytest

from daq.config import DEFAULT_RIG_FILE, load_rig
from daq.thruster_run_drive import thruster_drive
from estimation.thrust.curve import CalibratedThrust, ThrustCurve

CURVE = ThrustCurve(
    np.array([50.0, 0.05, 0.8, 39.0, 0.05, 0.8, 0.0]), np.zeros(7), np.eye(7), 0.1, -0.8, 0.8
)
T = np.arange(0.0, 4.0, 0.1)


def test_recorded_steps_reproduce_the_modelled_ramp_when_the_heartbeat_kept_time():
    rig = load_rig(DEFAULT_RIG_FILE)
    n, slew = rig.thrusters.count, rig.limits.max_command_slew_per_s
    t_on = 0.55
    modelled = thruster_drive(CURVE, rig, "tow", [0.5] * n, T, t_on)
    # The driver's ramp: a step at t_on credited with the 0.05 s since the tick at 0.5,
    # then one step per tick credited with the time since the previous step.
    level, previous, steps = 0.0, 0.5, []
    for instant in [t_on, *T[t_on < T]]:
        level = min(0.5, level + slew * (instant - previous))
        steps.append((float(instant), [level] * n))
        previous = instant
    recorded = thruster_drive(CURVE, rig, "tow", [0.5] * n, T, t_on, steps)
    np.testing.assert_allclose(recorded, modelled, rtol=1e-9, atol=1e-9)


def test_a_late_heartbeat_is_in_the_recorded_drive_not_in_the_model():
    rig = load_rig(DEFAULT_RIG_FILE)
    n = rig.thrusters.count
    # The supervisor missed the ticks at 0.6 and 0.7: the output stayed at 0.1 until 0.8,
    # then the thrust went off at 2.5.
    steps = [(0.5, [0.1] * n), (0.8, [0.3] * n), (0.9, [0.5] * n), (2.5, [0.0] * n)]
    recorded = thruster_drive(CURVE, rig, "tow", [0.5] * n, T, 0.5, steps)
    modelled = thruster_drive(CURVE, rig, "tow", [0.5] * n, T, 0.5)
    lag = rig.thrusters.time_constant_s
    during_gap = (T >= 0.6) & (T < 0.8)
    assert recorded[during_gap].max() < n * float(CURVE.force(0.1)) + 1e-9
    assert modelled[during_gap].min() > recorded[during_gap].max()
    settled = (0.9 + 8 * lag < T) & (T < 2.5)
    assert recorded[settled] == pytest.approx(n * float(CURVE.force(0.5)), rel=1e-3)
    assert recorded[-1] < 0.01 * recorded[settled][-1]


def test_steps_with_the_wrong_number_of_outputs_are_refused():
    rig = load_rig(DEFAULT_RIG_FILE)
    with pytest.raises(ValueError, match="one output per thruster"):
        thruster_drive(CURVE, rig, "tow", [0.5, 0.5], T, 0.5, [(0.5, [0.1])])


def test_the_supply_voltage_scales_the_drive_against_the_calibration_voltage():
    rig = load_rig(DEFAULT_RIG_FILE)
    n, q = rig.thrusters.count, rig.thrusters.voltage_exponent
    assert q == 1.5
    table = [
        {"command": u, "thrust_per_thruster_n": float(CURVE.force(u)), "supply_voltage_v": v}
        for u, v in ((0.2, 15.9), (0.5, 15.6))
    ]
    calibrated = CalibratedThrust.from_table(CURVE, table)
    steps = [(0.5, [0.5] * n)]
    at_calibration = thruster_drive(calibrated, rig, "tow", [0.5] * n, T, 0.5, steps, T * 0 + 15.6)
    sagged_less = thruster_drive(calibrated, rig, "tow", [0.5] * n, T, 0.5, steps, T * 0 + 15.9)
    unknown = thruster_drive(calibrated, rig, "tow", [0.5] * n, T, 0.5, steps)
    np.testing.assert_allclose(at_calibration, unknown, rtol=1e-12)
    on = T > 1.5
    np.testing.assert_allclose(sagged_less[on] / at_calibration[on], (15.9 / 15.6) ** q)
    # A calibration that recorded no voltage cannot be compensated against.
    bare = CalibratedThrust.from_table(
        CURVE, [{k: r[k] for k in ("command", "thrust_per_thruster_n")} for r in table]
    )
    np.testing.assert_allclose(
        thruster_drive(bare, rig, "tow", [0.5] * n, T, 0.5, steps, T * 0 + 15.9), unknown
    )
