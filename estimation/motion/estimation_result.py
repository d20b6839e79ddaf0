"""The one result of every estimate — a tow set's, a spin's, a free decay's, a pendulum's —
and its JSON document (docs/estimation.md, *The result document*).

What the one engine produces is a field of :class:`EstimationResult` for every kind: the
coefficients with σ (None: not identified) and unit, the effects the search kept and its
evidence, the error before and after, the residual's whiteness, what the records determine
well, B_e, the bootstrap, the repeats, the next release. What only one kind has (a tow's
drive laws and calibration draws, a decay's equilibrium, a pendulum's peaks and seed methods)
is its ``section``: an object with its own fields and document keys
(:class:`KindSection`; ``axis.tow_section``, ``motion.decay_section``,
``pendulum.pendulum_estimate``). The faces read the one type; a kind's adapter builds it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Generic, Protocol, TypeVar

import numpy as np

from estimation.design.decay_information import PlannedRelease
from estimation.motion.equivalent import EquivalentDamping, equivalent_damping
from estimation.motion.output_error_fit import MotionFit
from estimation.motion.record_bootstrap import Bootstrap
from estimation.motion.records import Record, Setup, known_terms_of
from estimation.motion.term_search import Step, evidence_json
from estimation.motion.well_determined import Combination
from estimation.report_numbers import Coefficient, finite_or_none, finite_values
from estimation.stats.acceptance_rules import RuleSet
from estimation.stats.diagnostics import Whiteness
from estimation.stats.repeatability import RepeatAnalysis

#: The document's version: 2 since every kind's document carries every shared key.
SCHEMA_VERSION = 2


@dataclass(frozen=True)
class EffectEstimate:
    """An effect the search kept: library name, value ± σ, unit."""

    name: str
    value: float
    std: float
    unit: str

    def to_json(self) -> dict[str, Any]:
        """{name, value, std, unit}."""
        return {
            "name": self.name,
            "value": finite_or_none(self.value),
            "std": finite_or_none(self.std),
            "unit": self.unit,
        }


class KindSection(Protocol):
    """What one kind of record adds to the result: ``to_json(result)`` gives its document
    keys (a dict value is merged into the shared key of that name, as a tow's force-domain
    diagnostics into ``diagnostics``)."""

    def to_json(self, result: EstimationResult[Any]) -> dict[str, Any]: ...


S = TypeVar("S", bound=KindSection)


@dataclass(frozen=True)
class EstimationResult(Generic[S]):
    """Everything one estimate produced; ``to_json()`` is the documented document.

    ``axis``: the line or DOF the equation is of (surge, yaw, heave, roll, a pendulum's swing
    axis); ``dof``: the line as imported where it differs (a settling sphere's tow: heave);
    ``names``: the kind's name for an engine coefficient where it differs (a pendulum's
    inertia is its added mass): the document names the engine's coefficients through it
    wherever it lists them (the bootstrap, the correlation, the next release, the given, the
    unidentified and the rivals' coefficients). ``possibly_biased``: the residual holds
    structure no kept term explains, so the coefficients may be biased by it (a decay's
    misfit verdict, a tow set's ``unexplained``); None where nothing judged it (a seed
    method's result)."""

    axis: str
    method: str
    runs: tuple[str, ...]
    coefficients: dict[str, Coefficient]
    coefficients_before: dict[str, Coefficient]
    units: dict[str, str]
    effects: tuple[EffectEstimate, ...]
    rmse_before: float
    rmse_after: float
    whiteness_before: Whiteness
    whiteness_after: Whiteness
    rules: RuleSet
    section: S
    rmse_per_run_before: dict[str, float] = field(default_factory=dict)
    rmse_per_run_after: dict[str, float] = field(default_factory=dict)
    #: Terms given, not fitted (a declared stiffness or inertia), σ 0.
    known: dict[str, Coefficient] = field(default_factory=dict)
    #: How a report names a coefficient whose key alone would mislead a reader (a decay given
    #: the body's own inertia: ``inertia`` is the added part, "added inertia (body's own
    #: 115.743 given)" in the coefficient's unit); the key stays the document's name.
    labels: dict[str, str] = field(default_factory=dict)
    not_identified: tuple[str, ...] = ()
    #: Groups of terms the records cannot tell apart (a kept term first).
    ambiguous: tuple[tuple[str, ...], ...] = ()
    #: Per rival of a kept term: the final model with the rival in its place (its
    #: coefficients, and its BIC minus the final's).
    alternatives: dict[str, tuple[dict[str, Coefficient], float]] = field(default_factory=dict)
    #: The position noise floor the final residual implies (m or rad; None: not formed).
    noise: float | None = None
    possibly_biased: bool | None = None
    natural_period_s: float | None = None
    steps: tuple[Step, ...] = ()
    #: Leave-one-record-out RMSE of the base and final models (None: fewer than 3 records).
    cv_before: float | None = None
    cv_after: float | None = None
    warnings: tuple[str, ...] = ()
    advice: tuple[str, ...] = ()
    #: Combinations the data determine well (``motion.well_determined``).
    well_determined: tuple[Combination, ...] = ()
    #: B_e over the swings the records cover (``motion.equivalent``).
    equivalent: tuple[EquivalentDamping, ...] = ()
    #: The record-level bootstrap (three records or more).
    bootstrap: Bootstrap | None = None
    #: The runs' repeats and Chauvenet outliers (``stats.repeatability``).
    repeats: RepeatAnalysis | None = None
    #: Each coefficient's σ predicted after one more release (``design.decay_information``).
    next_release: tuple[PlannedRelease, ...] = ()
    names: dict[str, str] = field(default_factory=dict)
    dof: str | None = None
    fit_before: MotionFit | None = field(default=None, repr=False, compare=False)
    fit_after: MotionFit | None = field(default=None, repr=False, compare=False)
    #: What the fit was given: the equation's setup and the records as windowed (a refit
    #: with a declared input moved, ``uncertainty.record_refits``).
    setup: Setup | None = field(default=None, repr=False, compare=False)
    records: tuple[Record, ...] = field(default=(), repr=False, compare=False)

    @property
    def subject(self) -> str:
        """What the fit is of, in the user's words: the imported line, else the axis."""
        return self.dof or self.axis

    @property
    def effect_names(self) -> tuple[str, ...]:
        """The kept effects' library names, in the order the search added them."""
        return tuple(e.name for e in self.effects)

    def reported(self, name: str) -> str:
        """The kind's name for the engine's coefficient ``name``."""
        return self.names.get(name, name)

    def equivalent_damping(self, amplitude: float) -> EquivalentDamping | None:
        """B_e at ``amplitude`` (m or rad) at the natural frequency (``motion.equivalent``),
        with the first record's known terms and weights; None without a fit, its records or
        a natural period."""
        if self.fit_after is None or self.setup is None or not self.records:
            return None
        if self.natural_period_s is None:
            return None
        first = self.records[0]
        omega = 2 * np.pi / self.natural_period_s
        known = known_terms_of(first, self.setup)
        return equivalent_damping(
            self.fit_after, known, self.setup.dof, amplitude, omega, first.weights
        )

    def to_json(self) -> dict[str, Any]:
        """The document: every kind's shared keys, then its section's."""
        name: Callable[[str], str] = self.reported
        fit = self.fit_after
        doc: dict[str, Any] = {
            "schema_version": SCHEMA_VERSION,
            "method": self.method,
            "runs": list(self.runs),
            "coefficients": {k: c.to_json() for k, c in self.coefficients.items()},
            "coefficients_before": {k: c.to_json() for k, c in self.coefficients_before.items()},
            "known": {name(k): c.to_json() for k, c in self.known.items()},
            "labels": dict(self.labels),
            "units": dict(self.units),
            "effects": [e.to_json() for e in self.effects],
            "not_identified": [name(n) for n in self.not_identified],
            "ambiguous": [list(g) for g in self.ambiguous],
            "alternatives": {
                rival: {
                    "coefficients": {name(k): c.to_json() for k, c in coeffs.items()},
                    "delta_bic": finite_or_none(delta),
                }
                for rival, (coeffs, delta) in self.alternatives.items()
            },
            "well_determined": [c.to_json() for c in self.well_determined],
            "equivalent_linear_damping": [e.to_json() for e in self.equivalent],
            "natural_period_s": finite_or_none(self.natural_period_s),
            "rmse_before": finite_or_none(self.rmse_before),
            "rmse_after": finite_or_none(self.rmse_after),
            "rmse_per_run_before": finite_values(self.rmse_per_run_before),
            "rmse_per_run_after": finite_values(self.rmse_per_run_after),
            "noise": finite_or_none(self.noise),
            "coefficients_possibly_biased": self.possibly_biased,
            "correlation": {
                "names": [] if fit is None else [name(n) for n in fit.names],
                "matrix": []
                if fit is None
                else [[finite_or_none(x) for x in row] for row in np.asarray(fit.correlation)],
            },
            "diagnostics": {
                "ljung_box_before": self.whiteness_before.to_json(),
                "ljung_box_after": self.whiteness_after.to_json(),
            },
            "warnings": list(self.warnings),
            "advice": list(self.advice),
            "evidence": evidence_json(
                self.fit_before, self.fit_after, self.cv_before, self.cv_after, self.steps
            ),
            "acceptance_rules": self.rules.to_json(),
            "bootstrap": self.bootstrap.to_json(name) if self.bootstrap else None,
            "repeats": self.repeats.to_json() if self.repeats else None,
            "next_release": [p.to_json(name) for p in self.next_release],
        }
        for key, value in self.section.to_json(self).items():
            shared = doc.get(key)
            doc[key] = (
                shared | value if isinstance(shared, dict) and isinstance(value, dict) else value
            )
        return doc
