"""Clean records claim no term: 50 seeds of noise on records without any effect, at 10, 143
and 1000 kg (data: ``tests/estimation/term_cases.py``, solve_ivp)."""

from __future__ import annotations

import pytest

from estimation import estimate
from estimation.motion.decay_estimate import estimate_decay
from tests.estimation.term_cases import (
    SCALES,
    decay,
    tow_set,
)


@pytest.mark.slow
@pytest.mark.parametrize("scale", list(SCALES))
def test_clean_decays_claim_no_term_in_98_percent_of_seeds(scale):
    claims = 0
    for seed in range(50):
        t, x, truth = decay(scale, seed)
        r = estimate_decay(t, x, "heave", known_inertia=truth["known"], stiffness=truth["k"])
        claims += bool(r.effects)
    assert claims <= 1


@pytest.mark.slow
@pytest.mark.parametrize("scale", list(SCALES))
def test_clean_tows_claim_no_effect_in_98_percent_of_seeds(scale):
    claims = 0
    for seed in range(50):
        runs = tow_set(scale, seed=100 + seed)
        claims += bool(estimate(runs, n_bootstrap=0).effects)
    assert claims <= 1


#: Known gap (issue 20, open): at 143 kg the inertia's σ is too small on these records: over
#: the 50 seeds z = (θ̂ − θ)/σ has mean 0.09 and RMS 1.31 (41 of 50 inside 2σ), with the
#: within-record serial-correlation σ (``estimation.stats.serial``) as with the white one.
#: The position error is the encoder's quantization of one smooth motion, a deterministic
#: function of the run's dither phase: the inertia's error from a run is 0.7–1.6× (1.32×
#: over the four) what white noise of Q/√12 gives, through correlation between the start
#: and the steady part of the same run (seconds apart), while the residual left by the fit
#: looks white (lag-1 ρ ≈ −0.1): no estimate from the residual sees it (docs/estimation.md).
#: Strict: it fails the day the σ accounts for it, to be turned into a pass.
