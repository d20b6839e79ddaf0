"""The output-error fit of a tow or spin set: the one equation's fit
(``estimation.motion.output_error_fit.fit_motion``) on the runs as records at rest until
their release, from this kind's own start values.

Minimises Σ_runs Σ_samples (x_meas − x0_run − X(t; θ))², θ = (M, K_L, K_Q, effects...),
one rest position x0 per run as a nuisance parameter (``MotionFit.equilibrium``). Standard
errors as every kind's (``estimation.stats.identify.honest_statistics``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from estimation.axis.model import records_of, setup_of, simulate
from estimation.axis.prepared_run import PreparedRun
from estimation.motion.output_error_fit import (
    MotionFit,
    fit_motion,
    leave_one_record_out,
    names_of,
)
from estimation.motion.terms import LIBRARY
from estimation.stats.smoothing import savgol


def _equation_error_guess(runs: Sequence[PreparedRun]) -> np.ndarray:
    """(M, K_L, K_Q) by least squares on smoothed derivatives: τ − M_drive·a = M·a + K_L·v + …"""
    rows, rhs = [], []
    for r in runs:
        moving = r.t > r.t_release
        if np.count_nonzero(moving) < 9:
            continue
        t, x = r.t[moving], r.x[moving]
        dt = float(np.median(np.diff(t)))
        v = savgol(x, 9, 2, deriv=1, delta=dt)
        a = savgol(x, 9, 2, deriv=2, delta=dt)
        rows.append(np.column_stack([a, v, np.abs(v) * v]))
        rhs.append(r.drive[moving] - r.extra_inertia * a)
    if not rows:
        return np.array([np.nan, np.nan, np.nan])
    return np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)[0]


def initial_guess(runs: Sequence[PreparedRun], effects: Sequence[str]) -> np.ndarray:
    """Start values: equation-error least squares, then a vectorized grid over the inertia
    (a tow's transient is short: the derivatives' inertia can be far off)."""
    drives = np.array([r.mean_abs_drive for r in runs])
    speeds = np.array([np.max(np.abs(np.diff(r.x) / np.diff(r.t))) for r in runs]) + 1e-9
    inertia, k_l, k_q = _equation_error_guess(runs)
    k_l = k_l if np.isfinite(k_l) and k_l > 0 else 0.1 * drives.max() / speeds.max()
    k_q = k_q if np.isfinite(k_q) and k_q > 0 else 0.5 * drives.max() / speeds.max() ** 2
    damping = k_l + 2 * k_q * speeds.mean()
    centre = inertia if np.isfinite(inertia) and inertia > 0 else damping
    grid = centre * np.geomspace(0.05, 20.0, 40)
    theta = np.column_stack([grid, np.full_like(grid, k_l), np.full_like(grid, k_q)])
    sims = simulate(theta, (), runs)
    sse = np.zeros(grid.size)
    for r, (x, _) in zip(runs, sims, strict=True):
        res = r.x[None, :] - x
        res -= res.mean(axis=1, keepdims=True)
        sse += np.sum(res**2, axis=1)
    inertia = grid[int(np.argmin(np.nan_to_num(sse, nan=np.inf)))]
    extra = [effect_start(e, runs) for e in effects]
    return np.array([inertia, k_l, k_q, *extra])


def effect_start(name: str, runs: Sequence[PreparedRun]) -> float:
    """The entry's own start value on these runs (its share of the force the smallest
    drive exerts along the measured motion)."""
    force = min(r.mean_abs_drive for r in runs)
    x = np.concatenate([r.x - r.x[0] for r in runs])
    v = np.concatenate([np.gradient(r.x, r.t) for r in runs])
    a = np.concatenate([np.gradient(np.gradient(r.x, r.t), r.t) for r in runs])
    weight = max(r.weight_equivalent for r in runs)
    return LIBRARY[name].start(force, x, v, a, weight)


def fit_output_error(
    runs: Sequence[PreparedRun],
    effects: Sequence[str] = (),
    start: np.ndarray | None = None,
    max_nfev: int = 200,
    quantization_sigma: bool = True,
) -> MotionFit:
    """Fit (M, K_L, K_Q, effects) and one rest position per run to all runs jointly.

    ``start``: the coefficients to start from (else ``initial_guess``). ``max_nfev`` caps
    the model evaluations (the effect search screens with a low cap).
    ``quantization_sigma``: False for a refit whose σ is discarded (a bootstrap draw, a
    leave-one-run-out refit): the encoder's quantization σ (its costliest part) is not
    computed, so ``std`` lacks it and ``std_quantization`` is None.
    """
    effects = tuple(effects)
    g0 = initial_guess(runs, effects) if start is None else np.asarray(start, dtype=float)
    return fit_motion(
        records_of(runs),
        setup_of(runs),
        effects,
        start=g0,
        max_nfev=max_nfev,
        quantization_sigma=quantization_sigma,
    )


def leave_one_run_out_rmse(runs: Sequence[PreparedRun], fit: MotionFit) -> float | None:
    """Leave-one-run-out prediction RMSE (m or rad; ``leave_one_record_out``); None with
    fewer than 3 runs."""
    held = leave_one_record_out(records_of(runs), setup_of(runs), fit)
    return None if held is None else held.rmse


def evaluate_parameters(
    runs: Sequence[PreparedRun],
    values: np.ndarray,
    std: np.ndarray,
    correlation: np.ndarray,
    effects: Sequence[str] = (),
) -> MotionFit:
    """Simulate fixed coefficients (e.g. from a seed approach), refitting only the rest
    positions (each run's mean residual)."""
    effects = tuple(effects)
    values = np.asarray(values, dtype=float)
    sims = simulate(values[None, :], effects, runs)
    residuals, offsets = [], []
    for r, (x, _) in zip(runs, sims, strict=True):
        res = r.x - x[0]
        offsets.append(float(np.mean(res)))
        residuals.append(res - offsets[-1])
    sse = float(sum(float(r @ r) for r in residuals))
    return MotionFit(
        effects=effects,
        names=names_of(setup_of(runs), effects),
        values=values,
        std=np.asarray(std, dtype=float),
        correlation=np.asarray(correlation, dtype=float),
        residuals=tuple(residuals),
        sse=sse,
        n_samples=sum(r.size for r in residuals),
        n_params=values.size + len(runs),
        at_bound=(),
        equilibrium=np.array(offsets),
        initial=np.zeros((len(runs), 2)),
        free=np.zeros(len(runs), dtype=bool),
        displacements=tuple(x[0] for x, _ in sims),
        velocities=tuple(v[0] for _, v in sims),
    )
