"""``estimation.stats.smoothing.savgol`` is SciPy's ``savgol_filter`` (mode "interp") to
rounding: interior and both ends, every derivative the estimators use, any sample step."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import savgol_filter

from estimation.stats.smoothing import running_median, savgol


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


@pytest.mark.parametrize("window", [7, 21, 41])
@pytest.mark.parametrize("deriv", [1, 2])
@pytest.mark.parametrize("order", [2, 4])  # 4: SG_POLYORDER
def test_savgol_equals_scipys_filter_on_a_pendulums_windows(window, order, deriv):
    """The pendulum's equation error filters with a quartic over a sixth of a period. There
    SciPy rounds at up to ~10⁻¹⁰ of the signal (its edge fit takes x⁴ at positions up to
    w − 1 = 40: 2.6·10⁶); ours, on positions in [−1, 1], is nearer the exact value (below)."""
    rng = np.random.default_rng(window + order)
    delta = 0.02
    t = np.arange(1500) * delta
    y = 0.2 * np.exp(-0.05 * t) * np.cos(2.5 * t) + 1e-4 * rng.standard_normal(t.size)
    ours = savgol(y, window, order, deriv=deriv, delta=delta)
    scipys = savgol_filter(y, window, order, deriv=deriv, delta=delta)
    np.testing.assert_allclose(ours, scipys, rtol=0, atol=1e-9 * np.max(np.abs(scipys)))


def test_a_quartic_filter_of_a_quartic_is_exact_to_rounding_at_both_ends():
    t = np.arange(300) * 0.02
    y = 0.3 - 0.2 * t + 0.05 * t**2 - 0.01 * t**3 + 0.002 * t**4
    exact = 0.1 - 0.06 * t + 0.024 * t**2
    for window in (7, 41):
        ours = savgol(y, window, 4, deriv=2, delta=0.02)
        np.testing.assert_allclose(ours, exact, rtol=0, atol=1e-11)  # SciPy's: 2·10⁻¹⁰


@pytest.mark.parametrize("size", [1, 3, 5, 9])
@pytest.mark.parametrize("n", [1, 2, 4, 9, 10, 257])
def test_running_median_is_scipys_median_filter_to_the_bit(size, n):
    """The window finder's running median (sizes 5 and 9) is ``median_filter(mode="nearest")``
    exactly, ends included: an odd window's median is one of its samples, ties and repeated
    values (an encoder's steps) too."""
    from scipy.ndimage import median_filter

    rng = np.random.default_rng(n + 100 * size)
    for x in (rng.standard_normal(n), np.round(rng.standard_normal(n) * 3) * 0.25):
        ours = running_median(x, size)
        np.testing.assert_array_equal(ours, median_filter(x, size=size, mode="nearest"))


def test_running_median_of_samples_not_all_finite_is_scipys():
    from scipy.ndimage import median_filter

    x = np.array([0.0, 1.0, np.nan, 3.0, np.inf, 2.0, -1.0])
    np.testing.assert_array_equal(running_median(x, 5), median_filter(x, size=5, mode="nearest"))
