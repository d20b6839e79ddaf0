"""Residual diagnostics: RMSE, Ljung–Box whiteness, force-domain residual, regressor correlation."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_filter
from scipy.stats import chi2

from estimation.axis.effects import EFFECTS
from estimation.axis.model import ParamView, PreparedRun
from estimation.axis.output_error import FitResult


@dataclass(frozen=True)
class Whiteness:
    """Ljung–Box test Q = n(n+2)·Σ_k ρ_k²/(n − k), summed over runs; p from χ²(Σ lags)."""

    q_statistic: float
    lags: int
    p_value: float


def ljung_box(residuals: Sequence[np.ndarray], max_lag: int = 10) -> Whiteness:
    """Ljung–Box whiteness of each run's residual, pooled over runs."""
    q_total, lags_total = 0.0, 0
    for r in residuals:
        r = np.asarray(r, dtype=float) - np.mean(r)
        n = r.size
        h = min(max_lag, n // 5)
        denom = float(r @ r)
        if h < 1 or denom <= 0:
            continue
        rho = np.array([float(r[:-k] @ r[k:]) / denom for k in range(1, h + 1)])
        q_total += n * (n + 2) * float(np.sum(rho**2 / (n - np.arange(1, h + 1))))
        lags_total += h
    p = float(chi2.sf(q_total, lags_total)) if lags_total else 1.0
    return Whiteness(q_total, lags_total, p)


def smoothed_derivatives(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First and second time derivative of samples y(t) at the sample times.

    Resampled to a uniform grid (irregular timestamps would otherwise read as noise),
    smoothed by a 7-point Savitzky–Golay filter and mapped back.
    """
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.1
    grid = np.arange(t[0], t[-1] + 0.5 * dt, dt)
    if grid.size < 7:
        d1 = np.gradient(y, t) if t.size > 1 else np.zeros_like(y)
        return d1, np.gradient(d1, t) if t.size > 1 else np.zeros_like(y)
    yy = np.interp(grid, t, y)
    d1 = savgol_filter(yy, 7, 2, deriv=1, delta=dt)
    d2 = savgol_filter(yy, 7, 2, deriv=2, delta=dt)
    return np.interp(t, grid, d1), np.interp(t, grid, d2)


def force_residuals(fit: FitResult, runs: Sequence[PreparedRun]) -> list[np.ndarray]:
    """Force-domain residual per run (N or N·m): the force the model misses, linearised.

    For a position residual r(t) about the model trajectory v(t):
        τ_res ≈ M_tot·r̈ + (K_L + 2K_Q·|v| + 3K_C·v²)·ṙ + k_s·r
    with ṙ, r̈ from smoothed derivatives of r (model derivatives are exact, so fast
    transients do not bias it).
    """
    return [
        _force_of(fit, r, res, v)
        for r, res, v in zip(runs, fit.residuals, fit.velocities, strict=True)
    ]


def _force_of(fit: FitResult, run: PreparedRun, res: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The linearised force of one run's position residual ``res`` (see force_residuals):
    each term's own stiffness −θ·∂φ/∂x and damping −θ·∂φ/∂v along the model motion."""
    d1, d2 = smoothed_derivatives(run.t, res)
    p = ParamView(fit.values[None, :], fit.effects)
    x = run.x - run.x[0]
    damping, stiffness = np.zeros_like(v), np.zeros_like(v)
    for c in p.forces:
        damping = damping - c.value[0, 0] * c.term.dphi_dv(x, v)
        stiffness = stiffness - c.value[0, 0] * c.term.dphi_dx(x, v)
    return p.total_inertia(run)[0] * d2 + damping * d1 + stiffness * res


NOISE_WINDOW = 20  # samples per window of the noise estimate
NOISE_QUANTILE = 25  # percentile of the windows' estimates taken as the noise


def position_noise(residuals: Sequence[np.ndarray]) -> float:
    """White-noise σ of position residuals from third differences (var Δ³r = 20σ²).

    In windows of ``NOISE_WINDOW`` samples, the lower quartile of the windows over all runs.
    Third differences cancel smooth structure up to a quadratic, so a force the model lacks
    barely raises the estimate, while the scatter of the encoder and the clock stays.
    """
    estimates = []
    for r in residuals:
        d = np.diff(np.asarray(r, dtype=float), 3)
        for k in range(0, max(d.size - NOISE_WINDOW // 2, 1), NOISE_WINDOW):
            w = d[k : k + NOISE_WINDOW]
            if w.size >= NOISE_WINDOW // 2:
                estimates.append(float(np.sqrt(np.mean(w**2) / 20.0)))
    return float(np.percentile(estimates, NOISE_QUANTILE)) if estimates else 0.0


def force_noise_floor(fit: FitResult, runs: Sequence[PreparedRun], draws: int = 4) -> float:
    """RMS force residual that white position noise of each run's own σ would produce.

    The fit implies this floor: the same derivative filter and model terms applied to
    white noise at the scatter ``position_noise`` measures (fixed seed: reproducible).
    Only moving samples count, as in ``unexplained``.
    """
    rng = np.random.default_rng(12345)
    total, count = 0.0, 0
    sigma = position_noise(fit.residuals)
    for r, res, v in zip(runs, fit.residuals, fit.velocities, strict=True):
        moving = r.t > r.t_release
        for _ in range(draws):
            f = _force_of(fit, r, rng.normal(0.0, sigma, res.size), v)[moving]
            total += float(f @ f)
            count += f.size
    return float(np.sqrt(total / count)) if count else 0.0


def noise_floor_ratio(fit: FitResult, runs: Sequence[PreparedRun]) -> float:
    """Pooled RMS force residual of the moving samples over the noise floor the fit implies
    (≈ 1 when only noise is left)."""
    forces = np.concatenate(
        [f[r.t > r.t_release] for f, r in zip(force_residuals(fit, runs), runs, strict=True)]
    )
    floor = force_noise_floor(fit, runs)
    rms = float(np.sqrt(np.mean(forces**2))) if forces.size else 0.0
    return rms / floor if floor > 0 else (np.inf if rms > 0 else 1.0)


def regressor_correlations(
    fit: FitResult, runs: Sequence[PreparedRun], force_res: Sequence[np.ndarray]
) -> dict[str, float]:
    """Partial correlation of the pooled force residual with each effect's regressor.

    Both are first made orthogonal to the base model's own regressors (v̇, v, |v|·v), since
    whatever lies along those was already absorbed by M, K_L and K_Q. Sign: positive means
    adding the effect with a positive value would explain the residual.
    """
    base: list[np.ndarray] = []
    regressors = [e for e in EFFECTS if EFFECTS[e].role != "timing"]
    cols: dict[str, list[np.ndarray]] = {k: [] for k in regressors}
    for r, offset, v in zip(runs, fit.offsets, fit.velocities, strict=True):
        a = np.gradient(v, r.t) if r.t.size > 1 else np.zeros_like(v)
        base.append(np.column_stack([a, v, np.abs(v) * v]))
        for name in regressors:
            cols[name].append(EFFECTS[name].regressor(r.x - offset, v, a, r.weight_equivalent))
    h = np.vstack(base)
    h_pinv = np.linalg.pinv(h)
    res = np.concatenate(force_res)
    res = res - h @ (h_pinv @ res)
    out = {}
    for name, parts in cols.items():
        reg = np.concatenate(parts)
        reg = reg - h @ (h_pinv @ reg)
        denom = float(np.linalg.norm(res) * np.linalg.norm(reg))
        out[name] = float(res @ reg) / denom if denom > 0 else 0.0
    return out
