"""Which effects these runs can tell apart: partial correlation of their output sensitivities.

Two effects are one on a set of runs when their columns of the position Jacobian ∂x/∂θ are
(nearly) parallel once every other parameter of the model (inertia, K_L, K_Q, the other
effects, one offset per run) is projected out. Example: when every run moves one way,
sign(v) is constant, so −F_c·sign(v) and a bias b move the model identically (ρ = −1) and
no data of that kind can separate dry friction from a current force. The verdict depends
only on the runs and the fitted trajectory, never on how far an optimiser went.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import combinations

import numpy as np

from estimation.axis.effects import EFFECTS
from estimation.axis.fit_memo import Recent
from estimation.axis.model import BASE_NAMES, simulate
from estimation.axis.prepared_run import PreparedRun
from estimation.motion.output_error_fit import MotionFit

#: |ρ| at or above this: the two effects are structurally the same on these runs.
COLLINEAR = 0.995
#: |ρ| at or above this: close enough that converged fits must decide (see search.py).
NEAR_COLLINEAR = 0.9


def _typical_step(name: str, fit: MotionFit, runs: Sequence[PreparedRun]) -> float:
    """A finite-difference step small against the parameter's plausible size: an effect's
    typical size is its entry's own (the coefficient that exerts the smallest drive along
    the fitted motion), a base coefficient's its fitted value."""
    if name in EFFECTS:
        drive = max(min(r.mean_abs_drive for r in runs), 1e-9)
        x = np.concatenate([r.x - r.x[0] for r in runs])
        v = np.concatenate(fit.velocities)
        a = np.concatenate(
            [
                np.gradient(u, r.t) if u.size > 1 else 0 * u
                for r, u in zip(runs, fit.velocities, strict=True)
            ]
        )
        weight = max(r.weight_equivalent for r in runs)
        scale = EFFECTS[name].typical(drive, x, v, a, weight) if np.any(v) else drive
    else:  # a base coefficient
        scale = abs(fit.value(name)) if name in fit.names else 1.0
    return 1e-4 * max(scale, 1e-12)


#: A search asks for the same sensitivity matrix (an ODE integration) to judge
#: identifiability, correlations and the predicted steps: kept per fit, runs and effects.
_RECENT: Recent[tuple[tuple[str, ...], np.ndarray]] = Recent()


def sensitivities(
    fit: MotionFit, runs: Sequence[PreparedRun], extra: Sequence[str]
) -> tuple[tuple[str, ...], np.ndarray]:
    """∂x/∂θ at ``fit`` (its effects, plus ``extra`` effects at zero), stacked over runs.

    Returns the parameter names and a (n_samples, n_params) matrix (read-only: the same
    one is returned again for the same fit, runs and ``extra``). A step that leaves a
    parameter's bounds is taken the other way.
    """
    asked = tuple(extra)
    return _RECENT.get((fit, runs, asked), lambda: _sensitivities(fit, runs, asked))


def _sensitivities(
    fit: MotionFit, runs: Sequence[PreparedRun], extra: Sequence[str]
) -> tuple[tuple[str, ...], np.ndarray]:
    effects = (*fit.effects, *(e for e in extra if e not in fit.effects))
    names = (*BASE_NAMES, *effects)
    values = np.array([fit.value(n) if n in fit.names else 0.0 for n in names])
    steps = np.array([_typical_step(n, fit, runs) for n in names])
    for i, n in enumerate(names):
        if n in EFFECTS and values[i] + steps[i] > EFFECTS[n].upper:
            steps[i] = -steps[i]
    sets = np.vstack([values, values + np.diag(steps)])
    sims = simulate(sets, effects, runs)
    x = np.concatenate([s[0] for s in sims], axis=1)  # finite: the engine's guard
    jac = ((x[1:] - x[0]) / steps[:, None]).T
    jac.flags.writeable = False
    return names, jac


def _offset_columns(runs: Sequence[PreparedRun]) -> np.ndarray:
    """One indicator column per run: the sensitivity to that run's position offset."""
    sizes = [r.t.size for r in runs]
    offsets = np.zeros((sum(sizes), len(runs)))
    offsets[np.arange(sum(sizes)), np.repeat(np.arange(len(runs)), sizes)] = 1.0
    return offsets


def _residualise(columns: np.ndarray, others: np.ndarray) -> np.ndarray:
    """``columns`` with their least-squares projection on ``others`` removed."""
    if others.shape[1] == 0:
        return columns
    q, _ = np.linalg.qr(others)
    return columns - q @ (q.T @ columns)


def independent_shares(
    fit: MotionFit, runs: Sequence[PreparedRun], names: Sequence[str]
) -> dict[str, float]:
    """Share of each effect's sensitivity that ``fit``'s own parameters cannot mimic.

    ‖P⊥ ∂x/∂θ_e‖ / ‖∂x/∂θ_e‖ with P⊥ removing the span of the base coefficients, ``fit``'s
    effects and one offset per run: 0 when the effect is a combination of them (e.g. a bias
    on one run at one force is an inertia change), 1 when it is orthogonal to them all.
    """
    params, jac = sensitivities(fit, runs, names)
    offsets = _offset_columns(runs)
    held = [i for i, n in enumerate(params) if n in fit.names]
    others = np.hstack([jac[:, held], offsets])
    out = {}
    for name in names:
        column = jac[:, [params.index(name)]]
        norm = float(np.linalg.norm(column))
        out[name] = float(np.linalg.norm(_residualise(column, others))) / norm if norm else 0.0
    return out


def partial_correlations(
    fit: MotionFit, runs: Sequence[PreparedRun], names: Sequence[str]
) -> dict[frozenset[str], float]:
    """Partial correlation of the sensitivities of each pair in ``names``.

    The other parameters held out are the base coefficients, ``fit``'s effects that are not
    in the pair, and one offset per run. Every column is made orthogonal to the base
    coefficients and offsets once (one QR); a pair's remaining held effects are then taken
    out on the Gram matrix of those columns (Frisch–Waugh–Lovell: the same projection).
    """
    params, jac = sensitivities(fit, runs, names)
    base = [i for i, n in enumerate(params) if n in BASE_NAMES]
    perp = _residualise(jac, np.hstack([jac[:, base], _offset_columns(runs)]))
    gram = perp.T @ perp
    out: dict[frozenset[str], float] = {}
    for a, b in combinations(dict.fromkeys(names), 2):
        pair = [params.index(a), params.index(b)]
        held = [params.index(n) for n in fit.effects if n not in (a, b)]
        g = gram[np.ix_(pair, pair)]
        if held:
            cross = gram[np.ix_(held, pair)]
            g = g - cross.T @ np.linalg.lstsq(gram[np.ix_(held, held)], cross, rcond=None)[0]
        if g[0, 0] <= 0.0 or g[1, 1] <= 0.0:
            out[frozenset((a, b))] = 0.0  # an effect that does not move this model at all
            continue
        out[frozenset((a, b))] = float(g[0, 1] / np.sqrt(g[0, 0] * g[1, 1]))
    return out


def predicted_steps(
    fit: MotionFit, runs: Sequence[PreparedRun], combos: Sequence[tuple[str, ...]]
) -> dict[tuple[str, ...], tuple[float, np.ndarray]]:
    """One Gauss–Newton step from ``fit`` for each combination of added effects.

    Returns, per combination, the predicted SSE after the step and the start values it
    gives (``fit``'s coefficients and effects, then the combination's). A step that takes a
    bounded effect past its bound leaves that effect at the bound. A linear prediction,
    used to decide which combinations are worth a converged fit. The least squares on
    [held, added, offsets] is solved by Frisch–Waugh–Lovell: the held parameters and
    offsets are factored once (QR), each combination solves only its added columns.
    """
    extra = sorted({e for c in combos for e in c if e not in fit.effects})
    params, jac = sensitivities(fit, runs, extra)
    residual = np.concatenate(fit.residuals)
    held = [params.index(n) for n in fit.names]
    q, r = np.linalg.qr(np.hstack([jac[:, held], _offset_columns(runs)]))
    q_res, q_jac = q.T @ residual, q.T @ jac
    res_perp, jac_perp = residual - q @ q_res, jac - q @ q_jac
    gram, moment = jac_perp.T @ jac_perp, jac_perp.T @ res_perp
    out: dict[tuple[str, ...], tuple[float, np.ndarray]] = {}
    for combo in combos:
        free = [e for e in combo if e not in fit.effects]
        while True:
            cols = [params.index(e) for e in free]
            delta = (
                np.linalg.lstsq(gram[np.ix_(cols, cols)], moment[cols], rcond=None)[0]
                if cols
                else np.zeros(0)
            )
            beta = np.linalg.lstsq(r, q_res - q_jac[:, cols] @ delta, rcond=None)[0]
            values = np.array([*fit.values, *np.zeros(len(free))])
            values = values + np.concatenate([beta[: len(held)], delta])
            past = [
                e
                for e, v in zip(free, values[len(held) :], strict=True)
                if not EFFECTS[e].lower <= v <= EFFECTS[e].upper
            ]
            if not past:
                break
            free = [e for e in free if e not in past]
        left = res_perp - jac_perp[:, cols] @ delta
        full = {n: v for n, v in zip([*fit.names, *free], values, strict=True)}
        # an effect the step took past its bound starts at the bound nearest to zero
        start = np.array(
            [
                full[n] if n in full else float(np.clip(0.0, EFFECTS[n].lower, EFFECTS[n].upper))
                for n in (*fit.names, *(e for e in combo if e not in fit.names))
            ]
        )
        out[combo] = (float(left @ left), start)
    return out


def variance_inflation(fit: MotionFit, runs: Sequence[PreparedRun], name: str) -> float:
    """VIF of ``name`` in ``fit``: 1/(1 − R²), R² the share of its sensitivity column that
    the fit's other parameters (and one offset per run) reproduce; ‖col‖²/‖P⊥ col‖².
    1 for a column orthogonal to the rest, ∞ for one the rest span."""
    params, jac = sensitivities(fit, runs, ())
    others = np.hstack(
        [jac[:, [i for i, n in enumerate(params) if n != name]], _offset_columns(runs)]
    )
    column = jac[:, [params.index(name)]]
    kept = float(np.linalg.norm(_residualise(column, others)))
    return float(np.linalg.norm(column)) ** 2 / kept**2 if kept > 0 else float("inf")
