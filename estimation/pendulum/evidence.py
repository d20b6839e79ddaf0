"""Ljung–Box Q before and after each step of the pendulum's effect search, from the fits
``estimation.motion.search.search_terms`` returns (nothing is refitted).

Whiteness is a verdict on the final model, not a rule of the search (module doc of
``estimation.motion.search``): with structure left in the residual its normalised
autocorrelation stays near 1 whatever share a true term removes. The per-step Q is reported
beside ΔBIC and the materiality figures as evidence a reader can compare with a tow's, never
as the reason a term was kept or rejected.

A step of round r compares the model of round r (the base plus the terms chosen in rounds
1…r−1) with its trial (that model plus the step's term). The search returns the base fit,
the final fit and the trials rejected in its last round, so

- Q before is known in round 1 (the base) and in the round after the last chosen term (the
  final model); between them, when two or more terms are kept, the intermediate model is
  not returned: null;
- Q after is known for the term chosen last (its trial is the final model; with one term
  kept, that is round 1's choice) and for every candidate fitted and rejected in the last
  round; a candidate rejected in an earlier round, one kept but beaten by another, or one
  never fitted (screened out by its linearised step, not identified, out of bounds) has no
  trial to test: null.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from estimation.motion.fit import MotionFit
from estimation.motion.search import Step
from estimation.numbers import finite_or_none
from estimation.stats.diagnostics import ljung_box


@dataclass(frozen=True)
class StepWhiteness:
    """Ljung–Box Q (pooled over runs, ``stats.diagnostics.ljung_box``) of the residual of
    the step's current model and of its trial; None where that fit is not available."""

    q_before: float | None
    q_after: float | None


def _q(fit: MotionFit | None) -> float | None:
    return None if fit is None else ljung_box(fit.residuals).q_statistic


def chosen(step: Step, base: MotionFit, final: MotionFit) -> bool:
    """Whether ``step`` is the one whose term its round added to the model (a step that
    passed the rules can still lose to a better candidate or to its rival)."""
    added = final.effects[len(base.effects) :]  # one per round that kept a term, in order
    return step.round <= len(added) and added[step.round - 1] == step.term


def step_whiteness(
    steps: Sequence[Step], base: MotionFit, final: MotionFit, rejected: Sequence[MotionFit]
) -> tuple[StepWhiteness, ...]:
    """Q before/after of each search step (module doc) from ``search_terms``'s results:
    the base fit, the final fit and ``rejected`` (the trials rejected in the last round)."""
    rounds = len(final.effects) - len(base.effects) + 1  # the last: nothing left to keep
    model = {1: base, rounds: final}  # the current model of round r, where known
    last_trials = {e: t for t in rejected for e in t.effects if e not in final.effects}
    out = []
    for s in steps:
        if chosen(s, base, final):
            after = model.get(s.round + 1)
        elif s.round == rounds:
            after = last_trials.get(s.term)
        else:
            after = None
        out.append(StepWhiteness(_q(model.get(s.round)), _q(after)))
    return tuple(out)


def step_json(s: Step, w: StepWhiteness) -> dict[str, Any]:
    """One search step in the documented keys (docs/pendulum.md, *evidence*)."""
    doc = s.to_json()
    return {
        "round": doc["round"],
        "effect": doc["term"],
        "delta_bic": doc["delta_bic"],
        "ljung_box_q_before": finite_or_none(w.q_before),
        "ljung_box_q_after": finite_or_none(w.q_after),
        "explained_rms": doc["explained_rms"],
        "noise": doc["noise"],
        "accepted": doc["accepted"],
        "reason": doc["reason"],
    }
