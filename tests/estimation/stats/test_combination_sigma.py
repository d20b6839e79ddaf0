"""σ of a combination of coefficients the data do not determine one by one
(``estimation.stats.identify``, ``FitStatistics.combination_std``), on a model-free problem:
x = (a + b)·t + c with the columns of a and b equal, fitted to one record of white noise.
a and b trade along a + b = const (neither identified alone); a + b is what the record
shows, its σ the one-slope fit's; a − b is not determined."""

from __future__ import annotations

import numpy as np
import pytest

from estimation.stats.fit_statistics import FitStatistics
from estimation.stats.identify import honest_statistics

N = 400


def _fits() -> tuple[FitStatistics, float]:
    """The fit of (a, b, c) and the σ of the slope of the one-slope fit of (a + b, c)."""
    rng = np.random.default_rng(3)
    t = np.arange(N) * 0.1
    x = 0.7 * t + 1.0 + 0.05 * rng.standard_normal(N)
    one = np.column_stack([t, np.ones(N)])
    theta = np.linalg.lstsq(one, x, rcond=None)[0]
    residual = x - one @ theta
    slope_std = float(honest_statistics(residual, -one, 2, (N,)).std[0])
    both = np.column_stack([t, t, np.ones(N)])  # a and b enter alike
    ident = honest_statistics(residual, -both, 3, (N,))
    values = np.array([theta[0] / 2, theta[0] / 2, theta[1]])
    fit = FitStatistics(
        effects=(),
        names=("a", "b", "c"),
        values=values,
        residuals=(residual,),
        **ident.fit_fields(),
    )
    return fit, slope_std


def test_each_of_two_trading_terms_is_unknown_and_their_sum_is_known():
    fit, slope_std = _fits()
    assert np.isnan(fit.std[:2]).all() and np.isfinite(fit.std[2])
    # a + b: the slope's σ (the white one on n − 3 against n − 2 degrees of freedom)
    assert fit.combination_std(np.array([1.0, 1.0, 0.0])) == pytest.approx(slope_std, rel=0.01)
    assert fit.combination_std(np.array([1.0, -1.0, 0.0])) is None  # along the trade
    assert fit.combination_std(np.array([1.0, 0.0, 0.0])) is None  # a alone
    assert fit.combination_std(np.array([0.0, 0.0, 2.0])) == pytest.approx(2 * fit.std[2])


def test_a_combination_of_a_coefficient_whose_sigma_was_withdrawn_has_none():
    fit, _ = _fits()
    withdrawn = fit.without_sigma(("c",))
    assert withdrawn.combination_std(np.array([0.0, 0.0, 1.0])) is None
    assert withdrawn.combination_std(np.array([1.0, 1.0, 0.0])) is not None
