"""The shared σ (``estimation.stats.identify.honest_statistics`` with
``estimation.stats.serial``) on a model-free problem: a straight line x = a_r + b·t fitted to
three records (one offset a_r each, a common slope b), whose noise is AR(1) within a record
and independent across records. The coverage rule is the one of test_term_coverage: with an
honest σ, ≥ 90 % of seeds inside 2σ, and median |z| ≥ 0.34 (not more than ~2× too wide)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from estimation.stats.identify import honest_statistics
from estimation.stats.serial import long_run_scores

SIZES = (200, 150, 250)
SLOPE = 0.3
MEDIAN_ABS_Z_MIN = 0.34  # as in test_term_coverage: 0.674 − 3 × 0.11


def _noise(rng, size, rho, sd=1.0):
    e = np.empty(size)
    e[0] = sd * rng.standard_normal()
    for k in range(1, size):
        e[k] = rho * e[k - 1] + sd * np.sqrt(1 - rho**2) * rng.standard_normal()
    return e


def _fit(rng, rho):
    """Least squares of the slope and offsets; (slope error, σ, white σ)."""
    t = [np.arange(n) * 0.1 for n in SIZES]
    x = np.concatenate([2.0 + SLOPE * tr + _noise(rng, tr.size, rho) for tr in t])
    design = np.zeros((x.size, 1 + len(SIZES)))
    design[:, 0] = np.concatenate(t)
    start = 0
    for r, n in enumerate(SIZES):
        design[start : start + n, 1 + r] = 1.0
        start += n
    theta = np.linalg.lstsq(design, x, rcond=None)[0]
    residual = x - design @ theta
    ident = honest_statistics(residual, -design, 1, SIZES)  # J = ∂residual/∂θ
    return theta[0] - SLOPE, float(ident.std[0]), float(ident.std_white[0])


def _coverage(rho, seeds=200):
    rng = np.random.default_rng(5)
    rows = np.array([_fit(rng, rho) for _ in range(seeds)])
    z, z_white = np.abs(rows[:, 0] / rows[:, 1]), np.abs(rows[:, 0] / rows[:, 2])
    return np.mean(z <= 2), np.median(z), np.mean(z_white <= 2), rows


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.8])
def test_two_sigma_intervals_cover_the_slope_with_correlated_noise(rho):
    hit, median, _, rows = _coverage(rho)
    assert hit >= 0.90, (rho, hit)
    assert median >= MEDIAN_ABS_Z_MIN, (rho, median)
    assert np.all(rows[:, 1] >= rows[:, 2])  # never below the white σ


def test_white_sigma_is_what_fails_on_correlated_noise():
    """The case above is one the white formula cannot pass (so the test can fail)."""
    _, _, white_hit, _ = _coverage(0.8)
    assert white_hit < 0.6


def test_no_lag_crosses_a_record_boundary():
    rng = np.random.default_rng(1)
    residual = rng.standard_normal(sum(SIZES))
    jacobian = rng.standard_normal((residual.size, 2))
    whole = long_run_scores(residual, jacobian, SIZES)
    edges = np.cumsum((0, *SIZES))
    parts = sum(
        long_run_scores(residual[a:b], jacobian[a:b], [b - a]) for a, b in itertools.pairwise(edges)
    )
    np.testing.assert_allclose(whole, parts)


def test_record_sizes_that_do_not_add_up_are_refused():
    with pytest.raises(ValueError, match="record_sizes: sum 5, allowed: 6"):
        long_run_scores(np.zeros(6), np.ones((6, 1)), [2, 3])


@pytest.mark.parametrize("rho", [0.0, 0.6, 0.95])
def test_long_run_scores_are_statsmodels_newey_west(rho):
    """The NumPy Newey–West (the estimate path does not import statsmodels and pandas) is
    statsmodels' ``S_nw_panel`` with Bartlett weights, record by record, prewhitened and
    recoloured as the module doc says, to rounding."""
    from statsmodels.stats.sandwich_covariance import S_nw_panel, weights_bartlett

    from estimation.stats.serial import (
        bartlett_bandwidth,
        lag_one_autocorrelation,
        prewhitening_rho,
    )

    rng = np.random.default_rng(3)
    sizes = (*SIZES, 2, 4)  # and records too short for a lag
    # AR(1) smoothed over 8 samples: correlation that prewhitening leaves, so L > 1
    residual = np.concatenate([np.convolve(_noise(rng, n, rho), np.ones(8))[:n] for n in sizes])
    jacobian = rng.standard_normal((residual.size, 3))
    scores = jacobian * residual[:, None]
    expected = np.zeros((3, 3))
    lags_used = []
    for a, b in itertools.pairwise(np.cumsum((0, *sizes))):
        e, g = residual[a:b], scores[a:b]
        if b - a < 3:
            expected += g.T @ g
            continue
        r = prewhitening_rho(e)
        lags = bartlett_bandwidth(lag_one_autocorrelation(e[1:] - r * e[:-1]), b - a - 1)
        lags_used.append(lags)
        white = g[1:] - r * g[:-1]
        expected += S_nw_panel(white, weights_bartlett(lags), [(0, b - a - 1)]) / (1 - r) ** 2
    np.testing.assert_allclose(
        long_run_scores(residual, jacobian, sizes), expected, rtol=1e-12, atol=0
    )
    assert max(lags_used) >= 1  # the lagged sums are exercised (L > 1 for ρ 0.6 and 0.95)
