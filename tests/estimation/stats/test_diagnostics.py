"""Residual diagnostics: whiteness, force-domain residual, regressor correlations."""

import numpy as np
import pytest

from estimation import estimate
from estimation.stats.diagnostics import ljung_box, position_noise, third_differences
from tests.estimation.synth import SURGE_TRUTH, Physics, tow_set


def test_ljung_box_separates_white_from_correlated():
    rng = np.random.default_rng(0)
    white = ljung_box([rng.normal(size=300) for _ in range(4)])
    drift = ljung_box([np.cumsum(rng.normal(size=300)) for _ in range(4)])
    assert white.p_value > 0.01 and drift.p_value < 1e-6
    assert white.lags == drift.lags == 40


@pytest.mark.parametrize(
    ("physics_kw", "regressor"),
    [
        ({"coulomb": 3.0}, "coulomb_friction"),
        ({"spring": 1.0}, "restoring_spring"),
        ({"cubic": 150.0}, "cubic_drag"),
    ],
)
def test_base_residual_points_at_the_missing_effect(physics_kw, regressor):
    result = estimate(tow_set(Physics(*SURGE_TRUTH, **physics_kw), seed=31), n_bootstrap=0)
    doc = result.to_json()["diagnostics"]
    corr = doc["residual_correlation_before"]
    assert corr[regressor] == max(corr.values()) and corr[regressor] > 0.7
    # after the effect is added the force-domain residual is down to encoder noise
    before = np.array(list(doc["force_rmse_per_run_before"].values()))
    after = np.array(list(doc["force_rmse_per_run_after"].values()))
    assert np.all(after < 0.2) and np.max(before) > 5 * np.max(after)
    assert doc["ljung_box_after"]["p_value"] > 0.001 > doc["ljung_box_before"]["p_value"]


def test_clean_data_residual_correlates_with_nothing():
    doc = estimate(tow_set(seed=32), n_bootstrap=0).to_json()["diagnostics"]
    assert max(abs(v) for v in doc["residual_correlation_before"].values()) < 0.2


@pytest.mark.parametrize("seed", range(5))
def test_position_noise_of_an_irregular_record_is_its_scatter_not_its_trend(seed):
    """30 samples at irregular instants (a digitized or sparse record) of a parabola plus
    white noise of 0.1 mm: the noise is the scatter, within the spread 20 third differences
    allow (σ of a 20-sample RMS ≈ 16 %; the lower quartile of one window is that window).
    Plain Δ³ of irregular samples cancels not even a straight line and read the parabola as
    0.5 m of "noise"."""
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0.0, 10.0, 30))
    x = 0.3 + 2.0 * t - 0.7 * t**2 + 1e-4 * rng.standard_normal(t.size)
    assert 0.6e-4 < position_noise([x], [t]) < 1.5e-4


def test_third_differences_on_a_uniform_grid_are_the_plain_ones_scaled():
    """On a uniform grid the divided differences are ±Δ³r/√20 (var Δ³r = 20σ²)."""
    r = np.random.default_rng(3).standard_normal(50)
    d = third_differences(0.05 * np.arange(50) + 2.0, r)
    assert np.allclose(np.abs(d), np.abs(np.diff(r, 3)) / np.sqrt(20.0), rtol=1e-9)
