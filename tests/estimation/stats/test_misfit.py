"""The one rule that calls a residual structured (``estimation.stats.misfit``), on residuals
made here: white noise at its floor, a short record far above it, a long correlated one."""

from __future__ import annotations

import numpy as np
import pytest

from estimation.stats.misfit import ABOVE_FLOOR, effective_sample_size, excess_p, structured


def test_white_noise_has_its_full_sample_size_and_a_correlated_residual_far_less():
    rng = np.random.default_rng(0)
    white = rng.standard_normal(4000)
    ar = np.empty(4000)
    ar[0] = 0.0
    for i in range(1, ar.size):  # AR(1), ρ = 0.9: n_eff ≈ n·0.1/1.9
        ar[i] = 0.9 * ar[i - 1] + rng.standard_normal()
    assert effective_sample_size([white]) == pytest.approx(4000, rel=0.05)
    assert effective_sample_size([ar]) == pytest.approx(4000 * 0.1 / 1.9, rel=0.25)


def test_a_residual_at_its_floor_is_never_structured_whatever_its_whiteness():
    """A quantized encoder's residual at a steady speed is never white but sits at the floor."""
    assert not structured(0.0, 1.2, 5000.0)
    assert not structured(0.0, ABOVE_FLOOR * 0.99, 5000.0)


def test_a_short_record_far_above_its_floor_is_structured_though_ljung_box_cannot_say_so():
    """Ten Cate E1's whole record: 10.6× its floor, Ljung–Box p 0.16 on 24 points."""
    assert excess_p(10.6, 3.0) < 1e-3
    assert structured(0.16, 10.6, 3.0)


def test_a_few_effective_samples_just_above_the_floor_are_not_enough():
    """Ratio 3.2 on one effective sample: P[χ²(1) ≥ 10.2] ≈ 1.4e-3, not decisive."""
    assert excess_p(3.2, 1.0) == pytest.approx(1.4e-3, rel=0.05)
    assert not structured(0.5, 3.2, 1.0)
    assert structured(1e-4, 3.2, 1.0)
