"""What a tow or spin set tells the one effect search (``estimation.motion.term_search``):
its rules (``TOW_RULES``), pairs in the first round (dry friction and a bias act together,
and neither alone may pass), its experiment's resolution (release timing, motion floor:
``materiality``), the force-domain noise floor (``force_residual``) and each effect's own
start value."""

from __future__ import annotations

from collections.abc import Sequence

from estimation.axis.effects import EFFECTS
from estimation.axis.force_residual import noise_floor_ratio
from estimation.axis.materiality import below_resolution
from estimation.axis.output_error import effect_start
from estimation.axis.prepared_run import PreparedRun
from estimation.motion.output_error_fit import MotionFit
from estimation.motion.term_search import KindSearch
from estimation.stats.acceptance_rules import TOW_RULES

#: The trial fits of a tow set run to convergence: its fit is cheap (the closed form of a
#: constant pull where it holds), and a verdict never rests on a partly converged fit.
TOW_TRIAL_NFEV = 200


def candidate_effects(runs_declared_mass: bool) -> list[str]:
    """Effects worth trying: an inertia term (the hung weight's) only when the hung mass is
    not declared (declared, its weight is 0 and the term could not act)."""
    return [e for e in EFFECTS if EFFECTS[e].role != "inertia" or not runs_declared_mass]


def tow_search(runs: Sequence[PreparedRun]) -> KindSearch:
    """The tow or spin set's part of the one search."""

    def unresolved(terms: Sequence[str], fit: MotionFit) -> list[str]:
        return [b for b in (below_resolution(e, fit, runs) for e in terms) if b]

    return KindSearch(
        rules=TOW_RULES,
        pairs=True,
        own_parameters="inertia, K_L or K_Q",
        unresolved=unresolved,
        floor_ratio=lambda fit: noise_floor_ratio(fit, runs),
        trial_nfev=TOW_TRIAL_NFEV,
        start_value=lambda term: effect_start(term, runs),
    )
