"""The one effect search of every record kind (tows and spins, free decays and pendulums).

Which library terms a set of records supports, and which they cannot tell apart. A record
kind tells the search only what it alone knows (``KindSearch``): its acceptance rules
(``stats.acceptance_rules``, each stated with its reason), whether its first round also
tries pairs, the words for its model's own parameters, and the evidence only it can form
(what its experiment resolves, the force-domain noise floor). Everything else is one code
path:

**Rounds.** Forward from the base model. Each round first *screens* the candidates left on
the current fit (``motion.term_separation``, one sensitivity matrix): a term with less than
``MIN_INDEPENDENT_SHARE`` of its sensitivity independent of the model's parameters
(``SEPARABLE``), or collinear (|ρ| ≥ ``COLLINEAR``) with a kept term, is a change of them
and is not tried; one Gauss–Newton step predicts every trial's SSE and start. A trial is
fitted to convergence (from the current fit, the new terms at their linearised value; a
set-valued term, dry friction, from a *profile*, ``motion.profile``) only when its
linearised value is inside its physical bounds, its predicted BIC is below what it must
beat (the current model; a pair, the best single too), and its predicted gain is at least
``FAR_BEHIND`` of a kept trial's (an earlier *rival* of a kept one is always fitted: the
choice below may prefer it). Trials
are fitted in order of predicted BIC and judged by the kind's rules; of those kept, the
lowest BIC is added — unless an earlier one in library order (the conventional term) is
within ``TIE_BIC`` of it, or rivals it and is not beaten by ``BIC_THRESHOLD`` on the
residual's effective sample size n_eff = n·(1 − r₁)/(1 + r₁) (BIC counts every sample as
independent: two alternatives that fit one direction differ by the residual's structure).
A kind that lists pairs (tows and spins: dry friction and a bias act together, and neither
alone may pass) tries in its first round every pair of separable candidates too, judged
against the best single (it must beat it by ``BIC_THRESHOLD``, and its held-out error).
Rounds go on until one keeps nothing.

**Rivals.** Candidates whose sensitivities, after projecting out the current model, have
|ρ| ≥ ``RIVALS`` explain the same part of the residual. One left out is still tried in later
rounds, judged against the model with its kept rival (it must beat it by ``BIC_THRESHOLD``):
rivals in the linearised screen may still be separated by a record's range (a decay from 10°
to 1.1° separates dry friction's amplitude-free loss per half-cycle from quadratic
damping's, KVLCC2 run 21338).

**Backward check.** When a round keeps nothing, every kept term is judged again by the
kind's rules against the final model without it (refitted from the final's values), the
out-of-sample rule included: with ≥ 3 records, each record predicted by the shared
coefficients refitted on the others (``output_error_fit.leave_one_record_out``) must be
predicted better with the term than without it. A term whose work a later term took over,
or whose coefficient one record alone carries, is removed (the cheapest first) until every
kept term passes. Forward selection alone never revisits an early choice.

**Ambiguity.** A kept term and a candidate the records cannot tell apart are reported
together with the experiment that would separate them: a candidate near-collinear with a
kept term (|ρ| ≥ ``RIVALS`` on the final model) whose converged fit in its place is physical
(inside its bounds, resolved) and not separated from it — their BIC differ by less than
``BIC_THRESHOLD`` on n_eff, the rivals rule of the choice, so a term the choice says the
records separated is never also called ambiguous (collinear ones, |ρ| ≥ ``COLLINEAR``,
always are); and, where the kind's out-of-sample rule falls back to variance inflation
(fewer than 3 records), a term kept by every other rule but more than ``VIF_LIMIT`` a
combination of the model's parameters.

Whiteness is a verdict on the final model, not a gate: with structure left in the residual,
its normalised autocorrelation stays near 1 whatever share of it a true term removes, so
"Ljung–Box Q must drop" rejects true terms (KVLCC2's quadratic damping). Each step carries
the Q of its round's model and of its trial as evidence.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import partial
from itertools import combinations
from typing import Any

import numpy as np

from estimation.errors import EstimationFailed
from estimation.motion.output_error_fit import (
    HeldOut,
    MotionFit,
    fit_motion,
    leave_one_record_out,
    parameters_of,
)
from estimation.motion.profile import profile_start
from estimation.motion.records import Record, Setup
from estimation.motion.term_separation import (
    COLLINEAR,
    NEAR_COLLINEAR,
    independent_shares,
    partial_correlations,
    predicted_steps,
    sensitivities,
    variance_inflation,
)
from estimation.motion.terms import LIBRARY
from estimation.report_numbers import finite_or_none
from estimation.stats.acceptance_rules import (
    BIC_THRESHOLD,
    SEPARABLE,
    Rival,
    RuleSet,
    Trial,
)
from estimation.stats.diagnostics import ljung_box
from estimation.stats.misfit import effective_sample_size
from estimation.stats.out_of_sample import loro_dropped

#: |partial ρ| of two candidates' sensitivities at or above which they explain the same part
#: of the residual (rivals; a kept term's near-twin).
RIVALS = NEAR_COLLINEAR
#: Kept trials whose BIC differ by less than this tie: the earlier in library order is added.
TIE_BIC = 2.0
#: A trial predicted to gain less than this share of a kept one's is not worth a fit.
FAR_BEHIND = 0.5
#: Above this variance inflation a term needs out-of-sample evidence (R² > 0.9 on the other
#: parameters: its σ is inflated √10 ≈ 3.2×; the conventional "serious collinearity" bound,
#: Kutner et al., Applied Linear Statistical Models, §10.5).
VIF_LIMIT = 10.0
#: Model evaluations of a trial refit that starts one Gauss–Newton step from its optimum
#: (the backward check's refits, a rival's swap, the uncertainty budget's refits).
TRIAL_NFEV = 40
#: Experiments that separate a pair better than each member's own advice.
PAIR_EXPERIMENTS = {
    frozenset({"coulomb_friction", "constant_bias"}): (
        "coulomb_friction and constant_bias are collinear when every run moves the same way: "
        "add a reverse tow/spin (opposite force) or a free-decay run"
    ),
}


@dataclass(frozen=True)
class Step:
    """Evidence for one trial (``term`` joins a pair's members with ' + '): its ΔBIC, the
    residual it explains and the position noise (m or rad), the verdict (``accepted``: it
    passed the rules; ``added``: its round added it), the Ljung–Box Q of the round's model
    and of the trial (NaN: not fitted) and the leave-one-record-out RMSE of the model
    without and with it (m or rad; NaN: not computed, fewer than 3 records or the rule not
    reached). ``backward``: a verdict of the backward check (the term judged again against
    the final model without it), not a trial of a forward round."""

    term: str
    round: int
    delta_bic: float
    explained_rms: float
    noise: float
    accepted: bool
    reason: str
    q_before: float = np.nan
    q_after: float = np.nan
    added: bool = False
    loro_before: float = np.nan
    loro_after: float = np.nan
    backward: bool = False

    @classmethod
    def untried(cls, terms: Sequence[str], round_no: int, why: str, delta: float = np.nan) -> Step:
        """A trial not fitted (screened out, or its fit failed): ``delta`` its predicted ΔBIC."""
        return cls(" + ".join(terms), round_no, delta, np.nan, np.nan, False, why)

    def to_json(self) -> dict[str, Any]:
        """The step as every result document writes it (docs/estimation.md, *evidence*)."""
        return {
            "round": self.round,
            "effect": self.term,
            "delta_bic": finite_or_none(self.delta_bic),
            "explained_rms": finite_or_none(self.explained_rms),
            "noise": finite_or_none(self.noise),
            "accepted": self.accepted,
            "added": self.added,
            "reason": self.reason,
            "ljung_box_q_before": finite_or_none(self.q_before),
            "ljung_box_q_after": finite_or_none(self.q_after),
            "cv_rmse_before": finite_or_none(self.loro_before),
            "cv_rmse_after": finite_or_none(self.loro_after),
            "backward_check": self.backward,
        }


@dataclass(frozen=True)
class KindSearch:
    """What a record kind tells the one search.

    ``rules``: its acceptance rules. ``pairs``: its first round also tries pairs.
    ``own_parameters``: its model's own parameters, in the words of the screen's reason.
    ``unresolved(terms, fit)``: why members are below what its experiment resolves.
    ``floor_ratio(fit)``: the residual against the noise floor the fit implies.
    ``trial_nfev``: model evaluations of a trial fit. ``free``: the records are free decays
    (the advice that separates two terms differs). ``start_value(term)``: a term's own
    small physical start value where no linearised step gives one (a swap; None: 0).
    """

    rules: RuleSet
    pairs: bool
    own_parameters: str
    unresolved: Callable[[Sequence[str], MotionFit], list[str]] | None = None
    floor_ratio: Callable[[MotionFit], float] | None = None
    trial_nfev: int = TRIAL_NFEV
    free: bool = False
    start_value: Callable[[str], float] | None = None


@dataclass(frozen=True)
class SearchOutcome:
    """The base and final fits, every step, the groups of terms the records cannot tell
    apart (a kept term first) with the advice that would, the fits of candidates rejected
    against the final model and of the terms the backward check removed (nested in the
    final: evidence whether its coefficients move), and the leave-one-record-out RMSE of
    the base and final models (None: fewer than 3 records)."""

    base: MotionFit
    final: MotionFit
    steps: tuple[Step, ...]
    ambiguous: tuple[tuple[str, ...], ...] = ()
    advice: tuple[str, ...] = ()
    rejected: tuple[MotionFit, ...] = ()
    cv_base: float | None = None
    cv_final: float | None = None
    #: False when the search was off (the final fit is the base fit, nothing was tried).
    searched: bool = True
    #: Per term that a kept one cannot be told from: the final model with it in its place.
    alternatives: dict[str, MotionFit] = field(default_factory=dict)


class HeldOutErrors:
    """The leave-one-record-out errors of the fits one search judges, each computed once."""

    def __init__(self, records: Sequence[Record], setup: Setup) -> None:
        self.records, self.setup = records, setup
        self._done: dict[tuple[tuple[str, ...], bytes], HeldOut | None] = {}

    def of(self, fit: MotionFit) -> HeldOut | None:
        """``fit``'s check (None: fewer than 3 records); raises ``EstimationFailed``."""
        key = (fit.names, parameters_of(fit).tobytes())
        if key not in self._done:
            self._done[key] = leave_one_record_out(self.records, self.setup, fit)
        return self._done[key]

    def rmse(self, fit: MotionFit, folds: Sequence[int] | None = None) -> float | None:
        """``fit``'s pooled held-out RMSE, over ``folds`` only when given (None: fewer than
        3 records, no fold, or a refit failed)."""
        try:
            held = self.of(fit)
        except EstimationFailed:
            return None
        if held is None or (folds is not None and not folds):
            return None
        return held.rmse if folds is None else held.pooled_over(folds)


@dataclass
class _Round:
    """One round's screen of the candidates left on the current fit."""

    predicted: dict[tuple[str, ...], float]  # trial → predicted BIC
    linear: dict[tuple[str, ...], dict[str, float]]  # trial → its terms' linearised values
    rho: dict[frozenset[str], float]
    own: np.ndarray  # the current model's own sensitivities (coefficients, nuisances)


class _Search:
    """One search (module doc): its records, the kind's part, and what it has seen."""

    def __init__(
        self, records: Sequence[Record], setup: Setup, kind: KindSearch, order: dict[str, int]
    ) -> None:
        self.records, self.setup, self.kind, self.order = records, setup, kind, order
        self.steps: list[Step] = []
        self.held_out = HeldOutErrors(records, setup)
        self.travel = max((float(np.ptp(r.x)) for r in records), default=0.0)
        self.times = tuple(np.asarray(r.t, dtype=float) for r in records)
        #: term → (the parameter it cannot be told from, the reason): kept by every other
        #: rule but inseparable without out-of-sample evidence.
        self.inseparable: dict[str, tuple[str, str]] = {}
        #: every converged fit made, by its terms (the backward check reuses them)
        self.fits: dict[frozenset[str], MotionFit] = {}

    # --- the screen -------------------------------------------------------------------

    def screen(
        self, current: MotionFit, remaining: Sequence[str], round_no: int, pairs: bool
    ) -> tuple[_Round, list[tuple[str, ...]]]:
        """The round's screen and the trials worth judging (singles, then pairs); what is
        not tried is recorded as a step."""
        records, setup = self.records, self.setup
        shares = independent_shares(records, setup, current, remaining)
        rho = partial_correlations(records, setup, current, [*current.effects, *remaining])
        tried: list[str] = []
        for c in remaining:
            why = SEPARABLE.verdict(c, shares[c], self.kind.own_parameters)
            twins = [k for k in current.effects if abs(rho[frozenset((c, k))]) >= COLLINEAR]
            if why is None and twins:
                why = f"{c} is collinear with the kept {twins[0]} on these records"
            if why is None:
                tried.append(c)
            else:
                self.steps.append(Step.untried((c,), round_no, why))
        trials: list[tuple[str, ...]] = [(c,) for c in tried]
        if pairs:
            trials += [p for p in combinations(tried, 2) if abs(rho[frozenset(p)]) < COLLINEAR]
        # one sensitivity matrix for the whole screen: every remaining candidate's
        steps = predicted_steps(records, setup, current, trials, remaining)
        _, jac, nuisance = sensitivities(records, setup, current, remaining)
        own = np.hstack([jac[:, : len(current.names)], nuisance])
        n = current.n_samples
        predicted, linears = {}, {}
        for trial in trials:
            sse, added, past = steps[trial]
            gain = n * np.log(max(sse, 1e-300) / current.sse) + len(trial) * np.log(n)
            predicted[trial] = current.bic + gain
            linear = {t: past.get(t, float(v)) for t, v in zip(trial, added, strict=True)}
            linears[trial] = linear
        return _Round(predicted, linears, rho, own), trials

    def _start(
        self, current: MotionFit, own: np.ndarray, trial: tuple[str, ...], linear: dict[str, float]
    ) -> np.ndarray:
        """A trial's full start vector: the current fit's parameters, each new term at its
        linearised value (clipped to its bounds), a lone set-valued term from its profile."""
        if len(trial) == 1 and LIBRARY[trial[0]].set_valued_at_rest:
            (term,) = trial
            return profile_start(self.records, self.setup, current, own, term, linear[term])
        p = parameters_of(current)
        k = len(current.values)
        added = [float(np.clip(linear[t], LIBRARY[t].lower, LIBRARY[t].upper)) for t in trial]
        return np.concatenate([p[:k], added, p[k:]])

    # --- the judge --------------------------------------------------------------------

    def judge(
        self,
        current: MotionFit,
        trial: MotionFit,
        terms: tuple[str, ...],
        round_no: int,
        rival: tuple[str, MotionFit] | None = None,
        stage: str = "forward",
    ) -> Step:
        """The kind's rules for ``trial`` = ``current`` + ``terms``; ``rival``: a model it must
        also beat (named, fit); ``stage``: "forward" or "backward" (the check)."""
        seen: list[float] = []
        unresolved, floor_ratio = self.kind.unresolved, self.kind.floor_ratio
        evidence = Trial(
            terms,
            current,
            trial,
            self.travel,
            not_identified=trial.not_identified,
            rival=None if rival is None else Rival(rival[0], rival[1]),
            unresolved=None if unresolved is None else partial(unresolved, terms, trial),
            floor_ratio=None if floor_ratio is None else partial(floor_ratio, trial),
            out_of_sample=lambda: self.out_of_sample(current, trial, terms, rival, seen),
            times=self.times,
            stage=stage,
        )
        reason = self.kind.rules.verdict(evidence)
        loro_before, loro_after = seen or (np.nan, np.nan)
        return Step(
            " + ".join(terms),
            round_no,
            evidence.delta_bic,
            evidence.explained_rms,
            evidence.noise,
            reason == "kept",
            reason,
            q_before=ljung_box(current.residuals).q_statistic,
            q_after=ljung_box(trial.residuals).q_statistic,
            loro_before=loro_before,
            loro_after=loro_after,
        )

    def out_of_sample(
        self,
        current: MotionFit,
        trial: MotionFit,
        terms: tuple[str, ...],
        rival: tuple[str, MotionFit] | None,
        seen: list[float],
    ) -> str | None:
        """Why ``trial`` predicts records it did not see no better than ``current`` (and the
        rival), or None; with fewer than 3 records the kind's stand-in (variance
        inflation, or nothing). ``seen`` receives the two pooled RMSEs."""
        try:
            bars = [self.held_out.of(current)]
            if rival is not None:
                bars.append(self.held_out.of(rival[1]))
            new = self.held_out.of(trial)
        except EstimationFailed as err:
            return f"leave-one-record-out refit failed: {err.why}"
        folds = self.testing_folds(current, terms) if new is not None else []
        if new is None or not folds:
            if not self.kind.rules.variance_inflation_stands_in:
                return None
            return self.tied(
                trial,
                terms,
                "too few records for a leave-one-record-out check"
                if new is None
                else "no record left out leaves the others able to separate it",
            )
        bar = bars[0]
        assert bar is not None
        before, after = bar.pooled_over(folds), new.pooled_over(folds)
        seen[:] = [before, after]
        if all(b is None or loro_dropped(after, b.pooled_over(folds)) for b in bars):
            return None
        shown = ", ".join(
            f"{self.records[i].run_id} {bar.per_record[i]:.3g} → {new.per_record[i]:.3g}"
            for i in folds
        )
        left = [self.records[i].run_id for i in range(len(self.records)) if i not in folds]
        aside = (
            f"; without {', '.join(left)} the other records cannot fit {' + '.join(terms)}, "
            "so those folds are not counted"
            if left
            else ""
        )
        return (
            f"leave-one-record-out error did not drop (RMSE {before:.4g} → "
            f"{after:.4g}; per record {shown}{aside})"
        )

    def testing_folds(self, current: MotionFit, terms: Sequence[str]) -> list[int]:
        """The leave-one-record-out folds that can test ``terms``: those whose training
        records (all but the fold's) leave each term at least the screen's share of its
        sensitivity independent of ``current``'s parameters (``SEPARABLE``). On the others
        the term is a combination of those parameters, so the fold's refit puts an arbitrary
        value on it (a mirror pair of spins, +5 and −5 N·m, cannot tell dry friction from
        K_L) and its prediction of the record left out says nothing about the term."""
        new = [t for t in terms if t not in current.names]
        return [
            i
            for i in range(len(self.records))
            if all(
                SEPARABLE.verdict(t, share, "") is None
                for t, share in independent_shares(
                    self.records, self.setup, current, new, without=i
                ).items()
            )
        ]

    def tied(
        self,
        fit: MotionFit,
        terms: Sequence[str],
        unchecked: str = "too few records for a leave-one-record-out check",
    ) -> str | None:
        """Why a member of ``terms`` is not identified without out-of-sample evidence
        (variance inflation above ``VIF_LIMIT``), or None; recorded in ``inseparable``.
        ``unchecked``: why there is no such evidence, in the reason's words."""
        for term in terms:
            vif = variance_inflation(self.records, self.setup, fit, term)
            if vif <= VIF_LIMIT:
                continue
            i = fit.names.index(term)
            # a parameter the fit cannot determine has no correlation (NaN): not a partner
            row = np.nan_to_num(np.abs(fit.correlation[i]), nan=-1.0)
            j = int(np.argmax(np.where(np.arange(len(fit.names)) == i, -1.0, row)))
            partner = fit.names[j]
            rho = fit.correlation[i, j]
            shown = f"ρ = {rho:.3f}" if np.isfinite(rho) else "ρ unknown: no σ"
            reason = (
                f"{term} not identified: inseparable from {partner} on these records "
                f"(VIF {vif:.0f} > {VIF_LIMIT:g}, {shown}; {unchecked}): add "
                f"{LIBRARY[term].separation(self.kind.free)}"
            )
            self.inseparable.setdefault(term, (partner, reason))
            return reason
        return None

    # --- a round ----------------------------------------------------------------------

    def round(
        self,
        current: MotionFit,
        screen: _Round,
        trials: Sequence[tuple[str, ...]],
        round_no: int,
        rival_of: dict[str, str],
        beat: tuple[str, MotionFit] | None = None,
    ) -> tuple[dict[tuple[str, ...], MotionFit], list[MotionFit]]:
        """Fit and judge ``trials`` (module doc, *Rounds*): the kept ones and the fits of
        the rejected. ``beat``: the model every trial must also beat (a pair: the best
        single); a single that rivals a kept term must beat the model with it alone."""
        bar = (current.bic, "the current model")
        if beat is not None and beat[1].bic < current.bic:
            bar = (beat[1].bic, beat[0])
        position = {t: i for i, t in enumerate(trials)}
        kept: dict[tuple[str, ...], MotionFit] = {}
        rejected: list[MotionFit] = []
        for trial in sorted(trials, key=lambda t: (screen.predicted[t], position[t])):
            why = self._not_fitted(current, screen, trial, bar, kept)
            if why is not None:
                delta = screen.predicted[trial] - current.bic
                self.steps.append(Step.untried(trial, round_no, why, delta))
                continue
            try:
                fit = fit_motion(
                    self.records,
                    self.setup,
                    (*current.effects, *trial),
                    start=self._start(current, screen.own, trial, screen.linear[trial]),
                    max_nfev=self.kind.trial_nfev,
                )
            except EstimationFailed as err:
                self.steps.append(Step.untried(trial, round_no, err.why))
                continue
            self.fits.setdefault(frozenset(fit.effects), fit)
            rival = beat
            if rival is None and len(trial) == 1 and trial[0] in rival_of:
                rival = (f"{rival_of[trial[0]]} alone", current)
            step = self.judge(current, fit, trial, round_no, rival)
            self.steps.append(step)
            if step.accepted:
                kept[trial] = fit
            else:
                rejected.append(fit)
        return kept, rejected

    def _not_fitted(
        self,
        current: MotionFit,
        screen: _Round,
        trial: tuple[str, ...],
        bar: tuple[float, str],
        kept: dict[tuple[str, ...], MotionFit],
    ) -> str | None:
        """Why ``trial`` is not worth a converged fit (module doc), or None. ``bar``: the
        BIC it must beat, and whose it is."""
        past = [(t, v) for t, v in screen.linear[trial].items() if not LIBRARY[t].in_bounds(v)]
        if past:
            term, value = past[0]
            return (
                f"not fitted: a linearised step wants {term} = {value:.3g}, beyond its "
                f"physical bound ({LIBRARY[term].physical or 'its bounds'})"
            )
        bic = screen.predicted[trial]
        if bic >= bar[0]:
            return (
                f"not fitted: a linearised step predicts ΔBIC {bic - current.bic:.1f}, no "
                f"gain over {bar[1]}"
            )
        # an earlier rival of a kept trial may still win the round (``choose``): fit it
        rivals_kept = len(trial) == 1 and any(
            len(k) == 1
            and self.order[trial[0]] < self.order[k[0]]
            and abs(screen.rho[frozenset((trial[0], k[0]))]) >= RIVALS
            for k in kept
        )
        gains = [screen.predicted[k] - current.bic for k in kept]
        if gains and not rivals_kept and bic - current.bic > FAR_BEHIND * min(gains):
            return "not fitted: a linearised step predicts far less gain than a kept trial"
        return None

    def choose(
        self, kept: dict[tuple[str, ...], MotionFit], rho: dict[frozenset[str], float]
    ) -> tuple[str, ...]:
        """The trial a round adds (module doc): the lowest BIC, unless an earlier one in
        library order ties with it, or rivals it (the two differ by one term each, and those
        two are rivals) and is not beaten on n_eff."""
        best = min(kept, key=lambda t: kept[t].bic)
        fit = kept[best]
        scale = effective_sample_size(fit.residuals) / fit.n_samples
        for trial in sorted(kept, key=self.key):
            if self.key(trial) >= self.key(best):
                break
            gap = kept[trial].bic - fit.bic
            if gap < TIE_BIC or (_rivals(trial, best, rho) and gap * scale < BIC_THRESHOLD):
                return trial
        return best

    def key(self, trial: Sequence[str]) -> tuple[int, ...]:
        """Library order of a trial (fewer terms first, then the earlier terms)."""
        return (len(trial), *sorted(self.order[t] for t in trial))

    # --- the backward check -----------------------------------------------------------

    def backward(self, final: MotionFit, round_no: int) -> tuple[MotionFit, list[MotionFit]]:
        """The final fit without the terms that no longer pass (module doc), and the fits
        each removal left. Each removal, and then each term that stays (with the held-out
        errors of the final model without and with it), is a step of round ``round_no``. A
        model the search has already fitted to convergence (the one a term was added to, a
        round's single) is not refitted."""
        removed: list[MotionFit] = []
        while True:
            failing, passed = [], {}
            for term in final.effects:
                start = np.delete(parameters_of(final), final.names.index(term))
                rest = tuple(e for e in final.effects if e != term)
                if (seen := self.fits.get(frozenset(rest))) is not None:
                    without = seen  # a converged fit of the same model, made this search
                else:
                    try:
                        without = fit_motion(
                            self.records, self.setup, rest, start=start, max_nfev=TRIAL_NFEV
                        )
                    except EstimationFailed:
                        continue
                again = self.judge(without, final, (term,), round_no, stage="backward")
                if not again.accepted:
                    failing.append((final.bic - without.bic, again, without))
                else:
                    passed[term] = again
            if not failing:
                self.steps += [
                    replace(passed[t], reason="kept in the backward check", backward=True)
                    for t in final.effects
                    if t in passed
                ]
                return final, removed
            _, again, final = max(failing, key=lambda f: f[0])  # the cheapest to leave out
            removed.append(final)
            self.steps.append(
                replace(
                    again, reason=f"removed in the backward check: {again.reason}", backward=True
                )
            )

    # --- ambiguity --------------------------------------------------------------------

    def ambiguities(
        self, final: MotionFit, candidates: Sequence[str]
    ) -> tuple[tuple[tuple[str, ...], ...], tuple[str, ...], dict[str, MotionFit]]:
        """Groups (a kept term, then those the records cannot tell from it), the advice that
        would separate each (module doc, *Ambiguity*) and each twin's converged fit in its
        kept term's place."""
        others = [c for c in candidates if c not in final.effects]
        rho = (
            partial_correlations(self.records, self.setup, final, [*final.effects, *others])
            if final.effects
            else {}
        )
        groups: list[tuple[str, ...]] = []
        advice: list[str] = []
        swaps: dict[str, MotionFit] = {}
        for kept in final.effects:
            twins = []
            for c in others:
                r = abs(rho[frozenset((kept, c))])
                if r >= RIVALS and (swap := self._alike(final, kept, c, r < COLLINEAR)):
                    twins.append(c)
                    swaps.setdefault(c, swap)
            if twins:
                group = (kept, *twins)
                groups.append(group)
                advice.append(self.separating_advice(group))
        for term, (partner, why) in self.inseparable.items():
            if term not in final.effects:
                groups.append((term, partner))
                advice.append(why)
        return tuple(groups), tuple(advice), swaps

    def _alike(
        self, final: MotionFit, kept: str, other: str, compare_bic: bool
    ) -> MotionFit | None:
        """The converged fit with ``other`` in place of ``kept`` when it is physical (inside
        its bounds, resolved) and, unless the two are collinear, the data do not separate
        the two: their BIC differ by less than ``BIC_THRESHOLD`` on the residual's effective
        sample size (the rivals rule of a round's choice); else None."""
        effects = tuple(other if e == kept else e for e in final.effects)
        start = parameters_of(final)
        start[list(final.names).index(kept)] = (
            0.0 if self.kind.start_value is None else self.kind.start_value(other)
        )
        try:
            swap = fit_motion(
                self.records, self.setup, effects, start=start, max_nfev=self.kind.trial_nfev
            )
        except EstimationFailed:
            return None
        if other in swap.at_bound:
            return None  # e.g. an aiding force cannot be dry friction
        if self.kind.unresolved is not None and self.kind.unresolved((other,), swap):
            return None
        if not compare_bic:
            return swap
        better = min((swap, final), key=lambda f: f.bic)
        scale = effective_sample_size(better.residuals) / better.n_samples
        return swap if abs(swap.bic - final.bic) * scale < BIC_THRESHOLD else None

    def separating_advice(self, group: Sequence[str]) -> str:
        """What would tell ``group``'s terms apart."""
        if (key := frozenset(group)) in PAIR_EXPERIMENTS:
            return PAIR_EXPERIMENTS[key]
        parts = "; ".join(f"{e}: {LIBRARY[e].separation(self.kind.free)}" for e in group)
        return f"{' and '.join(group)} explain the data alike: to separate them — {parts}"


def search_terms(
    records: Sequence[Record],
    setup: Setup,
    base: MotionFit,
    candidates: Sequence[str],
    kind: KindSearch,
) -> SearchOutcome:
    """The one search (module doc) over ``candidates`` (in library order of preference)
    from ``base``."""
    search = _Search(records, setup, kind, {c: i for i, c in enumerate(candidates)})
    search.fits[frozenset(base.effects)] = base
    current, round_no = base, 1
    rival_of: dict[str, str] = {}  # a candidate still tried, and the kept term it rivals
    remaining = [c for c in candidates if c not in base.names]
    rejected_last: list[MotionFit] = []
    while remaining:
        pairs = kind.pairs and round_no == 1
        screen, trials = search.screen(current, remaining, round_no, pairs)
        first = len(search.steps)
        singles = [t for t in trials if len(t) == 1]
        kept, rejected_last = search.round(current, screen, singles, round_no, rival_of)
        chosen = search.choose(kept, screen.rho) if kept else None
        if pairs:
            beat = (
                None if chosen is None else (f"the best single effect ({chosen[0]})", kept[chosen])
            )
            duos = [t for t in trials if len(t) == 2]
            kept_pairs, rejected = search.round(current, screen, duos, round_no, {}, beat)
            rejected_last += rejected
            if kept_pairs:
                kept = {**kept, **kept_pairs}
                chosen = search.choose(kept_pairs, screen.rho)
        q_now = ljung_box(current.residuals).q_statistic
        search.steps[first:] = [replace(s, q_before=q_now) for s in search.steps[first:]]
        if chosen is None:
            round_no += 1  # the backward check is a round of its own
            break
        current = kept[chosen]
        rejected_last = []
        shown = " + ".join(chosen)
        search.steps[first:] = [_verdict_of_round(s, shown) for s in search.steps[first:]]
        for term in chosen:
            rival_of.pop(term, None)  # the data separated a rival pair: both are kept
        for c in sorted(remaining, key=search.order.__getitem__):
            if c in chosen or c in rival_of:
                continue
            for k in chosen:
                if abs(screen.rho[frozenset((c, k))]) >= RIVALS:
                    rival_of[c] = k
                    break
        remaining = [c for c in remaining if c not in chosen]
        round_no += 1
    final, removed = search.backward(current, round_no)
    ambiguous, advice, swaps = search.ambiguities(final, candidates)
    # the held-out errors over the folds that can test what was found (``testing_folds``)
    tested = search.testing_folds(base, final.effects) if final.effects else None
    return SearchOutcome(
        base=base,
        final=final,
        steps=tuple(search.steps),
        ambiguous=ambiguous,
        advice=advice,
        rejected=(*rejected_last, *removed),
        cv_base=search.held_out.rmse(base, tested),
        cv_final=search.held_out.rmse(final, tested),
        alternatives=swaps,
    )


def evidence_json(
    before: MotionFit | None,
    after: MotionFit | None,
    cv_before: float | None,
    cv_after: float | None,
    steps: Sequence[Step],
) -> dict[str, Any]:
    """A result's ``evidence``, every kind alike: the BIC and leave-one-record-out RMSE of the
    models before and after the search (None where not formed) and every step."""
    return {
        "bic_before": None if before is None else finite_or_none(before.bic),
        "bic_after": None if after is None else finite_or_none(after.bic),
        "cv_rmse_before": finite_or_none(cv_before),
        "cv_rmse_after": finite_or_none(cv_after),
        "steps": [s.to_json() for s in steps],
    }


def _rivals(a: Sequence[str], b: Sequence[str], rho: dict[frozenset[str], float]) -> bool:
    """Two trials are rivals when they differ by one term each and those two are."""
    only_a, only_b = set(a) - set(b), set(b) - set(a)
    if len(only_a) != 1 or len(only_b) != 1:
        return False
    return abs(rho[frozenset((*only_a, *only_b))]) >= RIVALS


def _verdict_of_round(step: Step, chosen: str) -> Step:
    """``step`` once its round has added ``chosen``: added, or — when it passed the rules
    too — said to have lost to it."""
    if step.term == chosen:
        return replace(step, added=True)
    if step.accepted:
        return replace(step, reason=f"passed the rules; {chosen} was added this round")
    return step
