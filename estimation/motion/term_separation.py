"""Which terms these records can tell apart: the output sensitivities of the one equation's
fit at its optimum, for every record kind (tows and spins, decays and pendulums).

Two terms are one on a set of records when their columns of the position Jacobian ∂x/∂θ
are (nearly) parallel once every other parameter of the model (the fitted coefficients,
the other terms, each record's nuisances: a rest position, or an equilibrium and initial
state) is projected out. Example: when every tow moves one way, sign(v) is constant, so
−F_c·sign(v) and a bias b move the model identically (ρ = −1) and no data of that kind can
separate dry friction from a current force. The verdict depends only on the records and the
fitted trajectory, never on how far an optimiser went. The columns are the fit's own
finite differences (``output_error_fit.sensitivities``).
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import combinations

import numpy as np

from estimation.motion import output_error_fit
from estimation.motion.fit_memo import Recent
from estimation.motion.output_error_fit import MotionFit
from estimation.motion.records import Record, Setup
from estimation.motion.terms import LIBRARY

#: |ρ| at or above this: the two terms are structurally the same on these records.
COLLINEAR = 0.995
#: |ρ| at or above this: close enough that converged fits must decide (``term_search``).
NEAR_COLLINEAR = 0.9

#: A search asks for the same sensitivity matrix (an ODE integration) to judge
#: identifiability, correlations and the predicted steps: kept per fit, records and terms.
_RECENT: Recent[tuple[tuple[str, ...], np.ndarray, np.ndarray]] = Recent()


def sensitivities(
    records: Sequence[Record], setup: Setup, fit: MotionFit, extra: Sequence[str]
) -> tuple[tuple[str, ...], np.ndarray, np.ndarray]:
    """∂x/∂θ at ``fit`` (its coefficients, then ``extra`` terms at zero) and ∂x/∂ of each
    record's nuisances, stacked over records.

    Returns the parameter names, their (n_samples, n_params) matrix and the nuisance
    columns (n_samples, n_nuisances), read-only: the same ones are returned again for the
    same fit, records (the same objects) and ``extra``.
    """
    wanted = set(extra) - set(fit.names)
    asked = tuple(n for n in LIBRARY if n in wanted)  # one order: one cache entry
    return _RECENT.get(
        (fit, records, setup, asked), lambda: _sensitivities(records, setup, fit, asked)
    )


def _sensitivities(
    records: Sequence[Record], setup: Setup, fit: MotionFit, added: tuple[str, ...]
) -> tuple[tuple[str, ...], np.ndarray, np.ndarray]:
    own, cols = output_error_fit.sensitivities(records, setup, fit, added)
    ng = len(fit.names)
    jac = np.hstack([own[:, :ng], cols])
    nuisance = own[:, ng:]
    jac.flags.writeable = nuisance.flags.writeable = False
    return (*fit.names, *added), jac, nuisance


def _residualise(columns: np.ndarray, others: np.ndarray) -> np.ndarray:
    """``columns`` with their least-squares projection on ``others`` removed."""
    if others.shape[1] == 0:
        return columns
    q, _ = np.linalg.qr(others)
    return columns - q @ (q.T @ columns)


def independent_shares(
    records: Sequence[Record],
    setup: Setup,
    fit: MotionFit,
    names: Sequence[str],
    without: int | None = None,
) -> dict[str, float]:
    """Share of each effect's sensitivity that ``fit``'s own parameters cannot mimic.

    ‖P⊥ ∂x/∂θ_e‖ / ‖∂x/∂θ_e‖ with P⊥ removing the span of the base coefficients, ``fit``'s
    effects and each record's nuisances: 0 when the effect is a combination of them (e.g. a bias
    on one run at one force is an inertia change), 1 when it is orthogonal to them all.
    ``without``: on the records but that one (a leave-one-record-out fold's), at ``fit``.
    """
    params, jac, nuisance = sensitivities(records, setup, fit, names)
    held = [i for i, n in enumerate(params) if n in fit.names]
    columns = jac[:, [params.index(name) for name in names]]
    others = np.hstack([jac[:, held], nuisance])
    if without is not None:  # the fold's rows; the left-out record's own nuisances go too
        rows = np.repeat(np.arange(len(records)), [r.t.size for r in records]) != without
        columns, others = columns[rows], others[rows]
        others = others[:, np.any(others != 0.0, axis=0)]
    perp = _residualise(columns, others)  # one QR for all
    norms = np.linalg.norm(columns, axis=0)
    kept = np.linalg.norm(perp, axis=0)
    return {name: float(k / n) if n else 0.0 for name, k, n in zip(names, kept, norms, strict=True)}


def partial_correlations(
    records: Sequence[Record], setup: Setup, fit: MotionFit, names: Sequence[str]
) -> dict[frozenset[str], float]:
    """Partial correlation of the sensitivities of each pair in ``names``.

    The other parameters held out are the base coefficients, ``fit``'s effects that are not
    in the pair, and the nuisances. Every column is made orthogonal to the base
    coefficients and nuisances once (one QR); a pair's remaining held effects are then taken
    out on the Gram matrix of those columns (Frisch–Waugh–Lovell: the same projection).
    """
    params, jac, nuisance = sensitivities(records, setup, fit, names)
    base = [i for i, n in enumerate(params) if n in fit.names and n not in fit.effects]
    perp = _residualise(jac, np.hstack([jac[:, base], nuisance]))
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
    records: Sequence[Record],
    setup: Setup,
    fit: MotionFit,
    combos: Sequence[tuple[str, ...]],
    among: Sequence[str] = (),
) -> dict[tuple[str, ...], tuple[float, np.ndarray, dict[str, float]]]:
    """One Gauss–Newton step from ``fit`` for each combination of added effects.
    ``among``: more terms whose sensitivities to form with the combinations' (a screen that
    has formed them for all its candidates: one integration, not two).

    Returns, per combination, the predicted SSE after the step, the values it gives the
    combination's terms (in its order) and the terms the step wanted past their bound
    (name → the value it wanted). A step that takes a bounded term past its bound leaves
    that term at the bound nearest to zero. A linear prediction, used to decide which
    combinations are worth a converged fit. The least squares on [held, added, nuisances]
    is solved by Frisch–Waugh–Lovell: the held parameters and nuisances are projected out
    once (QR), each combination solves only its added columns (the held parameters' own
    step is not formed: a trial starts them from ``fit``'s values).
    """
    extra = sorted({e for c in (*combos, among) for e in c if e not in fit.effects})
    params, jac, nuisance = sensitivities(records, setup, fit, extra)
    residual = np.concatenate(fit.residuals)
    held = [params.index(n) for n in fit.names]
    q, _ = np.linalg.qr(np.hstack([jac[:, held], nuisance]))
    q_res, q_jac = q.T @ residual, q.T @ jac
    res_perp, jac_perp = residual - q @ q_res, jac - q @ q_jac
    gram, moment = jac_perp.T @ jac_perp, jac_perp.T @ res_perp
    out: dict[tuple[str, ...], tuple[float, np.ndarray, dict[str, float]]] = {}
    for combo in combos:
        free = [e for e in combo if e not in fit.effects]
        wanted: dict[str, float] = {}
        while True:
            cols = [params.index(e) for e in free]
            delta = _solve_gram(gram, moment, cols)
            past = {
                e: float(v) for e, v in zip(free, delta, strict=True) if not LIBRARY[e].in_bounds(v)
            }
            if not past:
                break
            wanted.update(past)
            free = [e for e in free if e not in past]
        left = res_perp - jac_perp[:, cols] @ delta
        stepped = dict(zip(free, delta, strict=True))
        # an effect the step took past its bound starts at the bound nearest to zero
        values = np.array(
            [
                float(stepped[e])
                if e in stepped
                else float(np.clip(0.0, LIBRARY[e].lower, LIBRARY[e].upper))
                for e in combo
                if e not in fit.names
            ]
        )
        out[combo] = (float(left @ left), values, wanted)
    return out


def _solve_gram(gram: np.ndarray, moment: np.ndarray, cols: list[int]) -> np.ndarray:
    """The least-squares step on ``cols`` of the Gram system (``np.linalg.lstsq``). One
    column, a positive finite pivot g: m·(1/g), the number LAPACK's gelsd returns for a 1×1
    system (it scales by the reciprocal: the same bits, 10⁵ random pairs), without lstsq's
    overhead (a screen solves one per candidate)."""
    if not cols:
        return np.zeros(0)
    if len(cols) == 1:
        g, m = gram[cols[0], cols[0]], moment[cols[0]]
        if g > 0 and np.isfinite(g) and np.isfinite(m):
            return np.array([m * (1.0 / g)])
    return np.linalg.lstsq(gram[np.ix_(cols, cols)], moment[cols], rcond=None)[0]


def variance_inflation(records: Sequence[Record], setup: Setup, fit: MotionFit, name: str) -> float:
    """VIF of ``name`` in ``fit``: 1/(1 − R²), R² the share of its sensitivity column that
    the fit's other parameters (and the nuisances) reproduce; ‖col‖²/‖P⊥ col‖².
    1 for a column orthogonal to the rest, ∞ for one the rest span."""
    params, jac, nuisance = sensitivities(records, setup, fit, ())
    others = np.hstack([jac[:, [i for i, n in enumerate(params) if n != name]], nuisance])
    column = jac[:, [params.index(name)]]
    kept = float(np.linalg.norm(_residualise(column, others)))
    return float(np.linalg.norm(column)) ** 2 / kept**2 if kept > 0 else float("inf")
