"""Thrust curve: concave asymmetric curve with dead band and hysteresis, and its inverse."""

import numpy as np
import pytest

from estimation.thrust.curve import PARAMS, CalibratedThrust, ThrustCurve, fit_thrust_curve

TRUTH = {
    "forward_gain": 40.0,
    "forward_dead_band": 0.08,
    "forward_exponent": 0.7,
    "reverse_gain": 27.0,
    "reverse_dead_band": 0.11,
    "reverse_exponent": 0.8,
    "hysteresis": 0.03,
}
NOISE_N = 0.15


def _true_force(u, s):
    ue = u - 0.5 * TRUTH["hysteresis"] * s
    fwd = np.clip(ue - TRUTH["forward_dead_band"], 0, None) ** TRUTH["forward_exponent"]
    rev = np.clip(-ue - TRUTH["reverse_dead_band"], 0, None) ** TRUTH["reverse_exponent"]
    return TRUTH["forward_gain"] * fwd - TRUTH["reverse_gain"] * rev


def _sweeps(seed=0):
    """Up sweep −1 → 1 then down sweep 1 → −1, twice, in 0.04 steps, with load-cell noise."""
    rng = np.random.default_rng(seed)
    up = np.round(np.arange(-1.0, 1.0001, 0.04), 6)
    u = np.concatenate([up, up[::-1], up, up[::-1]])
    s = np.concatenate([np.ones(up.size), -np.ones(up.size)] * 2)
    return u, _true_force(u, s) + rng.normal(0, NOISE_N, u.size), s


def test_recovers_concave_asymmetric_curve_with_dead_band_and_hysteresis():
    u, f, s = _sweeps()
    curve = fit_thrust_curve(u, f, s)
    for name in PARAMS:
        value, std = curve.parameter(name), curve.std[PARAMS.index(name)]
        assert abs(value - TRUTH[name]) < max(4 * std, 1e-3), (name, value, std)
        assert std > 0
    assert curve.parameter("forward_exponent") < 1 and curve.parameter("reverse_exponent") < 1
    assert curve.rmse_n == pytest.approx(NOISE_N, rel=0.25)
    assert curve.to_json()["parameters"]["hysteresis"]["std"] > 0


def _bow(u, residual):
    """Mean residual in the middle third of a side minus the mean at its two ends (N)."""
    lo, hi = u.min(), u.max()
    third = (hi - lo) / 3
    mid = (u > lo + third) & (u < hi - third)
    return residual[mid].mean() - residual[~mid].mean()


def test_plain_quadratic_leaves_a_bowed_residual():
    u, f, s = _sweeps(1)
    curve = fit_thrust_curve(u, f, s)
    for side in (u > 0.2, u < -0.2):
        uu, ff = u[side], f[side]
        c = np.linalg.lstsq((np.abs(uu) * uu)[:, None], ff, rcond=None)[0][0]
        quad_res = ff - c * np.abs(uu) * uu
        curve_res = ff - curve.force(uu, s[side])
        n = uu.size
        assert abs(_bow(uu, quad_res)) > 10 * NOISE_N / np.sqrt(n / 3)
        assert abs(_bow(uu, curve_res)) < 4 * NOISE_N / np.sqrt(n / 3)
        assert np.sqrt(np.mean(quad_res**2)) > 3 * np.sqrt(np.mean(curve_res**2))


def test_inverse_map_round_trips_and_refuses_unreachable_force():
    u, f, s = _sweeps(2)
    curve = fit_thrust_curve(u, f, s)
    forces = np.array([-20.0, -5.0, -0.5, 0.0, 0.5, 5.0, 20.0, 35.0])
    for direction in (-1.0, 0.0, 1.0):
        commands = curve.command_for_force(forces, direction)
        assert np.allclose(curve.force(commands, direction), forces, atol=1e-9)
    assert curve.command_for_force(0.0) == 0.0
    with pytest.raises(ValueError, match=r"force: got 500 N, allowed"):
        curve.command_for_force(500.0)


def test_parameters_carry_units_and_round_trip():
    u, f, s = _sweeps(2)
    doc = fit_thrust_curve(u, f, s).to_json()
    assert {n: p["unit"] for n, p in doc["parameters"].items()} == {
        "forward_gain": "N", "forward_dead_band": "command", "forward_exponent": "1",
        "reverse_gain": "N", "reverse_dead_band": "command", "reverse_exponent": "1",
        "hysteresis": "command",
    }  # fmt: skip
    again = ThrustCurve.from_json(doc)
    assert again.to_json() == doc


def test_needs_points_on_both_sides():
    u = np.linspace(0.1, 1, 20)
    with pytest.raises(ValueError, match="command: got 20 forward and 0 reverse"):
        fit_thrust_curve(u, 30 * u)


def test_calibration_table_words_give_the_same_fit():
    """The calibration procedure records "up"/"down"/"hold" for |command| rising/falling."""
    u, f, s = _sweeps(3)
    magnitude_rising = s * np.sign(u)
    words = np.where(magnitude_rising > 0, "up", np.where(magnitude_rising < 0, "down", "hold"))
    numeric = fit_thrust_curve(u, f, s)
    worded = fit_thrust_curve(list(u), list(f), directions=list(words))
    assert np.allclose(worded.values, numeric.values, rtol=1e-6, atol=1e-9)
    with pytest.raises(ValueError, match="directions: got \\['sideways'\\]"):
        fit_thrust_curve(u, f, ["sideways"] * u.size)


def test_calibrated_inverse_hits_the_measured_thrusts_and_the_curve_in_between():
    curve = ThrustCurve(
        np.array([50.0, 0.05, 0.8, 39.0, 0.05, 0.8, 0.0]), np.zeros(7), np.eye(7), 0.1, -0.8, 0.8
    )
    # The load cell measured 0.6 N more than the curve at 0.4 and 0.3 N less at -0.4.
    table = [
        {"command": 0.4, "thrust_per_thruster_n": float(curve.force(0.4)) + 0.6},
        {"command": -0.4, "thrust_per_thruster_n": float(curve.force(-0.4)) - 0.3},
    ]
    calibrated = CalibratedThrust.from_table(curve, table)
    assert calibrated.command_for_force(float(curve.force(0.4)) + 0.6) == pytest.approx(0.4)
    assert calibrated.command_for_force(float(curve.force(-0.4)) - 0.3) == pytest.approx(-0.4)
    for force in (3.0, 12.0, 20.0, -8.0, -15.0):
        u = calibrated.command_for_force(force)
        assert float(calibrated.force(u)) == pytest.approx(force, abs=1e-6)
        assert abs(u - float(curve.command_for_force(force))) < 0.02  # a refinement, not a jump
    assert calibrated.command_for_force(0.0) == 0.0
    with pytest.raises(ValueError, match="force: got 99 N, allowed"):
        calibrated.command_for_force(99.0)
