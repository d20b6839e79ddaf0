"""Numerical care in the tow/spin fit: the leave-one-run-out verdict on a tie, the RK4 step
on a heavily damped record, σ machinery skipped where a refit's σ is discarded."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest

from estimation.axis.model import at_step_limit, simulate, step_of
from estimation.axis.output_error import fit_output_error, leave_one_run_out_rmse
from estimation.axis.prepared_run import prepare
from estimation.data.run_arrays import RunData
from estimation.stats.out_of_sample import LORO_RESOLUTION, loro_dropped
from tests.estimation.synth import SURGE_TRUTH, Physics, tow_set


def test_a_candidate_at_zero_ties_with_the_model_without_it_and_is_no_drop():
    """A force that aids forward tows wants a negative dry friction: the friction sits at its
    bound 0, the fit is the base model, and the two leave-one-run-out RMSEs differ only by
    where the refits stopped. That difference is no drop, whichever way it falls."""
    runs = [prepare(r) for r in tow_set(Physics(*SURGE_TRUTH, bias=0.5), seed=3)]
    base = fit_output_error(runs)
    pinned = fit_output_error(runs, ("coulomb_friction",), start=np.r_[base.values, 0.0])
    assert "coulomb_friction" in pinned.at_bound
    cv_base = leave_one_run_out_rmse(runs, base)
    cv_pinned = leave_one_run_out_rmse(runs, pinned)
    assert cv_base is not None and cv_pinned is not None
    assert abs(cv_pinned / cv_base - 1) < LORO_RESOLUTION  # a tie
    assert not loro_dropped(cv_pinned, cv_base) and not loro_dropped(cv_base, cv_pinned)
    # a bare "<" on round-off called one of them a drop; a resolved drop is still one
    assert not loro_dropped(cv_base * (1 - 1e-14), cv_base)
    assert loro_dropped(cv_base * (1 - 10 * LORO_RESOLUTION), cv_base)


def test_bootstrap_and_leave_one_run_out_refits_skip_the_quantization_sigma(monkeypatch):
    """Their σ is discarded (only values and predictions are kept): the quantization σ is
    not computed for them, and their values are those of a refit that computes it."""
    import estimation.stats.identify as identify
    from estimation.axis.tow_estimate import _bootstrap

    runs = [prepare(r) for r in tow_set(seed=4)]
    fit = fit_output_error(runs)
    assert fit.std_quantization is not None  # the reported fit carries it
    calls: list[int] = []
    real = identify.quantization_scores

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(identify, "quantization_scores", counted)
    boot = _bootstrap(runs, fit, 6, 0)
    assert boot.used >= 3
    assert leave_one_run_out_rmse(runs, fit) is not None
    assert calls == []
    train = runs[1:]
    with_sigma = fit_output_error(train, start=fit.values)
    without = fit_output_error(train, start=fit.values, quantization_sigma=False)
    assert calls == [1] and without.std_quantization is None
    np.testing.assert_array_equal(without.values, with_sigma.values)


#: A heavily damped thruster-driven tow at 10 Hz: the drag's local rate 2·K_Q·v/M at the
#: terminal speed is 50 /s, so the sample step (0.1 s, the step the simulator took before)
#: puts h·c/M ≈ 5 beyond RK4's real-axis stability limit ≈ 2.785.
DAMPING_RATE = 50.0  # 1/s at the terminal speed
DAMPED_SPEED = 0.1  # m/s, terminal speed at the mean thrust
SAMPLE_S, RELEASE_S, DURATION_S = 0.1, 1.0, 20.0
QUANTUM = 1e-5  # m, the encoder's step


@lru_cache(maxsize=3)
def _damped_tow(inertia: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[float, ...]]:
    """t, the thrust F_k = F₀·(1 + 0.3·sin(2πt/4)) held per sample from the release, the
    exact position and (M, K_L, K_Q): from scipy's solve_ivp, one interval of held thrust at
    a time (never our integrator). DOP853: an interval is 5 of the drag's time constants, not
    stiff for it; it differs from Radau at the same tolerances by ≤ 6e-14 m (every quantized
    sample the same) at a twentieth of the CPU (2.4 -> 0.1 s per inertia)."""
    from scipy.integrate import solve_ivp

    mean_thrust = 0.25 * inertia * DAMPING_RATE * DAMPED_SPEED  # K_Q·v∞² with the rate above
    k_q = mean_thrust / DAMPED_SPEED**2
    k_l = 0.01 * mean_thrust / DAMPED_SPEED
    t = np.arange(0.0, DURATION_S + SAMPLE_S / 2, SAMPLE_S)
    thrust = np.where(
        t >= RELEASE_S, mean_thrust * (1 + 0.3 * np.sin(2 * np.pi * (t - RELEASE_S) / 4)), 0.0
    )
    x, state = np.zeros(t.size), np.zeros(2)
    for k in range(round(RELEASE_S / SAMPLE_S), t.size - 1):
        sol = solve_ivp(
            lambda _t, y, f=thrust[k]: [y[1], (f - k_l * y[1] - k_q * abs(y[1]) * y[1]) / inertia],
            (t[k], t[k + 1]),
            state,
            method="DOP853",
            rtol=1e-10,
            atol=1e-13,
        )
        state = sol.y[:, -1]
        x[k + 1] = state[0]
    return t, thrust, x, (inertia, k_l, k_q)


@pytest.mark.parametrize("inertia", [10.0, 143.0, 1000.0])
def test_a_heavily_damped_tow_is_integrated_with_a_stable_step(inertia):
    t, thrust, exact, truth = _damped_tow(inertia)
    run = RunData(
        "damped",
        "surge",
        t,
        QUANTUM * np.round(exact / QUANTUM),
        drive=thrust,
        t_release=RELEASE_S,
    )
    prepared = prepare(run)
    h, unresolved = step_of(np.atleast_2d(truth), (), [prepared])
    assert not unresolved.any() and not at_step_limit(np.array(truth), (), [prepared])
    assert h * 2 * truth[2] * DAMPED_SPEED * 1.3 / inertia < 2.785  # peak speed ≈ 1.3 v∞
    simulated = simulate(np.array(truth), (), [prepared])[0][0][0]
    assert np.max(np.abs(simulated - exact[np.isin(t, prepared.t)])) < 1e-6  # m, of 1.9 m
    fit = fit_output_error([prepared], start=np.array(truth) * [1.0, 1.2, 0.8])
    assert fit.value("quadratic_damping") == pytest.approx(truth[2], rel=0.01)
    assert fit.rmse < QUANTUM  # the encoder's step: the model explains the record
