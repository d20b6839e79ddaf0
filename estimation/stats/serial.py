"""Long-run covariance of least-squares scores when the residual is correlated in time within
each record (records are concatenated and independent of one another).

A least-squares estimate θ̂ moves with the scores gₜ = Jₜᵀ·eₜ (Jₜ the Jacobian row, eₜ the
residual of sample t). With white residuals Var(Σ gₜ) = σ̂²·JᵀJ; with serially correlated ones
it is the long-run covariance S, estimated per record r and summed (no lag crosses a record
boundary) by Newey and West's (1987) Bartlett-kernel estimator after AR(1) prewhitening
(Andrews and Monahan 1992, the default of R's ``sandwich::NeweyWest``)::

    ρ_r    = lag-1 autocorrelation of the record's residual, bias-corrected (below), ±RHO_MAX
    g*ₜ    = gₜ − ρ_r·gₜ₋₁                                   (prewhitened scores)
    S*_r   = Γ*(0) + Σ_{l=1}^{L_r} (1 − l/(L_r + 1))·(Γ*(l) + Γ*(l)ᵀ),  Γ*(l) = Σₜ g*ₜ·g*ₜ₋ₗᵀ
    S      = Σ_r S*_r / (1 − ρ_r)²                            (recoloured)
    cov    = n/(n − p) · (JᵀJ)⁻¹·S·(JᵀJ)⁻¹

(the arithmetic of ``statsmodels.stats.sandwich_covariance.S_nw_panel`` with
``weights_bartlett``, written here in NumPy so an estimate does not import statsmodels and
pandas; tests/estimation/stats/test_serial_sigma.py checks the two agree; the Bartlett
weights keep S positive semi-definite.) Prewhitening removes most of the Bartlett
estimator's downward bias on strongly correlated residuals, where a truncated kernel
alone sums too little of the correlation (on tows with AR(1) noise of ρ = 0.8 the 2σ
coverage of the damping was 44/50 without it, 47/50 with it).

The sample lag-1 autocorrelation of a residual with its mean removed is biased low by about
(1 + 3ρ)/n (Kendall 1954; Marriott and Pope 1954), and the recolouring 1/(1 − ρ)² magnifies
that near 1: on 200-sample tows with AR(1) noise of ρ = 0.9 the fit's residual gave ρ̂ 0.85
on average (20 runs: 0.75–0.92) and the 2σ coverage of K_Q was 43/50 at every scale (10,
143, 1000 kg). So ρ_r = ρ̂ + (1 + 3ρ̂)/n_r (``prewhitening_rho``): 0.87 on average, S 1.37×
larger, K_Q 45–46/50; white residuals move by 1/n_r.

Bandwidth L_r: Andrews' (1991) plug-in for the Bartlett kernel under an AR(1) approximation
of what is left after prewhitening, L = ⌊1.1447·(α·n_r)^{1/3}⌋, α = 4ρ*²/((1 − ρ*)²·(1 + ρ*)²),
ρ* the lag-1 autocorrelation of eₜ − ρ_r·eₜ₋₁, at most n_r − 2. It is the bandwidth that
minimises the asymptotic mean-squared error of S, and data-dependent: white residuals give
L = 0 and S = Σ gₜgₜᵀ (the white formula with each sample's own e²).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from estimation.stats.misfit import effective_sample_size

#: |ρ| above this is treated as this (α and L stay finite; L is capped at n_r − 1 anyway).
RHO_MAX = 0.97


def lag_one_autocorrelation(residual: np.ndarray) -> float:
    """ρ of a record's residual (mean removed), clipped to ±``RHO_MAX``; 0 when flat."""
    e = np.asarray(residual, dtype=float)
    e = e - e.mean()
    energy = float(e @ e)
    if e.size < 3 or energy <= 0.0:
        return 0.0
    return float(np.clip(e[1:] @ e[:-1] / energy, -RHO_MAX, RHO_MAX))


def prewhitening_rho(residual: np.ndarray) -> float:
    """ρ_r of the module doc: the lag-1 autocorrelation with Kendall's small-sample bias
    correction ρ̂ + (1 + 3ρ̂)/n, clipped to ±``RHO_MAX`` (0 when flat or under 3 samples)."""
    rho = lag_one_autocorrelation(residual)
    size = np.asarray(residual).size
    if size < 3 or rho == 0.0:
        return rho
    return float(np.clip(rho + (1.0 + 3.0 * rho) / size, -RHO_MAX, RHO_MAX))


def bartlett_bandwidth(rho: float, size: int) -> int:
    """Andrews' AR(1) plug-in lag window L for a record of ``size`` samples (module doc)."""
    alpha = 4.0 * rho**2 / ((1.0 - rho) ** 2 * (1.0 + rho) ** 2)
    return int(max(min(np.floor(1.1447 * (alpha * size) ** (1.0 / 3.0)), size - 2), 0))


def long_run_scores(
    residuals: np.ndarray, jacobian: np.ndarray, record_sizes: Sequence[int]
) -> np.ndarray:
    """S, the long-run covariance of the scores Jₜᵀeₜ, summed over records (module doc)."""
    e = np.asarray(residuals, dtype=float)
    scores = np.asarray(jacobian, dtype=float) * e[:, None]
    if sum(record_sizes) != e.size:
        raise ValueError(f"record_sizes: sum {sum(record_sizes)}, allowed: {e.size} (samples)")
    meat = np.zeros((scores.shape[1], scores.shape[1]))
    start = 0
    for size in record_sizes:
        block = slice(start, start + size)
        start += size
        if size < 3:
            meat += scores[block].T @ scores[block]
            continue
        rho = prewhitening_rho(e[block])
        whitened = scores[block][1:] - rho * scores[block][:-1]
        rest = lag_one_autocorrelation(e[block][1:] - rho * e[block][:-1])
        lags = bartlett_bandwidth(rest, size - 1)
        meat += bartlett_long_run(whitened, lags) / (1.0 - rho) ** 2
    return meat


def bartlett_long_run(scores: np.ndarray, lags: int) -> np.ndarray:
    """Γ(0) + Σ_{l=1}^{L} (1 − l/(L + 1))·(Γ(l) + Γ(l)ᵀ), Γ(l) = Σₜ gₜ·gₜ₋ₗᵀ, of one
    record's scores (n, p): Newey–West with Bartlett weights, ``lags`` = L."""
    g = np.asarray(scores, dtype=float)
    total = g.T @ g
    for lag in range(1, min(lags, g.shape[0] - 1) + 1):
        gamma = g[lag:].T @ g[:-lag]
        total += (1.0 - lag / (lags + 1.0)) * (gamma + gamma.T)
    return total


@dataclass(frozen=True)
class SerialCovariance:
    """A least-squares fit's covariance on a serially correlated residual: σ the larger of
    the white σ̂²(JᵀJ)⁻¹ and the long-run sandwich, with the sandwich's correlation; the
    white covariance alone; ν = n_eff − p; and its counts (n, n_eff, p) as text."""

    cov: np.ndarray
    cov_white: np.ndarray
    dof: float
    counts: str


def serial_covariance(
    residuals: np.ndarray, jacobian: np.ndarray, record_sizes: Sequence[int] | None = None
) -> SerialCovariance:
    """The covariance of a least-squares estimate (``SerialCovariance``) from its residuals
    and Jacobian (or regressors) over records of ``record_sizes`` samples (default one):
    cov_serial = n/(n − p)·(JᵀJ)⁻¹·S·(JᵀJ)⁻¹ (module doc), ν = n_eff − p (at least 1) with
    n_eff = n·(1 − r₁)/(1 + r₁) (``misfit.effective_sample_size``: the number of independent
    samples an AR(1) residual of lag-1 autocorrelation r₁ ≥ 0 is worth). With no more
    samples than parameters (n ≤ p) the residual is zero by construction and says nothing
    of the noise: every σ is then not known (NaN), ν = 0."""
    e = np.asarray(residuals, dtype=float)
    jac = np.asarray(jacobian, dtype=float)
    sizes = [e.size] if record_sizes is None else list(record_sizes)
    n, p = jac.shape
    if n <= p:
        unknown = np.full((p, p), np.nan)
        return SerialCovariance(unknown, unknown, 0.0, f"n = {n}, p = {p}: no residual")
    inv = np.linalg.pinv(jac.T @ jac)
    white = float(e @ e) / max(n - p, 1) * inv
    serial = n / max(n - p, 1) * (inv @ long_run_scores(e, jac, sizes) @ inv)
    std_serial = np.sqrt(np.maximum(np.diag(serial), 0.0))
    std = np.maximum(np.sqrt(np.maximum(np.diag(white), 0.0)), std_serial)
    denom = np.outer(std_serial, std_serial)
    corr = np.divide(serial, denom, out=np.eye(p), where=denom > 0)
    n_eff = effective_sample_size(np.split(e, np.cumsum(sizes)[:-1]))
    counts = f"n = {n}, n_eff = {n_eff:.0f}, p = {p}"
    return SerialCovariance(np.outer(std, std) * corr, white, max(n_eff - p, 1.0), counts)
