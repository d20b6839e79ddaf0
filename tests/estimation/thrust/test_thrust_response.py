"""The thrust time constant measured from a calibration's step responses: data from an
integrator written here (scipy's solve_ivp on τ·dF/dt + F = n·F(u)), sampled at 10 Hz
with jitter and load-cell noise as the rig samples it, give τ back within 10 %."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from estimation.thrust.curve import fit_thrust_curve
from estimation.thrust.response import measure_response_time


def _power_law(u: np.ndarray) -> np.ndarray:
    u = np.asarray(u, dtype=float)
    return 30 * np.clip(u - 0.05, 0, None) ** 0.8 - 22 * np.clip(-u - 0.06, 0, None) ** 0.85


@pytest.fixture(scope="module")
def curve():
    u = np.linspace(-0.9, 0.9, 37)
    return fit_thrust_curve(u, _power_law(u), [0.0] * u.size)


def _calibration_record(tau: float, seed: int, thrusters: int = 2):
    """A sweep 0 → 0.8 → −0.8 → 0 in steps held 2.5 s, the load cell sampled at 10 Hz
    (2 ms jitter, 0.05 N noise); each hold integrated from the end of the last."""
    rng = np.random.default_rng(seed)
    commands = [0.2, 0.4, 0.6, 0.8, 0.6, 0.4, 0.2, 0.0, -0.2, -0.4, -0.6, -0.8, -0.4, 0.0]
    starts = 1.0 + 2.5 * np.arange(len(commands)) + rng.uniform(0, 0.1, len(commands))
    steps = [(float(s), [u] * thrusters) for s, u in zip(starts, commands, strict=True)]
    t = np.arange(0.0, starts[-1] + 2.5, 0.1)
    t = np.sort(t + rng.normal(0.0, 0.002, t.size))
    edges = [float(t[0]) - 0.01, *starts, float(t[-1]) + 0.01]
    targets = [0.0, *(thrusters * float(_power_law(u)) for u in commands)]
    y = np.empty(t.size)
    state = 0.0
    for (a, b), held in zip(itertools.pairwise(edges), targets, strict=True):
        inside = (t >= a) & (t < b)

        def lag(_s, f, held=held):
            return [(held - f[0]) / tau]

        sol = solve_ivp(lag, (a, b), [state], dense_output=True, rtol=1e-10, atol=1e-12)
        y[inside] = sol.sol(t[inside])[0]
        state = float(sol.y[0, -1])
    return steps, t, y + rng.normal(0.0, 0.05, t.size)


@pytest.mark.parametrize("tau", [0.08, 0.15, 0.4])
def test_the_time_constant_comes_back_within_10_percent(curve, tau):
    steps, t, load = _calibration_record(tau, seed=int(tau * 1000))
    found = measure_response_time(curve, steps, t, load)
    assert found is not None
    assert found.time_constant_s == pytest.approx(tau, rel=0.10), found
    assert abs(found.time_constant_s - tau) < 3 * found.std_s + 0.02 * tau, found
    assert found.settle_90_s == pytest.approx(found.time_constant_s * np.log(10))
    assert found.transients == len(steps)


def test_too_few_steps_measure_nothing(curve):
    steps, t, load = _calibration_record(0.15, seed=1)
    assert measure_response_time(curve, steps[:2], t[t < 6.0], load[t < 6.0]) is None


def test_the_largest_step_for_the_report_leaves_unread_samples_out(curve):
    from estimation.thrust.response import largest_transient

    steps, t, load = _calibration_record(0.15, seed=3)
    for start, _ in steps:  # a poll lost in every step
        load[np.argmin(np.abs(t - (start + 0.15)))] = np.nan
    example = largest_transient(curve, steps, t, load, 0.15)
    assert len(example["t_s"]) >= 10 and np.all(np.isfinite(example["measured_n"]))
    assert min(example["t_s"]) >= -0.3 and max(example["model_t_s"]) <= 1.0
    assert json.dumps(example)  # storable as JSON (no NaN)
