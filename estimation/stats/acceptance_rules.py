"""The acceptance rules of the effect search: one set for every record kind.

A candidate — one term, or several judged together, added to the current model — is kept
when every rule its kind lists passes; the first that fails is the reason recorded for it
(each kind lists cheap evidence before costly). Each rule is a small object: a ``name``, a
``statement`` of what it asks and why, and ``verdict(trial)`` (None when it passes, else
the reason in words). ``RULE_SETS`` holds, per kind, the rules it applies and why it leaves
each other rule out — the union of the two searches that grew apart, decided here once and
printed with every result (``rules_json``). Every threshold is declared here once.

Before any fit, ``SEPARABLE`` screens out a term whose sensitivity is almost wholly a
combination of the model's own parameters' (every kind).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Protocol

import numpy as np

from estimation.stats.diagnostics import position_noise
from estimation.stats.fit_statistics import FitStatistics
from estimation.stats.misfit import effective_sample_size
from estimation.stats.out_of_sample import LORO_MIN_RUNS, LORO_RESOLUTION

#: ΔBIC below −10: "very strong" evidence (posterior odds > 150:1, Kass & Raftery 1995).
BIC_THRESHOLD = 10.0
#: A kept term explains at least this many times the position noise σ (RMS).
MATERIAL_NOISE = 1.0
#: An RMSE below this share of the travel is round-off, not structure (noise-free data).
NUMERICAL_SHARE = 1e-7
#: Below this share of its sensitivity independent of the model's own parameters' a term is
#: a combination of them on these records: no fit could pin it down.
MIN_INDEPENDENT_SHARE = 1e-3
MATERIAL_CUT = 0.5  # kept effects halve the RMSE unless they bring it to the noise floor
AT_NOISE_FLOOR = 2.0  # force-domain residual within 2× the floor the fit implies


@dataclass(frozen=True)
class Rival:
    """A model the candidate must also beat by ``BIC_THRESHOLD`` (``named`` in words)."""

    named: str
    fit: FitStatistics


@dataclass(frozen=True)
class Trial:
    """One candidate: ``terms`` added to ``current`` gave ``fit``, and the evidence only a
    kind can compute, asked for only when the rules before it passed (a leave-one-run-out
    check refits every run).

    ``travel``: the largest range of the motion over the records (m or rad).
    ``times``: each record's sample times (s) for the position noise (None: uniform).
    ``unresolved()``: why members are below what the experiment resolves (empty: none).
    ``floor_ratio()``: the residual against the noise floor the fit implies (force domain).
    ``out_of_sample()``: why a check on data the fit did not see fails, or None.
    ``stage``: "forward" (a trial added to the current model) or "backward" (a kept term
    judged again against the final model without it).
    """

    terms: tuple[str, ...]
    current: FitStatistics
    fit: FitStatistics
    travel: float
    not_identified: tuple[str, ...] = ()
    rival: Rival | None = None
    unresolved: Callable[[], list[str]] | None = None
    floor_ratio: Callable[[], float] | None = None
    out_of_sample: Callable[[], str | None] | None = None
    times: tuple[np.ndarray, ...] | None = None
    stage: str = "forward"

    @cached_property
    def delta_bic(self) -> float:
        """BIC of the trial minus the current model's."""
        return self.fit.bic - self.current.bic

    @cached_property
    def explained_rms(self) -> float:
        """√((SSE₀ − SSE₁)/n): the residual the candidate explains (m or rad)."""
        return float(np.sqrt(max(self.current.sse - self.fit.sse, 0.0) / self.current.n_samples))

    @cached_property
    def noise(self) -> float:
        """Position noise σ the trial implies (``stats.diagnostics.position_noise``)."""
        return position_noise(self.fit.residuals, self.times)


class Rule(Protocol):
    """One acceptance rule: ``verdict`` is None when the trial passes, else the reason."""

    @property
    def name(self) -> str: ...

    @property
    def statement(self) -> str: ...

    def verdict(self, trial: Trial) -> str | None: ...


@dataclass(frozen=True)
class RoundOff:
    """Nothing is left to explain once the current error is round-off."""

    share: float = NUMERICAL_SHARE
    name: str = "round-off"

    @property
    def statement(self) -> str:
        return (
            f"the current model's RMSE is above round-off ({self.share:g} of the travel): on "
            "noise-free data any term 'explains' numerical noise by a huge ΔBIC"
        )

    def verdict(self, trial: Trial) -> str | None:
        if trial.current.rmse <= self.share * trial.travel:
            return "the error is already at round-off: nothing left to explain"
        return None


@dataclass(frozen=True)
class Identified:
    """The data determine every new coefficient (no lost direction of the Jacobian)."""

    name: str = "identified"
    statement: str = "no direction of the Jacobian a new coefficient loads is lost"

    def verdict(self, trial: Trial) -> str | None:
        lost = [t for t in trial.terms if t in trial.not_identified]
        return f"{', '.join(lost)} is not identified by these records" if lost else None


@dataclass(frozen=True)
class Physical:
    """No new coefficient is held at the bound its physics sets."""

    name: str = "physical bound"
    statement: str = (
        "no new coefficient sits at its physical bound (a damping pushed to 0 wants a "
        "negative value a passive body cannot have)"
    )

    def verdict(self, trial: Trial) -> str | None:
        held = [t for t in trial.terms if t in trial.fit.at_bound]
        return f"{', '.join(held)} held at its physical bound" if held else None


@dataclass(frozen=True)
class StrongEvidence:
    """ΔBIC = n·ln(SSE₁/SSE₀) + Δp·ln n below −``threshold``."""

    threshold: float = BIC_THRESHOLD
    name: str = "information criterion"

    @property
    def statement(self) -> str:
        return (
            f"ΔBIC < −{self.threshold:g}, 'very strong' evidence (posterior odds > 150:1, "
            "Kass & Raftery 1995); BIC penalises a parameter by ln n, so a longer record "
            "does not make it more permissive"
        )

    def verdict(self, trial: Trial) -> str | None:
        gain = trial.delta_bic
        return None if gain < -self.threshold else f"ΔBIC {gain:.1f} ≥ −{self.threshold:g}"


@dataclass(frozen=True)
class BeatsRival:
    """Against a rival model (``Trial.rival``) the trial's BIC is lower by ``threshold``;
    ``effective``: the difference scaled to the residual's effective sample size
    n_eff = n·(1 − r₁)/(1 + r₁) (two alternatives that fit one direction differ by the
    residual's structure, which BIC on n counts as independent samples)."""

    effective: bool
    threshold: float = BIC_THRESHOLD
    name: str = "beats its rival"

    @property
    def statement(self) -> str:
        on = " on the residual's effective sample size" if self.effective else ""
        return f"ΔBIC < −{self.threshold:g}{on} against the rival model too"

    def verdict(self, trial: Trial) -> str | None:
        if trial.rival is None:
            return None
        gain = trial.fit.bic - trial.rival.fit.bic
        on = ""
        if self.effective:
            gain *= effective_sample_size(trial.fit.residuals) / trial.fit.n_samples
            on = " on the residual's effective sample size"
        if gain < -self.threshold:
            return None
        return (
            f"not better than {trial.rival.named} by ΔBIC {self.threshold:g}{on} "
            f"(ΔBIC {gain:.1f}): the data do not separate the two"
        )


@dataclass(frozen=True)
class AboveNoise:
    """The candidate explains at least ``factor`` × the position noise (RMS)."""

    factor: float = MATERIAL_NOISE
    name: str = "above the noise"

    @property
    def statement(self) -> str:
        return (
            f"the residual the candidate explains, √((SSE₀ − SSE₁)/n), is at least "
            f"{self.factor:g}× the position noise σ the fit implies (never measured against "
            "a drive or a restoring torque: on a lightly damped body every damping term is "
            "~1 % of the restoring torque)"
        )

    def verdict(self, trial: Trial) -> str | None:
        explained, noise = trial.explained_rms, trial.noise
        if explained < self.factor * noise:
            return (
                f"explains {explained:.3g} RMS, below the noise floor {noise:.3g} the fit implies"
            )
        return None


@dataclass(frozen=True)
class Resolved:
    """Each member is above what the experiment resolves (the kind's ``unresolved``)."""

    name: str = "resolved"
    statement: str = (
        "each member moves the fit by at least the motion floor (position noise, release "
        "timing, round-off), and a delay is beyond 3σ of the release timing"
    )

    def verdict(self, trial: Trial) -> str | None:
        below = trial.unresolved() if trial.unresolved is not None else []
        return "; ".join(below) if below else None


@dataclass(frozen=True)
class MaterialCut:
    """The candidate halves the RMSE, or brings the residual to within ``floor`` × the
    noise floor: structure outside the library is never absorbed by a term that only
    nibbles at it."""

    cut: float = MATERIAL_CUT
    floor: float = AT_NOISE_FLOOR
    name: str = "material cut"

    @property
    def statement(self) -> str:
        return (
            f"cuts the RMSE by {self.cut:.0%}, or leaves a residual within {self.floor:g}× "
            "the noise floor the fit implies"
        )

    def verdict(self, trial: Trial) -> str | None:
        before, after = trial.current.rmse, trial.fit.rmse
        if after <= (1 - self.cut) * before:
            return None
        if trial.floor_ratio is not None and trial.floor_ratio() <= self.floor:
            return None
        return (
            f"error not cut materially (RMSE −{1 - after / before:.1%}, residual still "
            "above the noise floor)"
        )


@dataclass(frozen=True)
class OutOfSample:
    """The kind's check on data the fit did not see: with ≥ ``LORO_MIN_RUNS`` runs (records)
    each is predicted by the shared coefficients refitted on the others, and the pooled error
    must drop by more than the refits resolve (``out_of_sample.loro_dropped``); ``held_out``
    names what is left out, ``judged`` which two models are compared, ``fewer`` what stands
    for the check with fewer; ``forward``: asked of a forward step too, not only in the
    backward check; ``variance_inflation``: with fewer records the variance-inflation
    bound stands in (``motion.term_search.VIF_LIMIT``)."""

    held_out: str = "run"
    fewer: str = "no member's variance inflation exceeds 10"
    judged: str = "with the candidate than without it"
    forward: bool = True
    variance_inflation: bool = True
    name: str = "out of sample"

    @property
    def statement(self) -> str:
        return (
            f"with ≥ {LORO_MIN_RUNS} {self.held_out}s, the leave-one-{self.held_out}-out "
            f"prediction error is lower by more than the refits resolve ({LORO_RESOLUTION:.0e} "
            f"of itself) {self.judged}, over the folds whose training {self.held_out}s can "
            f"separate the term; with fewer {self.held_out}s, or no such fold, {self.fewer}"
        )

    def verdict(self, trial: Trial) -> str | None:
        if trial.stage == "forward" and not self.forward:
            return None
        return trial.out_of_sample() if trial.out_of_sample is not None else None


@dataclass(frozen=True)
class RuleSet:
    """The rules a record kind applies, in order, and why it leaves each other one out."""

    rules: tuple[Rule, ...]
    omitted: dict[str, str]

    def verdict(self, trial: Trial) -> str:
        """ "kept", or the reason of the first rule the trial fails."""
        for rule in self.rules:
            if (why := rule.verdict(trial)) is not None:
                return why
        return "kept"

    @property
    def variance_inflation_stands_in(self) -> bool:
        """With fewer records than a leave-one-out check needs, the variance-inflation
        bound stands in for it (its ``OutOfSample`` rule says so)."""
        return any(isinstance(r, OutOfSample) and r.variance_inflation for r in self.rules)

    def to_json(self) -> dict[str, Any]:
        """{"applied": [{"name", "statement"}], "omitted": {name: why}} for every result."""
        applied = [{"name": r.name, "statement": r.statement} for r in self.rules]
        return {"applied": applied, "omitted": dict(self.omitted)}


#: Tows and spins (``estimation.motion.term_search``, as every kind's search).
TOW_RULES = RuleSet(
    (
        RoundOff(),
        StrongEvidence(),
        BeatsRival(effective=False),
        Physical(),
        Resolved(),
        MaterialCut(),
        OutOfSample(),
    ),
    {
        "identified": (
            "the screen before any fit (independent share) and the out-of-sample rule stand "
            "for it: a tow's fit reports no lost direction"
        ),
        "above the noise": "judged per member, with the release timing, by 'resolved'",
    },
)
#: Free decays and pendulums (``estimation.motion.term_search``).
DECAY_RULES = RuleSet(
    (
        RoundOff(),
        Identified(),
        Physical(),
        StrongEvidence(),
        AboveNoise(),
        BeatsRival(effective=True),
        OutOfSample(
            "record",
            forward=False,
            variance_inflation=False,
            judged=(
                "with each kept term than without it, judged on the final model in the "
                "backward check (a forward step compares two models that may both lack a true "
                "term, and a true term may predict only beside its partner)"
            ),
            fewer=(
                "it is not applied, nor the tows' variance-inflation bound in its place (a "
                "decay sweeps its amplitude, which separates B₁ from B₂, and a true quadratic "
                "damping's VIF is 70 on KVLCC2 run 21337): the backward check and the "
                "possibly-biased verdict guard the decay"
            ),
        ),
    ),
    {
        "resolved": (
            "a decay's release is fitted, not timed: its only floor is the position noise "
            "('above the noise')"
        ),
        "material cut": (
            "a decay's residual is its own noise plus what no library term explains; the "
            "misfit verdict on the final model speaks for the rest"
        ),
    },
)


@dataclass(frozen=True)
class Separable:
    """The screen before any fit: a term with less than ``min_share`` of its sensitivity
    independent of the model's own parameters' is a change of those parameters."""

    min_share: float = MIN_INDEPENDENT_SHARE

    def verdict(self, term: str, share: float, parameters: str) -> str | None:
        """None when ``term`` passes, else why (``parameters``: the model's, in words)."""
        if share >= self.min_share:
            return None
        return (
            f"{term} is not identified by these records: its effect is a change of "
            f"{parameters} (independent share {share:.2g} < {self.min_share:g})"
        )


SEPARABLE = Separable()
