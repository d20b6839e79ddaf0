"""Parameter recovery of the joint output-error fit on clean simulated runs."""

import dataclasses

import numpy as np
import pytest

from estimation import estimate
from estimation.axis.model import simulate
from estimation.axis.output_error import fit_output_error
from estimation.axis.prepared_run import prepare
from estimation.data.run_arrays import RunData
from tests.estimation.synth import SURGE_TRUTH, YAW_TRUTH, Physics, tow_set

TRUTH = {"surge": np.array(SURGE_TRUTH), "yaw": np.array(YAW_TRUTH)}


@pytest.mark.parametrize("axis", ["surge", "yaw"])
def test_recovers_truth_within_one_percent(axis):
    result = estimate(tow_set(axis=axis, seed=11), n_bootstrap=10)
    doc = result.to_json()
    values = np.array(
        [
            doc["coefficients"][k]["value"]
            for k in ("inertia", "linear_damping", "quadratic_damping")
        ]
    )
    assert np.all(np.abs(values / TRUTH[axis] - 1) < 0.01)
    assert doc["effects"] == [] and doc["ambiguous"] == []
    assert doc["rmse_after"] < 0.0001 / np.sqrt(12) * 1.2  # quantization noise only
    assert doc["bootstrap"]["used"] >= 5
    assert len(doc["correlation"]["matrix"]) == 3


def test_one_force_cannot_separate_linear_and_quadratic_damping():
    runs = tow_set(seed=2, drives=(24.5,))
    result = estimate(runs, search_effects=False, n_bootstrap=0)
    assert any("not separable from one force" in w and "4×" in w for w in result.warnings)


def test_standard_errors_grow_with_encoder_step():
    fine = fit_output_error([prepare(r) for r in tow_set(seed=4, quantum=1e-4)])
    coarse = fit_output_error([prepare(r) for r in tow_set(seed=4, quantum=1e-3)])
    assert np.all(coarse.std > 5 * fine.std)


@pytest.mark.slow
@pytest.mark.parametrize("axis", ["surge", "yaw"])
def test_truth_inside_two_sigma_in_90_percent_of_50_seeds(axis):
    truth = TRUTH[axis]
    inside, worst = np.zeros(3), np.zeros(3)
    for seed in range(50):
        fit = fit_output_error(
            [prepare(r) for r in tow_set(Physics(*truth), axis=axis, seed=1000 + seed)]
        )
        inside += np.abs(fit.values - truth) <= 2 * fit.std
        worst = np.maximum(worst, np.abs(fit.values / truth - 1))
    coverage = inside / 50
    print(f"{axis}: truth within ±2σ in {coverage} of 50 seeds, worst relative error {worst}")
    assert np.all(worst < 0.01)
    assert np.all(coverage >= 0.9)


def test_samples_after_t_end_are_ignored():
    """After the end-of-travel brake the carriage stands still: those samples must not count."""
    runs = []
    for r in tow_set(seed=14):
        t_stop = np.arange(1, 21) * 0.1 + r.t[-1]
        t = np.concatenate([r.t, t_stop])
        x = np.concatenate([r.position, np.full(t_stop.size, r.position[-1])])
        runs.append(dataclasses.replace(r, t=t, position=x, t_end=float(r.t[-1])))
    doc = estimate(runs, n_bootstrap=0).to_json()
    values = np.array(
        [
            doc["coefficients"][k]["value"]
            for k in ("inertia", "linear_damping", "quadratic_damping")
        ]
    )
    assert np.all(np.abs(values / TRUTH["surge"] - 1) < 0.01) and doc["effects"] == []
    braked = [dataclasses.replace(r, t_end=None) for r in runs]
    assert (
        estimate(braked, search_effects=False, n_bootstrap=0).rmse_after > 100 * doc["rmse_after"]
    )


def test_each_parameter_vector_is_integrated_once_with_all_its_jacobian_sets(monkeypatch):
    """The one fit integrates a parameter vector and its finite-difference sets (3 + effects
    of them) in one vectorized call, and never again for the same vector, whether the
    optimiser asks for its residual, its Jacobian or both."""
    t = np.arange(0.0, 15.0, 0.05)
    drive = 40.0 + 10.0 * np.sin(2 * np.pi * 0.3 * t)
    blank = prepare(RunData("w", "surge", t, np.zeros_like(t), drive, t_release=1.0))
    x = np.zeros_like(t)  # at rest until the release, then the model's path
    x[t.size - blank.t.size :] = simulate(np.array([SURGE_TRUTH]), (), [blank])[0][0][0]
    noise = np.random.default_rng(3).normal(0.0, 1e-4, t.size)
    run = prepare(RunData("w", "surge", t, x + noise, drive, t_release=1.0))
    calls: list[int] = []
    vectors: set[bytes] = set()
    from estimation.motion import output_error_fit

    def counting(tracks, inertia, coefficients, x0, *args, **kwargs):
        calls.append(x0.shape[0])  # parameter sets integrated at once
        return integrate(tracks, inertia, coefficients, x0, *args, **kwargs)

    def seen(method):
        def wrapped(self, p):
            vectors.add(np.asarray(p).tobytes())
            return method(self, p)

        return wrapped

    integrate = output_error_fit.integrate
    problem = output_error_fit._Problem
    monkeypatch.setattr(output_error_fit, "integrate", counting)
    monkeypatch.setattr(problem, "residual", seen(problem.residual))
    monkeypatch.setattr(problem, "jacobian", seen(problem.jacobian))
    fit = fit_output_error([run], (), start=1.2 * np.array(SURGE_TRUTH))
    assert set(calls) == {4}, calls  # the vector and its 3 perturbations, together
    assert len(calls) == len(vectors)  # once per vector the optimiser asked about
    assert fit.values[0] == pytest.approx(SURGE_TRUTH[0], rel=0.05)
