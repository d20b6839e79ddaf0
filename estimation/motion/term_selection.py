"""Which library terms a record supports: rules from statistics, each stated with its reason.

Forward selection from the base model: each round fits every remaining candidate to
convergence (from the current fit, the new term at its start value) and keeps the best of
those that pass the decay's acceptance rules, ``DECAY_RULES`` of the one rule set
(``estimation.stats.acceptance_rules``, where each rule states its reason): the error is
not round-off; the new coefficient is identified (no lost Jacobian direction) and not held
at its physical bound; ΔBIC < −``BIC_THRESHOLD``; the residual it explains is at least the
position noise σ the fit implies (never measured against the drive or the restoring force:
on a lightly damped body every damping term is ~1 % of the restoring torque, KVLCC2); a
rival of a kept term beats that term alone on n_eff (below). The last rule, out of sample
(it refits every record), is asked in the backward check (below), not of a forward step.

Before a candidate is fitted, one Gauss–Newton step from the current fit (its sensitivity
column beside the current model's, ``motion.term_separation``: every kind's) predicts its
SSE; a candidate predicted to miss the information criterion by a wide margin (predicted
ΔBIC > 0) is recorded, not fitted. A trial starts from that linearised value, the model's
own parameters where the current fit left them; a set-valued term (dry friction) starts from
a **profile** (``motion.profile``).

Two candidates whose sensitivities, after projecting out the current model, have |ρ| ≥
``RIVALS`` explain the same part of the residual: they are **rivals** (quadratic against
cubic damping on a decay), never added in the same round. Between kept rivals the earlier in
the library (the lower-order, conventional term: quadratic before cubic damping) wins unless
the later one beats it by ``BIC_THRESHOLD`` on the residual's effective sample size n_eff =
n·(1 − r₁)/(1 + r₁) (r₁: lag-1 autocorrelation of the residual; the AR(1) variance
inflation): BIC assumes white residuals, and with a structured one a difference computed on
n samples between two alternatives that fit the same direction measures the structure, not
the physics. White residuals give n_eff ≈ n and the data decide. The rival left out is still
tried in later rounds, and joins the kept one only by the same rule — the pair beats the
kept term alone by ``BIC_THRESHOLD`` on n_eff: rivals in the linearised screen may still be
separated by a record's range (a decay from 10° to 1.1° separates the loss per half-cycle
that does not depend on amplitude, dry friction's, from one that grows with it, quadratic
damping's: KVLCC2 run 21338; the shorter runs 21337 and 21340 do not). A pair the data
separate is kept and no longer reported as ambiguous; one they do not, is.

**Backward check.** When a round keeps nothing, every kept term is judged again by the
rules against the final model without it (refitted from the final's values): a term kept
early whose work a later term took over (quadratic damping kept first on a decay whose
damping is cubic, before its rival cubic drag joined it) no longer passes and is removed,
the one costing least first, until every kept term passes. Forward selection alone never
revisits an early choice. Here, with ≥ 3 records, each kept term must also lower the
**leave-one-record-out** error of the final model: each record predicted by the shared
coefficients refitted on the others, only its own equilibrium and initial state fitted
(``output_error_fit.leave_one_record_out``), pooled, below the error of the final model
without the term by more than the refits resolve (``stats.out_of_sample.loro_dropped``, the
tows' rule). A term whose coefficient one record alone carries (a drift in one record of
three) passes every in-sample rule and predicts the others worse: it is removed. The rule
is not asked of a forward step: that step compares two models that may both lack a true
term, and a true term may predict held-out records only beside its partner (KVLCC2 21338
cut into three amplitude bands: B₂ beside the hardening alone raises the pooled held-out
error 0.00400 → 0.00424 rad; with dry friction too the final model's is 0.00341). With
fewer than 3 records the rule is not applied.

Whiteness is a verdict on the final model, not a gate (``estimate``): when a structured
residual remains, its normalised autocorrelation stays near 1 whatever share of it a real
term removes, so "Ljung–Box Q must drop" rejects true terms (KVLCC2's quadratic damping).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from estimation.errors import EstimationFailed
from estimation.motion.output_error_fit import (
    HeldOut,
    MotionFit,
    fit_motion,
    leave_one_record_out,
    parameters_of,
)
from estimation.motion.profile import extend, profile_start
from estimation.motion.records import Record, Setup
from estimation.motion.term_separation import (
    independent_shares,
    partial_correlations,
    predicted_steps,
    sensitivities,
)
from estimation.motion.terms import LIBRARY
from estimation.report_numbers import finite_or_none
from estimation.stats.acceptance_rules import (
    BIC_THRESHOLD,
    DECAY_RULES,
    SEPARABLE,
    Rival,
    Trial,
)
from estimation.stats.diagnostics import ljung_box
from estimation.stats.misfit import effective_sample_size
from estimation.stats.out_of_sample import loro_dropped

#: The model's own parameters, in the words of the screen's reason (``SEPARABLE``).
SETUP_PARAMETERS = "the model's own parameters (a constant force only moves a spring's equilibrium)"
TRIAL_NFEV = 40  # a trial starts one Gauss–Newton step from its optimum
RIVALS = 0.9  # |partial correlation| of two candidates' sensitivities: the same direction


@dataclass(frozen=True)
class Step:
    """Evidence for one candidate: its ΔBIC, the residual it explains, the verdict
    (``accepted``: it passed the rules; ``added``: its round added it to the model — of
    the terms that pass in a round one is added), and the Ljung–Box Q of the round's
    model and of the trial (NaN: not fitted) — evidence beside the rules, not one of them —
    and the leave-one-record-out RMSE of both (NaN: not computed, the rule not reached or
    fewer than 3 records)."""

    term: str
    round: int
    delta_bic: float
    explained_rms: float  # m or rad
    noise: float  # m or rad
    accepted: bool
    reason: str
    q_before: float = np.nan
    q_after: float = np.nan
    added: bool = False
    loro_before: float = np.nan  # leave-one-record-out RMSE, m or rad (NaN: not computed)
    loro_after: float = np.nan

    def to_json(self) -> dict:
        """The step as plain numbers."""
        return {
            "term": self.term,
            "round": self.round,
            "delta_bic": finite_or_none(self.delta_bic),
            "explained_rms": finite_or_none(self.explained_rms),
            "noise": finite_or_none(self.noise),
            "accepted": self.accepted,
            "added": self.added,
            "reason": self.reason,
            "ljung_box_q_before": finite_or_none(self.q_before),
            "ljung_box_q_after": finite_or_none(self.q_after),
            "leave_one_record_out_rmse_before": finite_or_none(self.loro_before),
            "leave_one_record_out_rmse_after": finite_or_none(self.loro_after),
        }


class HeldOutErrors:
    """The leave-one-record-out errors of the fits one search judges (``leave_one_record_out``),
    each computed once: the final model is the bar of each of its terms."""

    def __init__(self, records: Sequence[Record], setup: Setup) -> None:
        self.records, self.setup = records, setup
        self._done: dict[tuple[tuple[str, ...], bytes], HeldOut | None] = {}

    def of(self, fit: MotionFit) -> HeldOut | None:
        """``fit``'s check (None: fewer than 3 records); raises ``EstimationFailed``."""
        key = (fit.names, parameters_of(fit).tobytes())
        if key not in self._done:
            self._done[key] = leave_one_record_out(self.records, self.setup, fit)
        return self._done[key]

    def check(
        self, current: MotionFit, trial: MotionFit, seen: list[float]
    ) -> Callable[[], str | None]:
        """The rule's question for ``trial`` against ``current``: why its held-out error
        does not drop by more than the refits resolve, or None (fewer than 3 records: not
        applied). ``seen`` receives the two pooled RMSEs once computed."""

        def verdict() -> str | None:
            try:
                bar, new = self.of(current), self.of(trial)
            except EstimationFailed as err:
                return f"leave-one-record-out refit failed: {err.why}"
            if bar is None or new is None:
                return None
            seen[:] = [bar.rmse, new.rmse]
            if loro_dropped(new.rmse, bar.rmse):
                return None
            folds = ", ".join(
                f"{r.run_id} {b:.3g} → {n:.3g}"
                for r, b, n in zip(self.records, bar.per_record, new.per_record, strict=True)
            )
            return (
                f"leave-one-record-out error did not drop (RMSE {bar.rmse:.4g} → "
                f"{new.rmse:.4g}; per record {folds})"
            )

        return verdict


def judge(
    records: Sequence[Record],
    current: MotionFit,
    trial: MotionFit,
    term: str,
    round_no: int,
    rival: str | None = None,
    held_out: HeldOutErrors | None = None,
) -> Step:
    """``DECAY_RULES`` (``stats.acceptance_rules``) for ``trial`` = ``current`` + ``term``;
    ``rival``: the kept term ``term`` rivals (the pair must beat it alone on n_eff);
    ``held_out``: the search's leave-one-record-out errors (None: the rule is not asked, as
    of a forward step)."""
    seen: list[float] = []
    evidence = Trial(
        (term,),
        current,
        trial,
        max((float(np.ptp(r.x)) for r in records), default=0.0),
        not_identified=trial.not_identified,
        rival=None if rival is None else Rival(f"{rival} alone", current),
        out_of_sample=None if held_out is None else held_out.check(current, trial, seen),
        times=tuple(np.asarray(r.t, dtype=float) for r in records),
    )
    reason = DECAY_RULES.verdict(evidence)
    q_after = ljung_box(trial.residuals).q_statistic
    loro_before, loro_after = seen or (np.nan, np.nan)
    return Step(
        term,
        round_no,
        evidence.delta_bic,
        evidence.explained_rms,
        evidence.noise,
        reason == "kept",
        reason,
        q_after=q_after,
        loro_before=loro_before,
        loro_after=loro_after,
    )


def effective_samples(fit: MotionFit) -> float:
    """The fit's residual's effective sample size (``stats.misfit.effective_sample_size``)."""
    return effective_sample_size(fit.residuals)


def _screen(records, setup, current: MotionFit, candidates):
    """Per candidate (``motion.term_separation``, every kind's): its predicted ΔBIC and
    start after one Gauss–Newton step from the current fit (the value the step wanted, when
    past its bound), the partial correlation of each pair, the current model's own
    sensitivities (coefficients, then nuisances) and why a candidate is a combination of
    them (``SEPARABLE``)."""
    shares = independent_shares(records, setup, current, candidates)
    rho = partial_correlations(records, setup, current, candidates)
    steps = predicted_steps(records, setup, current, [(c,) for c in candidates])
    _, jac, nuisance = sensitivities(records, setup, current, candidates)
    own = np.hstack([jac[:, : len(current.names)], nuisance])
    n = current.n_samples
    predicted, start, unseparable = {}, {}, {}
    for c in candidates:
        sse, values, wanted = steps[(c,)]
        predicted[c] = n * np.log(max(sse, 1e-300) / current.sse) + np.log(n)
        start[c] = wanted.get(c, float(values[-1]))
        why = SEPARABLE.verdict(c, shares[c], SETUP_PARAMETERS)
        if why is not None:  # a combination of the model's own parameters
            unseparable[c] = why
    return predicted, rho, start, own, unseparable


def search_terms(
    records: Sequence[Record], setup: Setup, base: MotionFit, candidates: Sequence[str]
) -> tuple[MotionFit, tuple[Step, ...], tuple[MotionFit, ...], tuple[tuple[str, str], ...]]:
    """Forward selection (module doc): the final fit, every step, the fits of the candidates
    rejected against the final model (to tell whether its coefficients move), and the
    rival pairs (kept term, its rival)."""
    current, round_no = base, 1
    steps: list[Step] = []
    rejected_last: list[MotionFit] = []
    rivals: list[tuple[str, str]] = []
    rival_of: dict[str, str] = {}  # a candidate still tried, and the kept term it rivals
    remaining = [c for c in candidates if c not in base.names]
    order = {c: i for i, c in enumerate(candidates)}
    held_out = HeldOutErrors(records, setup)
    while remaining:
        predicted, rho, start, own, unseparable = _screen(records, setup, current, remaining)
        first = len(steps)
        kept: list[tuple[MotionFit, str]] = []
        rejected_last = []
        for term in remaining:
            if term in unseparable:
                steps.append(Step(term, round_no, np.nan, 0.0, 0.0, False, unseparable[term]))
                continue
            if not LIBRARY[term].in_bounds(start[term]):
                steps.append(
                    Step(
                        term,
                        round_no,
                        predicted[term],
                        0.0,
                        0.0,
                        False,
                        f"not fitted: a linearised step wants {term} = "
                        f"{start[term]:.3g}, beyond its physical bound "
                        f"({LIBRARY[term].physical or 'its bounds'})",
                    )
                )
                continue
            if predicted[term] > 0:
                steps.append(
                    Step(
                        term,
                        round_no,
                        predicted[term],
                        0.0,
                        0.0,
                        False,
                        f"not fitted: a linearised step predicts ΔBIC {predicted[term]:.1f}",
                    )
                )
                continue
            try:
                trial = fit_motion(
                    records,
                    setup,
                    (*current.effects, term),
                    start=(
                        profile_start(records, setup, current, own, term, start[term])
                        if LIBRARY[term].set_valued_at_rest
                        else extend(current, start[term])
                    ),
                    max_nfev=TRIAL_NFEV,
                )
            except EstimationFailed as err:
                steps.append(Step(term, round_no, np.nan, 0.0, 0.0, False, err.why))
                continue
            step = judge(records, current, trial, term, round_no, rival_of.get(term))
            steps.append(step)
            if step.accepted:
                kept.append((trial, term))
            else:
                rejected_last.append(trial)
        q_now = ljung_box(current.residuals).q_statistic
        steps[first:] = [replace(s, q_before=q_now) for s in steps[first:]]
        if not kept:
            break
        best, chosen = min(kept, key=lambda k: k[0].bic)
        for fit, term in sorted(kept, key=lambda k: order[k[1]]):
            if order[term] < order[chosen] and abs(rho[frozenset((term, chosen))]) >= RIVALS:
                scale = effective_samples(best) / best.n_samples
                if (fit.bic - best.bic) * scale < BIC_THRESHOLD:
                    best, chosen = fit, term
                break
        current = best
        rejected_last = []
        steps[first:] = [_verdict_of_round(s, chosen) for s in steps[first:]]
        if chosen in rival_of:  # the data separated a rival pair: both are kept
            rivals.remove((rival_of.pop(chosen), chosen))
        for c in sorted(remaining, key=order.__getitem__):
            if c != chosen and c not in rival_of and abs(rho[frozenset((c, chosen))]) >= RIVALS:
                rival_of[c] = chosen
                rivals.append((chosen, c))
        remaining = [c for c in remaining if c != chosen]
        round_no += 1
    current, removed = _backward(records, setup, current, steps, round_no, held_out)
    rivals = [(kept, rival) for kept, rival in rivals if kept in current.effects]
    return current, tuple(steps), (*rejected_last, *removed), tuple(rivals)


def _backward(
    records, setup, final: MotionFit, steps: list[Step], round_no: int, held_out: HeldOutErrors
):
    """The backward check (module doc): the final fit without the terms that no longer pass
    (the out-of-sample rule included: ``held_out``), and the fits each removal left (nested
    in the final: evidence the coefficients move). Each removal is recorded in ``steps`` as
    round ``round_no``; a term that stays carries, on the step that added it, the held-out
    errors of the final model without it and with it."""
    removed: list[MotionFit] = []
    while True:
        failing, passed = [], {}
        for term in final.effects:
            start = np.delete(parameters_of(final), final.names.index(term))
            rest = tuple(e for e in final.effects if e != term)
            try:
                without = fit_motion(records, setup, rest, start=start, max_nfev=TRIAL_NFEV)
            except EstimationFailed:
                continue
            again = judge(records, without, final, term, round_no, held_out=held_out)
            if not again.accepted:
                failing.append((final.bic - without.bic, again, without))
            else:
                passed[term] = again
        if not failing:
            for i, s in enumerate(steps):
                if s.added and s.term in passed and s.term in final.effects:
                    by = passed[s.term]
                    steps[i] = replace(s, loro_before=by.loro_before, loro_after=by.loro_after)
            return final, removed
        _, again, final = max(failing, key=lambda f: f[0])  # the cheapest to leave out
        removed.append(final)
        steps.append(replace(again, reason=f"removed in the backward check: {again.reason}"))


def _verdict_of_round(step: Step, chosen: str) -> Step:
    """``step`` once its round has added ``chosen``: added, or — when it passed the rules
    too — said to have lost to it."""
    if step.term == chosen:
        return replace(step, added=True)
    if step.accepted:
        return replace(step, reason=f"passed the rules; {chosen} was added this round")
    return step
