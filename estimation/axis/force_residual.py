"""The force-domain residual of the tow/spin equation: the force the model misses, the
floor white position noise would give it, and its correlation with each entry's regressor."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from estimation.axis.effects import EFFECTS
from estimation.axis.model import ParamView
from estimation.axis.prepared_run import PreparedRun
from estimation.motion.fit_memo import Recent
from estimation.motion.output_error_fit import MotionFit
from estimation.stats.diagnostics import position_noise, smoothed_derivatives

#: An estimate reads the same fit's force residual and noise floor more than once (its
#: unexplained verdict, its per-run RMS, the search's materiality): kept per fit and runs.
_RESIDUALS: Recent[list[np.ndarray]] = Recent()
_FLOORS: Recent[float] = Recent()


def force_residuals(fit: MotionFit, runs: Sequence[PreparedRun]) -> list[np.ndarray]:
    """Force-domain residual per run (N or N·m): the force the model misses, linearised.

    For a position residual r(t) about the model trajectory v(t):
        τ_res ≈ M_tot·r̈ + (K_L + 2K_Q·|v| + 3K_C·v²)·ṙ + k_s·r
    with ṙ, r̈ from smoothed derivatives of r (model derivatives are exact, so fast
    transients do not bias it). Read-only arrays (shared by the calls for the same fit).
    """

    def compute() -> list[np.ndarray]:
        out = [
            _force_of(fit, r, res, v)
            for r, res, v in zip(runs, fit.residuals, fit.velocities, strict=True)
        ]
        for f in out:
            f.flags.writeable = False
        return out

    return list(_RESIDUALS.get((fit, runs), compute))


def _force_of(fit: MotionFit, run: PreparedRun, res: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The linearised force of one run's position residual ``res`` (see force_residuals)."""
    return _linear_force(_linearisation(fit, run, v), run, res)


def _linearisation(
    fit: MotionFit, run: PreparedRun, v: np.ndarray
) -> tuple[np.floating, np.ndarray, np.ndarray]:
    """What the linearised force of a residual on ``run`` multiplies r̈, ṙ and r by: the
    total inertia, each term's own damping −θ·∂φ/∂v and stiffness −θ·∂φ/∂x along the model
    motion ``v`` (the fit's and the run's alone: one for all the residuals of a noise floor)."""
    p = ParamView(fit.values[None, :], fit.effects)
    x = run.x - run.x[0]
    damping, stiffness = np.zeros_like(v), np.zeros_like(v)
    for c in p.forces:
        damping = damping - c.value[0, 0] * c.term.dphi_dv(x, v)
        stiffness = stiffness - c.value[0, 0] * c.term.dphi_dx(x, v)
    return p.total_inertia(run)[0], damping, stiffness


def _linear_force(
    linearisation: tuple[np.floating, np.ndarray, np.ndarray], run: PreparedRun, res: np.ndarray
) -> np.ndarray:
    """``_force_of`` with the run's linearisation already made (``_linearisation``)."""
    inertia, damping, stiffness = linearisation
    d1, d2 = smoothed_derivatives(run.t, res)
    return inertia * d2 + damping * d1 + stiffness * res


def force_noise_floor(fit: MotionFit, runs: Sequence[PreparedRun], draws: int = 4) -> float:
    """RMS force residual that white position noise of each run's own σ would produce.

    The fit implies this floor: the same derivative filter and model terms applied to
    white noise at the scatter ``position_noise`` measures (fixed seed: reproducible).
    Only moving samples count, as in ``unexplained``.
    """
    return _FLOORS.get((fit, runs, draws), lambda: _noise_floor(fit, runs, draws))


def _noise_floor(fit: MotionFit, runs: Sequence[PreparedRun], draws: int) -> float:
    rng = np.random.default_rng(12345)
    total, count = 0.0, 0
    sigma = position_noise(fit.residuals, [r.t for r in runs])
    for r, res, v in zip(runs, fit.residuals, fit.velocities, strict=True):
        moving = r.t > r.t_release
        linearisation = _linearisation(fit, r, v)
        for _ in range(draws):
            f = _linear_force(linearisation, r, rng.normal(0.0, sigma, res.size))[moving]
            total += float(f @ f)
            count += f.size
    return float(np.sqrt(total / count)) if count else 0.0


def noise_floor_ratio(fit: MotionFit, runs: Sequence[PreparedRun]) -> float:
    """Pooled RMS force residual of the moving samples over the noise floor the fit implies
    (≈ 1 when only noise is left)."""
    forces = np.concatenate(
        [f[r.t > r.t_release] for f, r in zip(force_residuals(fit, runs), runs, strict=True)]
    )
    floor = force_noise_floor(fit, runs)
    rms = float(np.sqrt(np.mean(forces**2))) if forces.size else 0.0
    return rms / floor if floor > 0 else (np.inf if rms > 0 else 1.0)


def regressor_correlations(
    fit: MotionFit, runs: Sequence[PreparedRun], force_res: Sequence[np.ndarray]
) -> dict[str, float]:
    """Partial correlation of the pooled force residual with each effect's regressor.

    Both are first made orthogonal to the base model's own regressors (v̇, v, |v|·v), since
    whatever lies along those was already absorbed by M, K_L and K_Q. Sign: positive means
    adding the effect with a positive value would explain the residual.
    """
    base: list[np.ndarray] = []
    regressors = [e for e in EFFECTS if EFFECTS[e].role != "timing"]
    cols: dict[str, list[np.ndarray]] = {k: [] for k in regressors}
    for r, offset, v in zip(runs, fit.equilibrium, fit.velocities, strict=True):
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
