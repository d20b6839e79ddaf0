"""When a fit's residual is structure rather than noise: one rule for every record kind.

A correct model leaves a residual at the noise floor the fit itself implies (ratio ≈ 1) and,
for most records, white. The residual is called **structured** (the coefficients may be
biased by something the model lacks) when it is well above that floor — RMS more than
``ABOVE_FLOOR`` × the floor — and that excess is not chance: either Ljung–Box rejects
whiteness (p < ``WHITE_P``), or the mean square itself is too large for noise at the floor
on the residual's *effective* sample size,

    p = P[χ²(n_eff) ≥ n_eff · ratio²] < WHITE_P,    n_eff = n·(1 − r₁)/(1 + r₁),

(r₁: the pooled lag-1 autocorrelation; the AR(1) variance inflation). The second test is what
a short record can reach: Ljung–Box needs tens of lags' worth of samples for p < 1e-3, which
a 24-point digitized record never has (ten Cate E1's whole record sits at 12.7× its floor);
counting on n_eff rather than n keeps a long, smoothly correlated residual from passing it
on sample count alone. Neither test alone flags a residual at the floor: a quantized
encoder's residual at a steady speed is never white (its error repeats with the fraction of
a count moved per sample) and is still at the floor.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Ljung–Box p (or the excess's p) below this: decisive, not chance.
WHITE_P = 1e-3
#: Residual RMS over the fit's own noise floor that counts as structure.
ABOVE_FLOOR = 3.0


def lag_one(*residuals: np.ndarray) -> float:
    """The pooled lag-1 autocorrelation r₁ of the residuals, clipped to [0, 0.999] (a
    negative one does not add information)."""
    arrays = [np.asarray(r, dtype=float) for r in residuals]
    num = sum(float(r[:-1] @ r[1:]) for r in arrays if r.size > 1)
    den = sum(float(r @ r) for r in arrays)
    return min(max(num / den, 0.0), 0.999) if den > 0 else 0.0


def ar1_inflation(r1: float) -> float:
    """(1 + r₁)/(1 − r₁): the factor by which an AR(1) residual of lag-1 autocorrelation
    r₁ inflates the variance of a mean over it (n_eff = n / this), r₁ clipped to
    [0, 0.999] as ``lag_one`` clips it."""
    r1 = min(max(float(r1), 0.0), 0.999)
    return (1 + r1) / (1 - r1)


def effective_sample_size(residuals: Sequence[np.ndarray]) -> float:
    """n·(1 − r₁)/(1 + r₁) from the pooled lag-1 autocorrelation r₁ of the residuals."""
    size = sum(np.asarray(r).size for r in residuals)
    return size / ar1_inflation(lag_one(*residuals))


def excess_p(ratio: float, n_eff: float) -> float:
    """P[χ²(n_eff) ≥ n_eff·ratio²]: how likely noise at the floor gives a residual mean
    square ``ratio``² times the floor's on ``n_eff`` effective samples."""
    if not np.isfinite(ratio) or n_eff <= 0:
        return 0.0 if ratio > 1 else 1.0
    from scipy.special import gammaincc  # here: the service imports this module

    return float(gammaincc(n_eff / 2.0, n_eff * ratio**2 / 2.0))


def structured(ljung_box_p: float, ratio: float, n_eff: float) -> bool:
    """The module's rule: above ``ABOVE_FLOOR`` × the floor, and decisively so by
    Ljung–Box or by the excess on ``n_eff``."""
    if not ratio > ABOVE_FLOOR:
        return False
    return ljung_box_p < WHITE_P or excess_p(ratio, n_eff) < WHITE_P
