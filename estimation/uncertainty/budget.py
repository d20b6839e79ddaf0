"""The uncertainty budget of every fitted coefficient, in the form of ITTC 7.5-02-01-01 and
the GUM (JCGM 100:2008), one for every kind of record (tow, spin, free decay, pendulum).

Per coefficient θ, each source i has a standard uncertainty u_i (in its own unit), a
sensitivity c_i = ∂θ/∂x_i and a contribution c_i·u_i. Combined standard uncertainty
u_c = √Σ(c_i u_i)² (sources independent), effective degrees of freedom by
Welch–Satterthwaite ν_eff = u_c⁴ / Σ (c_i u_i)⁴/ν_i, coverage factor k = t_0.975(ν_eff)
and expanded uncertainty U = k·u_c at 95 %, reported to 2 significant digits (rounded up,
GUM 7.2.6, so the stated U is never smaller than computed) with the value rounded to the
same decimal place.

Type A (evaluated from the data, ``estimation.uncertainty.type_a``): the largest of the
fit's σ, the encoder quantization's σ, the record bootstrap and the repeatability of repeat
campaigns (they estimate the same random error: counted once), and the sources a kind has
of its own (a tow's release-timing refit and thrust calibration draws).

Type B (declared tolerances): the sensitivity is a central finite difference of a re-fit,
c = (θ(x + u) − θ(x − u)) / 2u, with the fit's own model and effects. Chosen over a Monte
Carlo through the fit because it costs two re-fits per source (a Monte Carlo needs hundreds
for a stable spread), is deterministic, and gives the per-source sensitivity the ITTC table
asks for; the Monte Carlo is used in the tests to check it
(tests/estimation/uncertainty/test_uncertainty_chain.py). Declared tolerances are taken as
exactly known: ν_i = ∞.

What differs by kind is only how its records are re-fitted with something changed — an
input moved, a repeat campaign alone — and which inputs it can declare: a ``Refits``
(``uncertainty.tow_refits`` for tows and spins, ``uncertainty.record_refits`` for decays and
pendulum swings). Everything else is this module's ``uncertainty_budget``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from estimation.blas_threads import one_blas_thread
from estimation.errors import EstimationFailed
from estimation.kind_advice import advice_for
from estimation.motion.estimation_result import EstimationResult
from estimation.motion.output_error_fit import MotionFit
from estimation.motion.well_determined import Combination
from estimation.report_numbers import finite_or_none
from estimation.stats.repeatability import RepeatAnalysis, campaign_repeatability
from estimation.uncertainty.rows import BudgetRow
from estimation.uncertainty.type_a import (
    SeedSigma,
    combination_rows,
    fit_dof,
    random_rows,
    seed_rows,
)

__all__ = [
    "Budget",
    "BudgetRow",
    "CoefficientBudget",
    "DeclaredInput",
    "Refits",
    "uncertainty_budget",
]

COVERAGE = 0.95


@dataclass(frozen=True)
class DeclaredInput:
    """One declared Type B input of a kind's records: its half-width a (rectangular,
    u = a/√3, GUM 4.3.7), unit and meaning; ``parts``: its independent parts (one per
    distinct hung weight: one weight, one error); ``moves_records``: whether it changes the
    records' own data (a drive computed from a hung mass, an encoder scale) rather than a
    constant the model is given (a decay's stiffness)."""

    name: str
    half_width: float
    unit: str
    meaning: str
    parts: int = 1
    moves_records: bool = True

    @property
    def u(self) -> float:
        """The standard uncertainty a/√3."""
        return self.half_width / math.sqrt(3.0)

    @property
    def source(self) -> str:
        """The budget row's name."""
        return f"{self.name} (±{self.half_width:g} {self.unit}, rectangular)"


class Refits(Protocol):
    """How one kind's records are re-fitted for its budget; ``kind``: its ``kind_advice``
    key; ``not_declared``: the note when it declares no Type B input."""

    kind: str
    not_declared: str

    def inputs(
        self, tolerances: Mapping[str, float]
    ) -> tuple[dict[str, float], list[DeclaredInput], list[str]]:
        """The declared half-widths, checked (``ValueError`` naming the field for an unknown
        name or a bad half-width); those that reach the records; the others, each named with
        its half-width and why."""
        ...

    def moved(
        self, declared: DeclaredInput, delta: float, part: int
    ) -> tuple[MotionFit, tuple[Combination, ...]]:
        """The fit's model re-fitted with part ``part`` of ``declared`` (one of ``inputs``'
        reaching ones) moved by ``delta``, and the combinations on it."""
        ...

    def combinations(self, fit: MotionFit) -> tuple[Combination, ...]:
        """The result's well-determined combinations on ``fit``, at the result's own
        conditions (its drives and speeds, its amplitudes)."""
        ...

    def campaign(self, run_ids: Sequence[str]) -> MotionFit:
        """The fit's model fitted to the records ``run_ids`` alone."""
        ...

    def own_rows(self, name: str, unit: str) -> list[BudgetRow]:
        """The kind's own random sources of coefficient ``name`` (a tow's release timing and
        thrust calibration draws), which enter u_c as they are."""
        ...


@dataclass(frozen=True)
class CoefficientBudget:
    """The budget of one coefficient: rows, u_c, ν_eff, k, U (95 %), and U as reported."""

    name: str
    value: float
    rows: tuple[BudgetRow, ...]
    combined_std: float
    dof: float
    k: float
    expanded: float
    reported_value: str
    reported_expanded: str

    @property
    def dominant(self) -> str:
        """The source with the largest share."""
        used = [r for r in self.rows if r.combined]
        return max(used, key=lambda r: r.contribution).source if used else ""

    def to_json(self) -> dict[str, Any]:
        return {
            "value": finite_or_none(self.value),
            "combined_standard_uncertainty": finite_or_none(self.combined_std),
            "effective_dof": None if math.isinf(self.dof) else finite_or_none(self.dof),
            "coverage_factor": finite_or_none(self.k),
            "expanded_uncertainty": finite_or_none(self.expanded),
            "coverage": COVERAGE,
            "reported": (
                f"{self.reported_value} ± {self.reported_expanded}"
                if math.isfinite(self.expanded)
                else f"{self.reported_value} (not identified: no U)"
            ),
            "dominant_source": self.dominant,
            "rows": [r.to_json() for r in self.rows],
        }


@dataclass(frozen=True)
class Budget:
    """Budgets of every fitted coefficient of one estimate, and the notes that go with it."""

    coefficients: dict[str, CoefficientBudget]
    type_b_declared: bool
    notes: tuple[str, ...] = ()
    tolerances: dict[str, float] = field(default_factory=dict)
    #: The same for the combinations the record determines well, by name (a decay's T₀, ω₀,
    #: ζ: ``motion.well_determined``); empty where the budget has none.
    combinations: dict[str, CoefficientBudget] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "method": "GUM / ITTC 7.5-02-01-01; Type B sensitivities by central finite-"
            "difference re-fit",
            "coverage": COVERAGE,
            "type_b_declared": self.type_b_declared,
            "tolerances": dict(self.tolerances),
            "notes": list(self.notes),
            "coefficients": {k: b.to_json() for k, b in self.coefficients.items()},
            "combinations": {k: b.to_json() for k, b in self.combinations.items()},
        }


def effective_dof(contributions: Sequence[float], dofs: Sequence[float]) -> float:
    """Welch–Satterthwaite: ν_eff = u_c⁴ / Σ (c_i u_i)⁴/ν_i (ν_i = inf drops out)."""
    u_c2 = float(np.sum(np.square(contributions)))
    denom = sum(c**4 / v for c, v in zip(contributions, dofs, strict=True) if math.isfinite(v))
    if denom <= 0 or u_c2 <= 0:
        return math.inf
    return u_c2**2 / denom


def coverage_factor(dof: float, coverage: float = COVERAGE) -> float:
    """k = t_{(1+p)/2}(ν) of Student's t (1.960 for ν = ∞); ``scipy.special``'s inverse
    distribution functions, which ``scipy.stats``' t.ppf and norm.ppf call (importing
    ``scipy.stats`` costs ~0.4 s of CPU)."""
    q = 0.5 + coverage / 2
    from scipy import special  # here: the service imports this module (+27 MB resident)

    return float(special.ndtri(q) if math.isinf(dof) else special.stdtrit(dof, q))


def round_reported(value: float, expanded: float, digits: int = 2) -> tuple[str, str]:
    """U to ``digits`` significant digits, rounded up (GUM 7.2.6), and the value to the
    same decimal place: (value, U) as text, e.g. (143.3, 0.85)."""
    if not (math.isfinite(expanded) and expanded > 0):
        return (f"{value:.6g}", "nan" if not math.isfinite(expanded) else "0")
    exponent = math.floor(math.log10(expanded)) - (digits - 1)
    step = 10.0**exponent
    up = math.ceil(round(expanded / step, 9)) * step
    if up >= 10.0 ** (exponent + digits):  # 99.6 → 100: two digits are now "10" of tens
        exponent += 1
        step = 10.0**exponent
    decimals = max(0, -exponent)
    return f"{round(value / step) * step:.{decimals}f}", f"{up:.{decimals}f}"


def coefficient_budget(name: str, value: float, rows: list[BudgetRow]) -> CoefficientBudget:
    """One coefficient's budget from its rows: u_c of the combined rows (NaN when one has no
    value), ν_eff, k and U = k·u_c, and U as reported."""
    used = [r for r in rows if r.combined and math.isfinite(r.contribution)]
    u_c = float(np.sqrt(sum(r.contribution**2 for r in used)))
    if any(r.combined and not math.isfinite(r.contribution) for r in rows):
        u_c = math.nan  # a source that counts has no value (the coefficient is not identified)
    dof = effective_dof([r.contribution for r in used], [r.dof for r in used])
    k = coverage_factor(dof)
    shared = tuple(
        BudgetRow(
            **{**r.__dict__, "share": (r.contribution / u_c) ** 2 if r.combined and u_c > 0 else 0}
        )
        for r in rows
    )
    expanded = k * u_c
    shown_value, shown_u = round_reported(value, expanded)
    return CoefficientBudget(name, value, shared, u_c, dof, k, expanded, shown_value, shown_u)


@one_blas_thread
def uncertainty_budget(
    result: EstimationResult[Any],
    refits: Refits,
    tolerances: Mapping[str, float] | None = None,
    repeats: RepeatAnalysis | None = None,
    units: Mapping[str, str] | None = None,
    seed: SeedSigma | None = None,
) -> Budget:
    """The budget of every fitted coefficient of ``result`` and of its well-determined
    combinations (module doc), its records re-fitted by ``refits``.

    ``tolerances``: declared half-widths by the names ``refits`` knows (None or empty: Type
    B not declared, a note says so); ``repeats``: the repeat analysis of the records (its
    repeat campaigns give the repeatability row); ``units``: a coefficient's unit where the
    result's own is not the one reported (a pendulum's vehicle terms); ``seed``: a seed
    method's own σ and ν (``type_a.SeedSigma``), its Type A instead of the fit's (its
    combinations' by the delta method through the seed's covariance, on its smallest ν), its
    Type B by ``refits`` re-fitting the seed method."""
    fit = result.fit_after
    if fit is None:
        raise ValueError("result: got an estimate without its fit, allowed: an output-error fit")
    declared, inputs, idle = refits.inputs(tolerances or {})
    notes = [] if declared else [refits.not_declared]
    if idle:
        notes.append("declared, but not an input of this estimate: " + "; ".join(idle))
    units = {n: c.unit for n, c in result.coefficients.items()} | dict(units or {})
    # The fit's white σ where declared inputs move the records: the structure they put in
    # the residual is theirs, propagated by their re-fits (type_a module doc).
    white = any(i.moves_records for i in inputs)
    repeat_std, why = _repeatability(refits, fit, repeats, set(result.runs))
    if why:
        notes.append(why)
    if seed is None:
        dof = fit_dof(fit, white)  # the effective sample size: one pass over the residual
        rows = random_rows(result, fit, units, white, dof, repeat_std, refits.own_rows)
        combined = combination_rows(result, fit, white, dof, refits.combinations)
    else:
        rows = seed_rows(seed, units, repeat_std, refits.own_rows)
        dof = (max(min(seed.dof.values()), 1.0), seed.counts)
        combined = combination_rows(result, fit, False, dof, refits.combinations)
    for declared_input in inputs:
        try:
            coefficients, combinations = _type_b_rows(result, fit, refits, declared_input)
        except EstimationFailed as err:
            notes.append(
                f"{declared_input.name}: declared, but a re-fit with it moved by ±u did not "
                f"fit ({err.why}): not in U"
            )
            continue
        for name, row in coefficients.items():
            rows[name].append(row)
        for name, row in combinations.items():
            combined[name].append(row)
    budgets = {n: coefficient_budget(n, fit.value(n), rows[n]) for n in fit.names}
    combination_budgets = {
        c.name: coefficient_budget(c.name, c.value, combined[c.name])
        for c in result.well_determined
    }
    return Budget(budgets, bool(declared), tuple(notes), declared, combination_budgets)


def _type_b_rows(
    result: EstimationResult[Any], fit: MotionFit, refits: Refits, declared: DeclaredInput
) -> tuple[dict[str, BudgetRow], dict[str, BudgetRow]]:
    """The Type B row of ``declared`` for every coefficient and every well-determined
    combination: c = (θ(x + u) − θ(x − u)) / 2u from two re-fits per independent part; with
    several parts (hung weights) c is their root-sum-square, with one it keeps its sign."""
    u = declared.u
    named = [c.name for c in result.well_determined]
    slopes: list[np.ndarray] = []
    for part in range(declared.parts):
        values, combined = [], []
        for delta in (u, -u):
            moved = refits.moved(declared, delta, part)
            values.append(moved[0].values)
            again = {c.name: c.value for c in moved[1]}
            combined.append(np.array([again.get(n, math.nan) for n in named]))
        slopes.append(
            np.concatenate(
                [(values[0] - values[1]) / (2 * u), (combined[0] - combined[1]) / (2 * u)]
            )
        )
    note = declared.meaning
    if declared.parts > 1:
        note += f"; {declared.parts} weights, independent, c is their root-sum-square"
    out = {}
    for i, name in enumerate((*fit.names, *named)):
        parts = np.array([s[i] for s in slopes])
        c = float(parts[0]) if parts.size == 1 else float(np.sqrt(np.sum(parts**2)))
        out[name] = BudgetRow(
            declared.source, "B", declared.unit, u, c, abs(c) * u, math.inf, note=note
        )
    return {n: out[n] for n in fit.names}, {n: out[n] for n in named}


def _repeatability(
    refits: Refits, fit: MotionFit, repeats: RepeatAnalysis | None, fitted: set[str]
) -> tuple[dict[str, tuple[float, int]], str]:
    """{name: (s/√N, N)} from the N repeat campaigns of ``repeats`` among the ``fitted``
    records (campaign k takes the k-th record of every condition and is fitted on its own;
    u = s/√N, ν = N − 1, ITTC 7.5-02-01-01 §2.4), and a note when it cannot be evaluated
    ({} and "" without repeats)."""
    if repeats is None:
        return {}, ""
    groups = [[i for i in c.run_ids if i in fitted] for c in repeats.conditions]
    groups = [g for g in groups if g]
    if not any(len(g) > 1 for g in groups):
        return {}, (
            "repeatability not evaluated: no condition was recorded more than once (ITTC "
            "names run-to-run scatter the largest source in practice; "
            f"{advice_for(refits.kind).repeat_runs}, ≥ 5 for Chauvenet's criterion to be "
            "able to flag an outlier)"
        )
    try:
        spread, n = campaign_repeatability(
            groups, fit.names, lambda members: refits.campaign(members).values
        )
    except EstimationFailed as err:
        return {}, f"repeatability not evaluated: a repeat campaign did not fit ({err.why})"
    if n < 2:
        return {}, "repeatability not evaluated: some conditions were recorded only once"
    return spread, ""
