"""The thrust calibration's uncertainty reaches the coefficients (σ_cal, σ_total)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from estimation import estimate
from estimation.thrust.curve import ThrustCurve
from estimation.thrust.drive import curve_draws
from tests.estimation.synth import SURGE_TRUTH, Physics, thruster_run, tow_set

COEFFICIENTS = ("inertia", "linear_damping", "quadratic_damping")


def _curve(gain_rel_std: float) -> ThrustCurve:
    values = np.array([50.0, 0.05, 0.8, 39.0, 0.05, 0.8, 0.0])
    std = np.zeros(7)
    std[0] = gain_rel_std * values[0]  # only the forward gain is uncertain
    return ThrustCurve(values, std, np.eye(7), 0.1, -0.8, 0.8)


def _with_draws(run, curve: ThrustCurve, draws: list[ThrustCurve]):
    """The run's drive as two thrusters' forces through ``curve``; draws through the others."""
    command = curve.command_for_force(run.drive / 2)
    alt = np.array([2 * c.force(command) for c in draws])
    return replace(run, drive_draws=alt)


def test_gain_uncertainty_of_two_percent_gives_two_percent_on_every_coefficient():
    curve = _curve(0.02)
    draws = curve_draws(curve, 30)
    gains = np.array([c.parameter("forward_gain") for c in draws])
    phys = Physics(*SURGE_TRUTH)
    runs = [
        _with_draws(thruster_run(phys, (f,), hold_s=6.0, run_id=f"thr-{f:g}"), curve, draws)
        for f in (20.0, 45.0, 70.0)
    ]
    doc = estimate(runs, n_bootstrap=0).to_json()
    u = doc["uncertainty"]
    assert u["calibration_draws"] == 30
    # A drive scaled by k scales every coefficient by k: σ_cal/value = the drawn gains' spread.
    spread = float(np.std(gains, ddof=1) / curve.parameter("forward_gain"))
    assert spread == pytest.approx(0.02, rel=0.4)
    for name in COEFFICIENTS:
        value = doc["coefficients"][name]["value"]
        p = u["parameters"][name]
        assert p["std_calibration"] / value == pytest.approx(spread, rel=0.1), name
        assert p["std_fit"] == doc["coefficients"][name]["std"]  # existing key unchanged
        assert p["std_total"] == pytest.approx(np.hypot(p["std_fit"], p["std_calibration"]))
        assert p["std_total"] > p["std_fit"]


def test_weight_driven_runs_have_no_calibration_spread():
    doc = estimate(tow_set(drives=(24.5, 83.3)), n_bootstrap=0, search_effects=False).to_json()
    u = doc["uncertainty"]
    assert u["calibration_draws"] == 0
    for name in COEFFICIENTS:
        p = u["parameters"][name]
        assert p["std_calibration"] == 0.0 and p["std_total"] == p["std_fit"]


def test_drive_draws_of_the_wrong_shape_are_refused():
    run = thruster_run(Physics(*SURGE_TRUTH), (20.0,), hold_s=3.0)
    bad = replace(run, drive_draws=np.zeros((5, run.t.size - 1)))
    with pytest.raises(ValueError, match="drive_draws"):
        estimate([bad], n_bootstrap=0)


def test_lack_of_fit_factors_carry_the_curve_rmse_at_the_run_thrust():
    from estimation.thrust.drive import lack_of_fit_factors

    curve = replace(_curve(0.0), rmse_n=0.05)
    params = {"force_per_thruster_n": 5.0}
    a = lack_of_fit_factors(curve, params, "run-a", 400)
    assert np.std(a - 1.0) == pytest.approx(0.05 / 5.0, rel=0.15)
    assert np.array_equal(a, lack_of_fit_factors(curve, params, "run-a", 400))  # fixed per run
    b = lack_of_fit_factors(curve, params, "run-b", 400)
    assert abs(np.corrcoef(a, b)[0, 1]) < 0.2  # independent between runs
    assert np.all(lack_of_fit_factors(curve, {}, "run-a", 5) == 1.0)
