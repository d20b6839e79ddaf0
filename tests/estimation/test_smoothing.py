"""``estimation.stats.smoothing.savgol`` is SciPy's ``savgol_filter`` (mode "interp") to
rounding: interior and both ends, every derivative the estimators use, any sample step."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import savgol_filter

from estimation.stats.smoothing import savgol


@pytest.mark.parametrize("window", [5, 7, 9])
@pytest.mark.parametrize("deriv", [0, 1, 2])
@pytest.mark.parametrize("size", [9, 10, 31, 400])
def test_savgol_equals_scipys_filter(window, deriv, size):
    rng = np.random.default_rng(size + 10 * window + deriv)
    delta = 0.1 * (1 + rng.random())
    t = np.arange(size) * delta
    y = np.sin(3 * t) + 0.01 * rng.standard_normal(size) + 5.0
    ours = savgol(y, window, 2, deriv=deriv, delta=delta)
    scipys = savgol_filter(y, window, 2, deriv=deriv, delta=delta)
    np.testing.assert_allclose(ours, scipys, rtol=0, atol=1e-12 * np.max(np.abs(scipys)))


def test_a_filter_of_a_quadratic_is_exact_at_both_ends():
    """Order 2 reproduces a parabola and its derivatives everywhere, ends included."""
    t = np.arange(50) * 0.1
    y = 1.0 + 2.0 * t - 0.7 * t**2
    np.testing.assert_allclose(savgol(y, 7, 2, deriv=1, delta=0.1), 2.0 - 1.4 * t, atol=1e-10)
    np.testing.assert_allclose(savgol(y, 7, 2, deriv=2, delta=0.1), np.full(50, -1.4), atol=1e-9)
