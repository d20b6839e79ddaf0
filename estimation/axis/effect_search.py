"""Effect search over subsets of the library, judged as combinations.

Every single effect and every pair of effects is a candidate combination; a combination is
kept only if, as a whole, it passes the tow's acceptance rules (``TOW_RULES`` in
``estimation.stats.acceptance_rules``, the one rule set of every record kind): the error is
not already round-off; ΔBIC below −``BIC_THRESHOLD``; a pair beats the best single by
another ``BIC_THRESHOLD``; no member at its physical bound or below what the experiment
resolves (``materiality``); the error cut materially (halved, or the force-domain residual
brought near the noise floor: structure outside the library is never absorbed by an effect
that only nibbles at it, see unexplained.py); and the check on data the fit did not see:
the leave-one-run-out error drops (by more than the refits' own tolerance,
``stats.out_of_sample.loro_dropped``), or, when it cannot be formed (fewer than 3 runs), no member's
variance inflation against the model's other parameters exceeds ``VIF_LIMIT``: such a
term is > 90 % a combination of M, K_L, K_Q (and the other effects) on these runs, so any
small misfit of those (a release instant a few ms off, an undeclared pulley inertia)
projects onto it and the in-sample BIC cannot tell the two apart; only a prediction of
data the fit did not see can. It is reported as not identified, inseparable from its most
correlated parameter, with the run that separates them (two forward tows claimed a
0.042 N bias, ρ = 0.98 with K_L, VIF 450, from a 27 ms release offset).
Whiteness is not a gate: with structure left in the residual, its normalised
autocorrelation stays near 1 whatever share of it a real effect removes, so "Ljung–Box Q
must drop" rejected true effects (docs/estimation.md); it decides the ``unexplained`` verdict.
A pair must also beat the best single's leave-one-run-out error; a winning pair is
extended one effect at a time under the same rules (triples and beyond).

One Gauss–Newton step from the reference fit (one sensitivity matrix for all candidates)
predicts each combination's error; only combinations predicted to help are fitted to
convergence and judged, so the verdict never rests on a partly converged fit.

Two effects are *ambiguous* when their sensitivities are collinear on these runs
(``motion.term_separation.COLLINEAR``), or nearly so and fully converged fits with either
one explain the data alike (BIC within ``AMBIGUITY_BIC``). A collinear pair is never fitted
together.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from itertools import combinations

import numpy as np

from estimation.axis.ambiguity import AMBIGUITY_BIC, ambiguities
from estimation.axis.effects import EFFECTS
from estimation.axis.force_residual import noise_floor_ratio
from estimation.axis.materiality import below_resolution
from estimation.axis.model import records_of, setup_of
from estimation.axis.output_error import (
    MotionFit,
    fit_output_error,
    leave_one_run_out_rmse,
)
from estimation.axis.prepared_run import PreparedRun
from estimation.motion.term_separation import (
    COLLINEAR,
    independent_shares,
    partial_correlations,
    predicted_steps,
    variance_inflation,
)
from estimation.stats.acceptance_rules import (
    BIC_THRESHOLD,
    SEPARABLE,
    TOW_RULES,
    Rival,
    Trial,
)
from estimation.stats.diagnostics import ljung_box
from estimation.stats.out_of_sample import loro_dropped
from estimation.stats.selection import forward_selection, select_round

FAR_BEHIND = 0.5  # predicted gain below half a kept one's (both predicted): not worth a fit
#: Above this variance inflation a term needs out-of-sample evidence (R² > 0.9 on the other
#: parameters: its σ is inflated √10 ≈ 3.2×; the conventional "serious collinearity" bound,
#: Kutner et al., Applied Linear Statistical Models, §10.5).
VIF_LIMIT = 10.0


@dataclass(frozen=True)
class SearchStep:
    """Evidence for one candidate combination (``effect`` joins its members with ' + ')."""

    effect: str
    delta_bic: float
    cv_before: float | None
    cv_after: float | None
    ljung_box_before: float
    ljung_box_after: float
    accepted: bool
    reason: str
    round: int = 1  # 1 = singles and pairs on the base model, 2… = extensions of the winner


@dataclass(frozen=True)
class SearchOutcome:
    """Base fit, final fit, the steps taken and the ambiguities found."""

    base: MotionFit
    final: MotionFit
    cv_base: float | None
    cv_final: float | None
    steps: tuple[SearchStep, ...]
    ambiguous: tuple[tuple[str, ...], ...] = ()
    advice: tuple[str, ...] = field(default=())
    #: False when the search was off (the final fit is the base fit, nothing was tried).
    searched: bool = True


def candidate_effects(runs_declared_mass: bool) -> list[str]:
    """Effects worth trying: an inertia term (the hung weight's) only when the hung mass is
    not declared (declared, its weight is 0 and the term could not act)."""
    return [e for e in EFFECTS if EFFECTS[e].role != "inertia" or not runs_declared_mass]


@dataclass(frozen=True)
class _Reference:
    """What a combination must beat: a fit, its LORO error and its Ljung–Box Q."""

    fit: MotionFit
    cv: float | None
    q: float


class _Search:
    """One search over ``candidates`` on ``runs`` (holds the fits already made)."""

    def __init__(self, runs: Sequence[PreparedRun], candidates: Sequence[str]) -> None:
        self.runs = runs
        #: the runs as the one equation reads them (records, setup)
        self.equation = (records_of(runs), setup_of(runs))
        self.order = {e: i for i, e in enumerate(candidates)}
        self.steps: list[SearchStep] = []
        self.cv: dict[tuple[str, ...], float | None] = {}
        self.travel = max((float(np.ptp(r.x)) for r in runs), default=0.0)
        #: effect → (the parameter it cannot be told from, the reason): kept by every other
        #: rule but inseparable without out-of-sample evidence (module doc).
        self.inseparable: dict[str, tuple[str, str]] = {}

    def key(self, combo: Sequence[str]) -> tuple[int, ...]:
        """Library order of a combination (ties are broken towards common effects)."""
        return (len(combo), *sorted(self.order[e] for e in combo))

    def judge(
        self,
        ref: _Reference,
        combo: tuple[str, ...],
        fit: MotionFit,
        round_no: int,
        rival: _Reference | None = None,
    ) -> bool:
        """Record the evidence for ``combo`` (added to ``ref``) and whether it is kept.

        ``rival``: a model the combination must also beat on every count (a pair against
        the best single: BIC by another ``BIC_THRESHOLD``, Ljung–Box Q, LORO error).
        """
        gain = fit.bic - ref.fit.bic
        q_new = ljung_box(fit.residuals).q_statistic
        out_of_sample: list[float | None] = [None]  # the LORO error, once computed

        def check_out_of_sample() -> str | None:
            cv_new = out_of_sample[0] = leave_one_run_out_rmse(self.runs, fit)
            bars = [ref.cv] + ([rival.cv] if rival is not None else [])
            if cv_new is None:
                return self.tied(fit, combo)
            if any(b is not None and not loro_dropped(cv_new, b) for b in bars):
                return "leave-one-run-out error did not drop"
            return None

        trial = Trial(
            combo,
            ref.fit,
            fit,
            self.travel,
            rival=None if rival is None else Rival("the best single effect", rival.fit),
            unresolved=lambda: [
                b for b in (below_resolution(e, fit, self.runs) for e in combo) if b
            ],
            floor_ratio=lambda: noise_floor_ratio(fit, self.runs),
            out_of_sample=check_out_of_sample,
            times=tuple(r.t for r in self.runs),
        )
        reason = TOW_RULES.verdict(trial)
        cv_new = out_of_sample[0]
        kept = reason == "kept"
        if kept:
            self.cv[fit.effects] = cv_new
        self.steps.append(
            SearchStep(
                " + ".join(combo), gain, ref.cv, cv_new, ref.q, q_new, kept, reason, round_no
            )
        )
        return kept

    def tied(self, fit: MotionFit, combo: Sequence[str]) -> str | None:
        """Why a member of ``combo`` is not identified without out-of-sample evidence
        (variance inflation above ``VIF_LIMIT``), or None; recorded in ``inseparable``."""
        for effect in combo:
            vif = variance_inflation(*self.equation, fit, effect)
            if vif <= VIF_LIMIT:
                continue
            i = fit.names.index(effect)
            # a parameter the fit cannot determine has no correlation (NaN): not a partner
            row = np.nan_to_num(np.abs(fit.correlation[i]), nan=-1.0)
            j = int(np.argmax(np.where(np.arange(len(fit.names)) == i, -1.0, row)))
            partner = fit.names[j]
            rho = fit.correlation[i, j]
            shown = f"ρ = {rho:.3f}" if np.isfinite(rho) else "ρ unknown: no σ"
            reason = (
                f"{effect} not identified: inseparable from {partner} on these runs "
                f"(VIF {vif:.0f} > {VIF_LIMIT:g}, {shown}"
                f"; too few runs for a leave-one-run-out check): add "
                f"{EFFECTS[effect].separated_by}"
            )
            self.inseparable.setdefault(effect, (partner, reason))
            return reason
        return None

    def best(
        self,
        ref: _Reference,
        combos: Sequence[tuple[str, ...]],
        round_no: int,
        rival: _Reference | None = None,
    ) -> MotionFit | None:
        """The kept combination with the lowest BIC (library order within AMBIGUITY_BIC).

        A combination is fitted to convergence only when one Gauss–Newton step from the
        reference predicts a BIC below what it must beat (with ``BIC_THRESHOLD`` to spare)
        and a gain within ``FAR_BEHIND`` of a kept one; the others are recorded with their
        predicted ΔBIC.
        """
        predicted = predicted_steps(*self.equation, ref.fit, combos)
        gate = ref.fit.bic if rival is None else min(ref.fit.bic, rival.fit.bic - BIC_THRESHOLD)
        n = ref.fit.n_samples
        bics = {
            c: n * np.log(max(sse, 1e-300) / n) + (ref.fit.n_params + len(c)) * np.log(n)
            for c, (sse, _, _) in predicted.items()
        }

        def fit(c: tuple[str, ...], kept: Mapping[tuple[str, ...], MotionFit]) -> MotionFit | None:
            bic = bics[c]
            best_gain = min((bics[k] - ref.fit.bic for k in kept), default=0.0)
            why = None
            if bic >= gate + BIC_THRESHOLD:
                why = "a linearised step predicts no gain"
            elif bic - ref.fit.bic > FAR_BEHIND * best_gain:
                why = "a linearised step predicts far less gain than a kept combination"
            if why:
                self.steps.append(
                    SearchStep(
                        " + ".join(c),
                        bic - ref.fit.bic,
                        ref.cv,
                        None,
                        ref.q,
                        ref.q,
                        False,
                        f"not fitted: {why}",
                        round_no,
                    )
                )
                return None
            return fit_output_error(self.runs, (*ref.fit.effects, *c), start=predicted[c][1])

        chosen = select_round(
            sorted(combos, key=self.key),
            fit,
            lambda f: f.bic,
            lambda c, f, _: self.judge(ref, c, f, round_no, rival),
            predicted={c: bics[c] for c in combos},
            tolerance=AMBIGUITY_BIC,
        )
        return None if chosen is None else chosen[1]

    def identifiable(self, base: MotionFit, candidates: Sequence[str]) -> list[str]:
        """The candidates these runs can tell from inertia, K_L and K_Q (the rest are
        recorded as not identifiable: no fit could pin them down)."""
        shares = independent_shares(*self.equation, base, candidates)
        kept = []
        for e in candidates:
            why = SEPARABLE.verdict(e, shares[e], "inertia, K_L or K_Q")
            if why is None:
                kept.append(e)
            else:
                self.steps.append(SearchStep(e, 0.0, None, None, 0.0, 0.0, False, why))
        return kept

    def reference(self, fit: MotionFit) -> _Reference:
        """``fit`` as the model the next combinations must beat."""
        cv = self.cv.get(fit.effects)
        return _Reference(fit, cv, ljung_box(fit.residuals).q_statistic)


def search_effects(
    runs: Sequence[PreparedRun], base: MotionFit, candidates: Sequence[str]
) -> SearchOutcome:
    """Subset search of effects over ``candidates`` starting from ``base`` (module doc)."""
    search = _Search(runs, candidates)
    start = _Reference(
        base, leave_one_run_out_rmse(runs, base), ljung_box(base.residuals).q_statistic
    )
    candidates = search.identifiable(base, candidates)
    rho = partial_correlations(*search.equation, base, candidates)
    single = search.best(start, [(e,) for e in candidates], 1)
    pairs = [p for p in combinations(candidates, 2) if abs(rho[frozenset(p)]) < COLLINEAR]
    rival = search.reference(single) if single is not None else None
    chosen = search.best(start, pairs, 1, rival) or single
    current = start if chosen is None else search.reference(chosen)

    def extend(ref: _Reference, round_no: int) -> _Reference | None:
        """One more effect on a winning pair or larger (triples and beyond)."""
        rest = [e for e in candidates if e not in ref.fit.effects]
        rho = partial_correlations(*search.equation, ref.fit, [*ref.fit.effects, *rest])
        separable = [
            (e,)
            for e in rest
            if all(abs(rho[frozenset((e, k))]) < COLLINEAR for k in ref.fit.effects)
        ]
        chosen = search.best(ref, separable, round_no) if separable else None
        return None if chosen is None else search.reference(chosen)

    if chosen is not None and len(chosen.effects) >= 2:  # extend a winning pair
        current = forward_selection(current, extend, first_round=2)
    ambiguous, advice = ambiguities(runs, current.fit, candidates)
    tied = [
        (e, p, why) for e, (p, why) in search.inseparable.items() if e not in current.fit.effects
    ]
    ambiguous += tuple((e, p) for e, p, _ in tied)
    advice += tuple(why for _, _, why in tied)
    return SearchOutcome(
        base=base,
        final=current.fit,
        cv_base=start.cv,
        cv_final=current.cv,
        steps=tuple(search.steps),
        ambiguous=ambiguous,
        advice=advice,
    )
