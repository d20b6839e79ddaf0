"""Which effects these runs cannot tell apart from a kept one, and the experiment that
would (``search`` module doc, *ambiguity*): a candidate whose sensitivity is collinear
with a kept effect's (``motion.term_separation.COLLINEAR``), or nearly so and whose fully
converged fit in its place explains the data alike (BIC within ``AMBIGUITY_BIC``)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from estimation.axis.effects import EFFECTS
from estimation.axis.materiality import below_resolution
from estimation.axis.model import BASE_NAMES, records_of, setup_of
from estimation.axis.output_error import effect_start, fit_output_error
from estimation.axis.prepared_run import PreparedRun
from estimation.motion.output_error_fit import MotionFit
from estimation.motion.term_separation import COLLINEAR, NEAR_COLLINEAR, partial_correlations

AMBIGUITY_BIC = 2.0  # converged fits whose BIC differ by less than this explain the data alike
PAIR_EXPERIMENTS = {
    frozenset({"coulomb_friction", "constant_bias"}): (
        "coulomb_friction and constant_bias are collinear when every run moves the same way: "
        "add a reverse tow/spin (opposite force) or a free-decay run"
    ),
}


def start_from(fit: MotionFit, effects: Sequence[str], runs: Sequence[PreparedRun]) -> np.ndarray:
    """``fit``'s values, with each effect it lacks at a small physical start value."""
    names = (*BASE_NAMES, *effects)
    return np.array([fit.value(n) if n in fit.names else effect_start(n, runs) for n in names])


def _separating_advice(group: Sequence[str]) -> str:
    key = frozenset(group)
    if key in PAIR_EXPERIMENTS:
        return PAIR_EXPERIMENTS[key]
    parts = "; ".join(f"{e}: {EFFECTS[e].separated_by}" for e in group)
    return f"{' and '.join(group)} explain the data equally: to separate them — {parts}"


def ambiguities(
    runs: Sequence[PreparedRun], final: MotionFit, candidates: Sequence[str]
) -> tuple[tuple[tuple[str, ...], ...], tuple[str, ...]]:
    """Groups of effects the runs cannot tell apart from each kept effect, with advice."""
    if not final.effects:
        return (), ()
    others = [c for c in candidates if c not in final.effects]
    rho = partial_correlations(records_of(runs), setup_of(runs), final, [*final.effects, *others])
    groups, advice = [], []
    for kept in final.effects:
        twins = []
        for c in others:
            r = abs(rho[frozenset((kept, c))])
            if r >= NEAR_COLLINEAR and _explains_alike(runs, final, kept, c, r < COLLINEAR):
                twins.append(c)
        if twins:
            group = (kept, *twins)
            groups.append(group)
            advice.append(_separating_advice(group))
    return tuple(groups), tuple(advice)


def _explains_alike(
    runs: Sequence[PreparedRun], final: MotionFit, kept: str, other: str, compare_bic: bool
) -> bool:
    """A converged fit with ``other`` in place of ``kept`` is physical (inside its bounds,
    material) and, unless the two are collinear, explains the data as well."""
    effects = tuple(other if e == kept else e for e in final.effects)
    swap = fit_output_error(runs, effects, start=start_from(final, effects, runs))
    if other in swap.at_bound or below_resolution(other, swap, runs):
        return False  # e.g. an aiding force cannot be dry friction
    return not compare_bic or abs(swap.bic - final.bic) < AMBIGUITY_BIC
