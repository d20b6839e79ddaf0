"""Residual diagnostics of any model: Ljung–Box whiteness, smoothed derivatives, the white
position noise of a residual. Depends on no model (the force-domain residual of the tow/spin
equation is ``estimation.axis.force_residual``)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from estimation.stats.smoothing import savgol

SAVGOL_WINDOW = 7  # samples of the derivative filter


@dataclass(frozen=True)
class Whiteness:
    """Ljung–Box test Q = n(n+2)·Σ_k ρ_k²/(n − k), summed over runs; p from χ²(Σ lags)."""

    q_statistic: float
    lags: int
    p_value: float

    def to_json(self) -> dict[str, Any]:
        """{q, lags, p_value} as every result document writes them (null: not computed)."""
        q, p = float(self.q_statistic), float(self.p_value)
        return {
            "q": q if math.isfinite(q) else None,
            "lags": self.lags,
            "p_value": p if math.isfinite(p) else None,
        }


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
    # χ² survival function (scipy.stats.chi2.sf calls chdtrc; scipy.stats costs ~0.4 s to import)
    from scipy.special import chdtrc  # here: the service imports this module

    p = float(chdtrc(lags_total, q_total)) if lags_total else 1.0
    return Whiteness(q_total, lags_total, p)


def smoothed_derivatives(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First and second time derivative of samples y(t) at the sample times.

    Resampled to a uniform grid (irregular timestamps would otherwise read as noise),
    smoothed by a quadratic Savitzky–Golay filter of ``SAVGOL_WINDOW`` points (the largest
    odd window the grid holds, at least 5; else finite differences) and mapped back.
    """
    if t.size < 2:
        return np.zeros_like(y), np.zeros_like(y)
    dt = float(np.median(np.diff(t)))
    grid = np.arange(t[0], t[-1] + 0.5 * dt, dt)
    w = min(SAVGOL_WINDOW, grid.size - (1 - grid.size % 2))
    if w < 5:
        d1 = np.gradient(y, t)
        return d1, np.gradient(d1, t)
    yy = np.interp(grid, t, y)
    d1 = savgol(yy, w, 2, deriv=1, delta=dt)
    d2 = savgol(yy, w, 2, deriv=2, delta=dt)
    return np.interp(t, grid, d1), np.interp(t, grid, d2)


NOISE_WINDOW = 20  # samples per window of the noise estimate
NOISE_QUANTILE = 25  # percentile of the windows' estimates taken as the noise


def third_differences(t: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Normalised third divided differences of samples r(t): for each four consecutive
    samples, d = Σ wᵢ·rᵢ / ‖w‖ with wᵢ = 1/Πⱼ≠ᵢ(tᵢ − tⱼ) (the divided-difference weights).

    d is zero for any quadratic in t, whatever the spacing, and has variance σ² for white
    noise of σ (the weights are normalised). On a uniform grid w ∝ (−1, 3, −3, 1), so
    d = Δ³r/√20 (var Δ³r = 20σ²). The plain Δ³r of an irregularly sampled record cancels
    not even a straight line: on a 30-point irregular decay it read a linear model's
    misfit as noise (floor 0.2–0.5 mm, 3–10× what the divided differences give, the
    residual then 1.3–3.5× its "floor")."""
    t, r = np.asarray(t, dtype=float), np.asarray(r, dtype=float)
    if r.size < 4:
        return np.empty(0)
    w = _divided_difference_weights(t.tobytes())
    return np.sum(w * np.lib.stride_tricks.sliding_window_view(r, 4), axis=1)


@lru_cache(maxsize=8)  # the records of one estimate (each entry holds its times as key)
def _divided_difference_weights(t_bytes: bytes) -> np.ndarray:
    """``third_differences``' normalised weights of each four consecutive sample times
    (read-only): one search reads the noise of many residuals on the same records' times."""
    span = np.lib.stride_tricks.sliding_window_view(np.frombuffer(t_bytes), 4)
    gaps = span[:, :, None] - span[:, None, :]  # tᵢ − tⱼ per window
    gaps[:, np.arange(4), np.arange(4)] = 1.0
    w = 1.0 / np.prod(gaps, axis=2)
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    w.flags.writeable = False
    return w


def position_noise(
    residuals: Sequence[np.ndarray], times: Sequence[np.ndarray] | None = None
) -> float:
    """White-noise σ of position residuals from normalised third divided differences
    (``third_differences``; ``times``: each residual's sample times in s, None: a uniform
    grid).

    In windows of ``NOISE_WINDOW`` samples, the lower quartile of the windows over all runs.
    Third differences cancel smooth structure up to a quadratic in t, so a force the model
    lacks barely raises the estimate, while the scatter of the encoder and the clock stays.
    """
    estimates = []
    for i, r in enumerate(residuals):
        r = np.asarray(r, dtype=float)
        t = np.arange(r.size, dtype=float) if times is None else np.asarray(times[i], float)
        d = third_differences(t, r)
        # windows start every NOISE_WINDOW samples while at least half a window is left;
        # the whole ones at once (each row's mean is the same sum as the window's own)
        starts = range(0, max(d.size - NOISE_WINDOW // 2, 1), NOISE_WINDOW)
        whole = sum(1 for k in starts if k + NOISE_WINDOW <= d.size)
        rows = d[: whole * NOISE_WINDOW].reshape(whole, NOISE_WINDOW)
        estimates.extend(np.sqrt(np.mean(rows**2, axis=1)).tolist())
        if len(starts) > whole:  # the last window, shorter (at least half of one)
            w = d[whole * NOISE_WINDOW : whole * NOISE_WINDOW + NOISE_WINDOW]
            if w.size >= NOISE_WINDOW // 2:
                estimates.append(float(np.sqrt(np.mean(w**2))))
    return float(np.percentile(estimates, NOISE_QUANTILE)) if estimates else 0.0
