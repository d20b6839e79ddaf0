"""Output-error fit: simulate the axis model and fit measured positions of all runs jointly.

Minimises Σ_runs Σ_samples (x_meas − x0_run − X(t; θ))², θ = (M, K_L, K_Q, effects...),
one position offset x0 per run as a nuisance parameter. Standard errors from
``estimation.stats.identify.honest_statistics``, as every kind's (never below σ̂²(JᵀJ)⁻¹,
σ̂² = SSE/(n − p); larger when the residual is correlated within a run; NaN along a
direction the data cannot determine).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from estimation.axis.effects import EFFECTS
from estimation.axis.model import BASE_NAMES, bounded, simulate
from estimation.axis.prepared_run import PreparedRun
from estimation.motion.terms import LIBRARY
from estimation.stats.fit_statistics import FitStatistics
from estimation.stats.identify import honest_statistics
from estimation.stats.out_of_sample import LORO_MIN_RUNS, LORO_NFEV, REFIT_TOLERANCE, pooled_rmse
from estimation.stats.smoothing import savgol

BASE_LOWER = (1e-6, 0.0, 0.0)


@dataclass(frozen=True)
class FitResult(FitStatistics):
    """A converged joint fit: global coefficients with σ, offsets, residuals and evidence."""

    offsets: np.ndarray
    velocities: tuple[np.ndarray, ...]  # model velocity at the samples


def _bounds(effects: Sequence[str], n_runs: int) -> tuple[np.ndarray, np.ndarray]:
    lower = list(BASE_LOWER) + [EFFECTS[e].lower for e in effects] + [-np.inf] * n_runs
    upper = [np.inf] * 3 + [EFFECTS[e].upper for e in effects] + [np.inf] * n_runs
    return np.array(lower, dtype=float), np.array(upper, dtype=float)


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
    """Start values: equation-error least squares, then a vectorized grid over the inertia."""
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


class _Problem:
    """Residuals and Jacobian of the joint output-error problem."""

    def __init__(self, runs: Sequence[PreparedRun], effects: Sequence[str]) -> None:
        self.runs, self.effects = runs, tuple(effects)
        self.n_global = 3 + len(self.effects)
        self.sizes = [r.t.size for r in runs]
        self.starts = np.concatenate([[0], np.cumsum(self.sizes)])
        self.measured = np.concatenate([r.x for r in runs])
        self.run_index = np.repeat(np.arange(len(runs)), self.sizes)
        self._key: bytes | None = None
        self._sims = np.zeros(0)
        self._steps = np.zeros(0)
        self._sets = np.zeros((0, self.n_global))
        #: model velocity per run at the last parameters evaluated (their first set)
        self.velocities: tuple[np.ndarray, ...] = ()

    def model(
        self, params: np.ndarray, sets: np.ndarray, rows: slice
    ) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
        """Positions of the sets ``sets[rows]`` (on the step all of ``sets`` share), with
        each run's offset, and the velocity per run of the first of them. Bounded: an
        unstable trial comes back as a large, finite misfit where it starts (1e3 × the
        measured travel), so no overflow reaches the optimiser."""
        with np.errstate(over="ignore", invalid="ignore"):
            sims = simulate(sets, self.effects, self.runs, rows)
            x = np.concatenate([s[0] for s in sims], axis=1)
            x = bounded(x + params[self.n_global :][self.run_index][None, :], self.runs)
        return x, tuple(s[1][0] for s in sims)

    def _evaluate(self, params: np.ndarray, perturbed: bool) -> np.ndarray:
        """Model for the parameters (row 0) and, with ``perturbed``, each finite-difference
        perturbation: those only when the Jacobian asks (a rejected trial step never does),
        on the step the centre's residual was simulated with."""
        key = params.tobytes()
        if key != self._key:
            g = params[: self.n_global]
            self._steps = 1e-6 * np.maximum(np.abs(g), 1e-3)
            self._sets = np.vstack([g, g + np.diag(self._steps)])
            self._sims, self.velocities = self.model(params, self._sets, slice(0, 1))
            self._key = key
        if perturbed and self._sims.shape[0] == 1:
            perturbations, _ = self.model(params, self._sets, slice(1, None))
            self._sims = np.vstack([self._sims, perturbations])
        return self._sims

    def residual(self, params: np.ndarray) -> np.ndarray:
        return self.measured - self._evaluate(params, perturbed=False)[0]

    def jacobian(self, params: np.ndarray) -> np.ndarray:
        sims = self._evaluate(params, perturbed=True)
        jac = np.zeros((self.measured.size, params.size))
        jac[:, : self.n_global] = -((sims[1:] - sims[0]) / self._steps[:, None]).T
        jac[np.arange(self.measured.size), self.n_global + self.run_index] = -1.0
        return jac


def fit_output_error(
    runs: Sequence[PreparedRun],
    effects: Sequence[str] = (),
    start: np.ndarray | None = None,
    max_nfev: int = 200,
    quantization_sigma: bool = True,
) -> FitResult:
    """Fit (M, K_L, K_Q, effects) and one offset per run to all runs' positions jointly.

    ``max_nfev`` caps the model evaluations (the effect search screens with a low cap).
    ``quantization_sigma``: False for a refit whose σ is discarded (a bootstrap draw, a
    leave-one-run-out refit): the encoder's quantization σ (its costliest part) is not
    computed, so ``std`` lacks it and ``std_quantization`` is None.
    """
    effects = tuple(effects)
    prob = _Problem(runs, effects)
    g0 = initial_guess(runs, effects) if start is None else np.asarray(start, dtype=float)
    offsets0 = [
        float(np.median(r.x[r.t <= r.t_release])) if np.any(r.t <= r.t_release) else float(r.x[0])
        for r in runs
    ]
    lower, upper = _bounds(effects, len(runs))
    p0 = np.clip(np.concatenate([g0, offsets0]), lower, upper)
    on_lower = np.isfinite(lower) & (p0 <= lower)
    p0 = np.where(on_lower, lower + 1e-9 + 1e-6 * np.abs(np.nan_to_num(lower)), p0)
    from scipy.optimize import least_squares  # here: the service imports this module's types

    sol = least_squares(
        prob.residual,
        p0,
        jac=prob.jacobian,
        bounds=(lower, upper),
        method="trf",
        x_scale="jac",
        tr_solver="exact",
        xtol=REFIT_TOLERANCE,
        ftol=REFIT_TOLERANCE,
        gtol=REFIT_TOLERANCE,
        max_nfev=max_nfev,
    )
    params, ng = sol.x, prob.n_global
    res = prob.residual(params)
    steps = [r.encoder_step for r in runs] if quantization_sigma else []
    stats = honest_statistics(
        res, prob.jacobian(params), ng, prob.sizes, prob.measured - res, steps
    )
    names = (*BASE_NAMES, *effects)
    tol = 1e-6 * np.maximum(np.abs(params[:ng]), 1.0)
    at_bound = tuple(
        name
        for name, v, lo, hi in zip(names, params[:ng], lower, upper, strict=False)
        if abs(v - lo) < tol[names.index(name)] or abs(v - hi) < tol[names.index(name)]
    )
    return FitResult(
        effects=effects,
        names=names,
        values=params[:ng].copy(),
        **stats.fit_fields(),
        offsets=params[ng:].copy(),
        residuals=tuple(np.split(res, prob.starts[1:-1])),
        velocities=prob.velocities,  # of ``params``: evaluated last, by the residual above
        at_bound=at_bound,
    )


def predict_run(fit: FitResult, run: PreparedRun) -> np.ndarray:
    """Residual of a held-out run under ``fit``'s global parameters (offset refitted)."""
    x = simulate(fit.values[None, :], fit.effects, [run])[0][0][0]
    res = run.x - x
    return res - np.mean(res)


def leave_one_run_out_rmse(runs: Sequence[PreparedRun], fit: FitResult) -> float | None:
    """Leave-one-run-out prediction RMSE (m or rad); None with fewer than 3 runs."""
    if len(runs) < LORO_MIN_RUNS:
        return None
    held_out = []
    for i in range(len(runs)):
        train = [r for j, r in enumerate(runs) if j != i]
        sub = fit_output_error(
            train, fit.effects, start=fit.values, max_nfev=LORO_NFEV, quantization_sigma=False
        )
        held_out.append(predict_run(sub, runs[i]))
    return pooled_rmse(held_out)


def evaluate_parameters(
    runs: Sequence[PreparedRun],
    values: np.ndarray,
    std: np.ndarray,
    correlation: np.ndarray,
    effects: Sequence[str] = (),
) -> FitResult:
    """Simulate fixed coefficients (e.g. from a seed approach), refitting only the offsets."""
    effects = tuple(effects)
    values = np.asarray(values, dtype=float)
    sims = simulate(values[None, :], effects, runs)
    residuals, offsets = [], []
    for r, (x, _) in zip(runs, sims, strict=True):
        res = r.x - x[0]
        offsets.append(float(np.mean(res)))
        residuals.append(res - offsets[-1])
    sse = float(sum(float(r @ r) for r in residuals))
    return FitResult(
        effects=effects,
        names=(*BASE_NAMES, *effects),
        values=values,
        std=np.asarray(std, dtype=float),
        correlation=np.asarray(correlation, dtype=float),
        offsets=np.array(offsets),
        residuals=tuple(residuals),
        velocities=tuple(s[1][0] for s in sims),
        sse=sse,
        n_samples=sum(r.size for r in residuals),
        n_params=values.size + len(runs),
        at_bound=(),
    )
