"""The quantization σ (``estimation.stats.quantization``) on a model-free problem: a slow
uniformly accelerated motion x = a_r + A·t² in three records (one offset a_r each, a common
A), read by an encoder of step 1 with one unknown phase per record, fitted by linear least
squares. A travels 4 counts over a record of 12 s: long steps of one count, the error a
slowly varying staircase correlated over the whole record."""

from __future__ import annotations

import numpy as np
import pytest

from estimation.stats.identify import honest_statistics
from estimation.stats.quantization import encoder_step

SIZES = (120, 100, 140)
ACCELERATION = 0.03  # counts/s² (half of it): 4.3 counts over the longest record
MEDIAN_ABS_Z_MIN = 0.34  # as in test_term_coverage: 0.674 − 3 × 0.11


def _design():
    t = [np.arange(n) * 0.1 for n in SIZES]
    design = np.zeros((sum(SIZES), 1 + len(SIZES)))
    design[:, 0] = np.concatenate([tr**2 for tr in t])
    start = 0
    for r, n in enumerate(SIZES):
        design[start : start + n, 1 + r] = 1.0
        start += n
    return design


DESIGN = _design()


def _fit(rng, noise=0.0):
    """One campaign: (error of A, reported σ, white σ, quantization σ)."""
    phase = np.repeat(rng.uniform(0.0, 1.0, len(SIZES)), SIZES)
    x = ACCELERATION * DESIGN[:, 0] + phase + noise * rng.standard_normal(DESIGN.shape[0])
    measured = np.round(x)
    theta = np.linalg.lstsq(DESIGN, measured, rcond=None)[0]
    fitted = DESIGN @ theta
    ident = honest_statistics(measured - fitted, -DESIGN, 1, SIZES, fitted, [1.0] * len(SIZES))
    assert ident.std_quantization is not None
    return (
        theta[0] - ACCELERATION,
        float(ident.std[0]),
        float(ident.std_white[0]),
        float(ident.std_quantization[0]),
    )


def test_quantization_sigma_is_the_spread_over_the_unknown_phase():
    """Over 1000 phases the estimate's spread is the quantization σ (within 10 %: the
    Monte Carlo sd is known to ±2.2 %, and x̂ is the fit's, not the truth), and twice the
    white σ, which therefore covers in fewer than 80 % of the campaigns."""
    rows = np.array([_fit(np.random.default_rng(seed)) for seed in range(1000)])
    spread = rows[:, 0].std()
    assert np.mean(rows[:, 3]) == pytest.approx(spread, rel=0.10)
    assert np.mean(rows[:, 2]) < 0.6 * spread
    assert np.mean(np.abs(rows[:, 0]) <= 2 * rows[:, 2]) < 0.80


def test_reported_sigma_covers_and_is_not_absurdly_wide():
    rows = np.array([_fit(np.random.default_rng(10_000 + seed)) for seed in range(400)])
    z = np.abs(rows[:, 0]) / rows[:, 1]
    assert np.mean(z <= 2) >= 0.90
    assert np.median(z) >= MEDIAN_ABS_Z_MIN
    assert np.all(rows[:, 1] >= rows[:, 3]) and np.all(rows[:, 1] >= rows[:, 2])


def test_noise_that_dithers_the_encoder_leaves_the_white_sigma():
    """Noise of σ_w = 1 count before the quantizer makes its error white (the correlated
    harmonics are damped by exp(−(2πσ_w)²)): the quantization σ is the white σ."""
    for seed in range(20):
        _, _, white, quantization = _fit(np.random.default_rng(seed), noise=1.0)
        assert quantization == pytest.approx(white, rel=0.02)


def test_encoder_step_is_read_from_a_record_on_a_grid():
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 20.0, 0.1)
    fast = 0.3137 * t**2 + 0.4213 * t  # 4 mm in the first 0.1 s: never a change of one count
    on_grid = np.round((fast + rng.uniform(0, 1e-4)) / 1e-4) * 1e-4
    assert encoder_step(on_grid) == pytest.approx(1e-4, rel=1e-9)
    assert encoder_step(on_grid + 2.5) == pytest.approx(1e-4, rel=1e-6)  # float rounding
    assert encoder_step(fast + 1e-5 * rng.standard_normal(t.size)) == 0.0  # not on a grid
    assert encoder_step(np.r_[np.zeros(50), np.full(50, 1e-4)]) == 0.0  # one change
    assert encoder_step(np.zeros(10)) == 0.0


def test_a_search_reads_each_records_encoder_step_once(monkeypatch):
    """``fit_motion`` needs each record's step for the quantization σ of every fit a search
    makes; the record does not change between them, so the step is read once (≈ 1 ms each)
    and every fit still carries the quantization σ."""
    from scipy.integrate import solve_ivp

    import estimation.motion.output_error_fit as motion_fit
    import estimation.motion.record_derivatives as readings
    from estimation.motion.records import Record, Setup

    t = np.arange(0.0, 20.0, 0.1)
    sol = solve_ivp(
        lambda _t, y: [y[1], -(0.4 * y[1] + 40.0 * y[0]) / 10.0],
        (0.0, t[-1]),
        [0.05, 0.0],
        t_eval=t,
        rtol=1e-10,
        atol=1e-12,
    )
    record = Record("decay", t, 1e-4 * np.round(sol.y[0] / 1e-4))
    reads: list[float] = []

    def counted(x):
        reads.append(encoder_step(x))
        return reads[-1]

    monkeypatch.setattr(readings, "encoder_step", counted)
    readings._record_step.cache_clear()
    setup = Setup("heave")
    fits = [motion_fit.fit_motion([record], setup, effects) for effects in ((), ("cubic_drag",))]
    assert reads == [pytest.approx(1e-4, rel=1e-6)]
    assert all(f.std_quantization is not None for f in fits)
