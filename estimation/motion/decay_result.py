"""The result of a single-DOF record's estimate (``motion.decay_estimate.estimate_records``): the
coefficients with σ, what the search kept and why, the window, B_e and what the record
determines well, and its JSON document (docs/estimation.md, *Free decay*)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from estimation.design.decay_information import PlannedRelease
from estimation.motion.decay_end import FreeWindow
from estimation.motion.equivalent import EquivalentDamping, equivalent_damping
from estimation.motion.output_error_fit import MotionFit
from estimation.motion.record_bootstrap import Bootstrap
from estimation.motion.records import Record, Setup, known_terms_of
from estimation.motion.term_search import Step, evidence_json
from estimation.motion.terms import LIBRARY, units_of
from estimation.motion.well_determined import Combination
from estimation.report_numbers import Coefficient, finite_or_none, finite_values
from estimation.stats.acceptance_rules import DECAY_RULES
from estimation.stats.diagnostics import Whiteness
from estimation.stats.repeatability import RepeatAnalysis


@dataclass(frozen=True)
class DecayResult:
    """What one estimate of a DOF's equation produced; ``to_json()`` is its document."""

    dof: str
    runs: tuple[str, ...]
    coefficients: dict[str, Coefficient]
    known: dict[str, Coefficient]
    effects: tuple[str, ...]
    not_identified: tuple[str, ...]
    rmse_before: float
    rmse_after: float
    noise: float
    whiteness: Whiteness
    #: The base model's (before the search), as every result reports both.
    whiteness_before: Whiteness
    possibly_biased: bool
    natural_period_s: float | None
    warnings: tuple[str, ...]
    steps: tuple[Step, ...]
    equilibrium: dict[str, float]
    release_time_s: dict[str, float]
    #: Per record, where the fitted free motion ends and why (``envelope.free_decay_end``).
    window: dict[str, FreeWindow] = field(default_factory=dict)
    #: Groups of terms the records cannot tell apart (a kept term first) and what would.
    ambiguous: tuple[tuple[str, ...], ...] = ()
    advice: tuple[str, ...] = ()
    #: Leave-one-record-out RMSE of the base and final models (None: fewer than 3 records).
    cv_before: float | None = None
    cv_after: float | None = None
    #: Per rival of a kept term: the final model with the rival in its place (its
    #: coefficients, and its BIC minus the final's).
    alternatives: dict[str, tuple[dict[str, Coefficient], float]] = field(default_factory=dict)
    #: B_e over the swings the records cover (``motion.equivalent``).
    equivalent: tuple[EquivalentDamping, ...] = ()
    #: Combinations the data determine well (``motion.well_determined``): T₀, ζ.
    well_determined: tuple[Combination, ...] = ()
    #: The record-level bootstrap (three records or more), as a tow set's.
    bootstrap: Bootstrap | None = None
    #: The free records' repeats and Chauvenet outliers (``motion.decay_repeats``), in the
    #: shape of a tow set's.
    repeats: RepeatAnalysis | None = None
    #: Each coefficient's σ predicted after one more record released from each of a few
    #: amplitudes (``design.decay_information``; free records only).
    next_release: tuple[PlannedRelease, ...] = ()
    fit: MotionFit | None = field(default=None, repr=False, compare=False)
    #: The base model's fit (before the search).
    base: MotionFit | None = field(default=None, repr=False, compare=False)
    #: What the fit was given: the equation's setup and the records as windowed (a refit
    #: with a declared input moved, ``estimation.uncertainty.motion_budget``).
    setup: Setup | None = field(default=None, repr=False, compare=False)
    records: tuple[Record, ...] = field(default=(), repr=False, compare=False)

    def equivalent_damping(self, amplitude: float) -> EquivalentDamping | None:
        """B_e at ``amplitude`` (m or rad) at the natural frequency (``motion.equivalent``),
        with the first record's known terms and weights, as ``equivalent`` has it; None
        without a fit, its records or a period."""
        if self.fit is None or self.setup is None or not self.records:
            return None
        if self.natural_period_s is None:
            return None
        first = self.records[0]
        omega = 2 * np.pi / self.natural_period_s
        known = known_terms_of(first, self.setup)
        return equivalent_damping(self.fit, known, self.dof, amplitude, omega, first.weights)

    def to_json(self) -> dict[str, Any]:
        """The result document (docs/estimation.md, *Free decay*)."""
        return {
            "kind": "decay",
            "dof": self.dof,
            "runs": list(self.runs),
            "coefficients": {k: c.to_json() for k, c in self.coefficients.items()},
            "known": {k: c.to_json() for k, c in self.known.items()},
            "units": units_of(
                self.dof, [n for n in (*self.coefficients, *self.known) if n in LIBRARY]
            ),
            # every result's effects alike: {name, value, std, unit} (the faces read one shape)
            "effects": [{"name": e} | self.coefficients[e].to_json() for e in self.effects],
            "ambiguous": [list(p) for p in self.ambiguous],
            "alternatives": {
                rival: {
                    "coefficients": {k: c.to_json() for k, c in coeffs.items()},
                    "delta_bic": finite_or_none(delta),
                }
                for rival, (coeffs, delta) in self.alternatives.items()
            },
            "not_identified": list(self.not_identified),
            "rmse_before": finite_or_none(self.rmse_before),
            "rmse_after": finite_or_none(self.rmse_after),
            "noise": finite_or_none(self.noise),
            # every result's residual test alike: the base model's, then the final one's
            "diagnostics": {
                "ljung_box_before": self.whiteness_before.to_json(),
                "ljung_box_after": self.whiteness.to_json(),
            },
            "coefficients_possibly_biased": self.possibly_biased,
            "natural_period_s": finite_or_none(self.natural_period_s),
            "equivalent_linear_damping": [e.to_json() for e in self.equivalent],
            "well_determined": [c.to_json() for c in self.well_determined],
            "bootstrap": self.bootstrap.to_json() if self.bootstrap else None,
            "repeats": self.repeats.to_json() if self.repeats else None,
            "next_release": [p.to_json() for p in self.next_release],
            "warnings": list(self.warnings),
            "advice": list(self.advice),
            "evidence": evidence_json(
                self.base, self.fit, self.cv_before, self.cv_after, self.steps
            ),
            "acceptance_rules": DECAY_RULES.to_json(),
            "equilibrium": finite_values(self.equilibrium),
            "release_time_s": finite_values(self.release_time_s),
            "window": {
                run: {"release_time_s": self.release_time_s.get(run)} | w.to_json()
                for run, w in self.window.items()
            },
        }
