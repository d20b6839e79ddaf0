"""Residual diagnostics: RMSE, Ljung–Box whiteness, force-domain residual, regressor correlation."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_filter
from scipy.stats import chi2

from estimation.effects import STANDARD_GRAVITY
from estimation.model import PreparedRun
from estimation.output_error import FitResult


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


def measured_derivatives(run: PreparedRun) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and acceleration of the measured positions (Savitzky–Golay, 7 samples)."""
    dt = float(np.median(np.diff(run.t))) if run.t.size > 1 else 0.1
    if run.t.size < 7:
        v = np.gradient(run.x, run.t)
        return v, np.gradient(v, run.t)
    v = savgol_filter(run.x, 7, 2, deriv=1, delta=dt)
    a = savgol_filter(run.x, 7, 2, deriv=2, delta=dt)
    return v, a


def force_residuals(fit: FitResult, runs: Sequence[PreparedRun]) -> list[np.ndarray]:
    """Force-domain residual τ − (model forces) on measured derivatives, per run (N or N·m)."""
    out = []
    for r, offset in zip(runs, fit.offsets, strict=True):
        v, a = measured_derivatives(r)
        inertia = fit.value("inertia") + r.extra_inertia
        inertia += fit.value("drive_inertia") * r.mean_abs_drive / STANDARD_GRAVITY
        moving = r.t > r.t_release + fit.value("release_delay")
        drive = np.where(moving, r.drive + fit.value("constant_bias"), 0.0)
        friction = fit.value("coulomb_friction") * np.sign(v) * moving
        model = (
            inertia * a
            + fit.value("linear_damping") * v
            + fit.value("quadratic_damping") * np.abs(v) * v
            + fit.value("cubic_drag") * v**3
            + fit.value("restoring_spring") * (r.x - offset) * moving
            + friction
        )
        out.append(drive - model)
    return out


def regressor_correlations(
    fit: FitResult, runs: Sequence[PreparedRun], force_res: Sequence[np.ndarray]
) -> dict[str, float]:
    """Correlation of the pooled force residual with each effect's signature regressor."""
    cols: dict[str, list[np.ndarray]] = {
        k: []
        for k in (
            "coulomb_friction",
            "constant_bias",
            "drive_inertia",
            "restoring_spring",
            "cubic_drag",
        )
    }
    for r, offset, v_model in zip(runs, fit.offsets, fit.velocities, strict=True):
        _, a = measured_derivatives(r)
        cols["coulomb_friction"].append(-np.sign(v_model))
        cols["constant_bias"].append(np.ones_like(v_model))
        cols["drive_inertia"].append(-a * r.mean_abs_drive)
        cols["restoring_spring"].append(-(r.x - offset))
        cols["cubic_drag"].append(-(v_model**3))
    res = np.concatenate(force_res)
    out = {}
    for name, parts in cols.items():
        reg = np.concatenate(parts)
        if np.std(reg) == 0 or np.std(res) == 0:
            # a constant regressor: correlation is undefined, report the normalised mean
            out[name] = float(np.mean(res * reg) / (np.sqrt(np.mean(res**2)) or 1.0))
        else:
            out[name] = float(np.corrcoef(res, reg)[0, 1])
    return out
