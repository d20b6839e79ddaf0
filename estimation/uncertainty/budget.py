"""The uncertainty budget of every fitted coefficient, in the form of ITTC 7.5-02-01-01 and
the GUM (JCGM 100:2008).

Per coefficient θ, each source i has a standard uncertainty u_i (in its own unit), a
sensitivity c_i = ∂θ/∂x_i and a contribution c_i·u_i. Combined standard uncertainty
u_c = √Σ(c_i u_i)² (sources independent), effective degrees of freedom by
Welch–Satterthwaite ν_eff = u_c⁴ / Σ (c_i u_i)⁴/ν_i, coverage factor k = t_0.975(ν_eff)
and expanded uncertainty U = k·u_c at 95 %, reported to 2 significant digits (rounded up,
GUM 7.2.6, so the stated U is never smaller than computed) with the value rounded to the
same decimal place.

Type A (evaluated from the data, ``estimation.uncertainty.type_a``): the largest of the
fit's white σ, the encoder quantization's σ, the run-level bootstrap and the repeatability
of repeat campaigns (they estimate the same random error: counted once), and the
release-timing refit and thrust calibration draws (separate random sources).

Type B (declared tolerances, ``estimation.uncertainty.sources``): the sensitivity is a
central finite difference of a re-fit, c = (θ(x + u) − θ(x − u)) / 2u, with the fit's
own model and effects. Chosen over a Monte Carlo through the fit because it costs two
re-fits per source (a Monte Carlo needs hundreds for a stable spread), is deterministic,
and gives the per-source sensitivity the ITTC table asks for; the Monte Carlo is used in
the tests to check it (tests/estimation/uncertainty/test_uncertainty_chain.py). Declared tolerances
are taken as exactly known: ν_i = ∞.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy import special

from estimation.axis.output_error import fit_output_error
from estimation.axis.prepared_run import prepare
from estimation.axis.tow_estimate import combination_conditions, well_determined
from estimation.axis.tow_section import TowResult
from estimation.data.run_arrays import RunData
from estimation.kind_advice import advice_for
from estimation.motion.output_error_fit import MotionFit
from estimation.report_numbers import finite_or_none
from estimation.uncertainty.repeats import RepeatAnalysis, repeat_campaign_std
from estimation.uncertainty.rows import BudgetRow
from estimation.uncertainty.sources import (
    SOURCES,
    Chain,
    check_tolerances,
    perturbed,
    reaches,
    standard_uncertainty,
    weight_groups,
)
from estimation.uncertainty.type_a import combination_rows, type_a_rows

__all__ = ["Budget", "BudgetRow", "CoefficientBudget", "uncertainty_budget"]

COVERAGE = 0.95
TYPE_B_NOT_DECLARED = (
    "Type B not declared: the rig file has no [tolerances] section, so U covers the Type A "
    f"sources only ({advice_for('tow').declare_tolerances})"
)
#: The same for runs that came without a rig file (imported data): no section to add to.
TYPE_B_NO_RIG_FILE = (
    "Type B not declared: these runs came without a rig file, so the drive and the rig's "
    "constants are taken as exact and U covers the Type A sources only "
    f"({advice_for('import').declare_tolerances})"
)


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


def _type_b_sensitivity(
    runs: Sequence[RunData],
    result: TowResult,
    fit: MotionFit,
    conditions: tuple[Mapping[str, float], Sequence[float]],
    chain: Chain,
    source: str,
    u: float,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """∂θ/∂x per independent input of ``source`` (one per hung weight for weights), and
    the same for the result's well-determined combinations, each recomputed on the re-fit
    at the conditions the result gives it at (the nominal drives and reached speeds: a
    terminal speed is a function of the coefficients at a stated drive)."""
    groups: list[list[int]] = weight_groups(runs) if SOURCES[source].per_weight else [[]]
    named = [c.name for c in result.well_determined]
    out = []
    for only in groups:
        values, combined = [], []
        for delta in (u, -u):
            moved = [prepare(r) for r in perturbed(runs, chain, source, delta, only)]
            refit = fit_output_error(moved, fit.effects, start=fit.values, quantization_sigma=False)
            values.append(refit.values)
            again = {c.name: c.value for c in well_determined(refit, *conditions, runs[0].axis)}
            combined.append(np.array([again.get(n, math.nan) for n in named]))
        out.append(((values[0] - values[1]) / (2 * u), (combined[0] - combined[1]) / (2 * u)))
    return out


def _type_b_rows(
    runs: Sequence[RunData],
    result: TowResult,
    fit: MotionFit,
    conditions: tuple[Mapping[str, float], Sequence[float]],
    chain: Chain,
    tolerances: Mapping[str, float],
    notes: list[str],
) -> dict[str, list[BudgetRow]]:
    """Type B rows per coefficient and per well-determined combination (by name); a
    declared input that reaches no run is named in ``notes`` instead (a thrust calibration
    in a weight-driven estimate, the water temperature, which enters only ρ and ν)."""
    axis = runs[0].axis
    names = (*fit.names, *(c.name for c in result.well_determined))
    rows: dict[str, list[BudgetRow]] = {n: [] for n in names}
    idle = []
    for name, half_width in tolerances.items():
        source = SOURCES[name]
        if axis not in source.axes or half_width <= 0:
            continue
        u = standard_uncertainty(half_width)
        if not reaches(runs, chain, name, u):
            idle.append(f"{name} (±{half_width:g} {source.unit}: {source.meaning})")
            continue
        grads = [
            np.concatenate([g, c])
            for g, c in _type_b_sensitivity(runs, result, fit, conditions, chain, name, u)
        ]
        for i, coef in enumerate(names):
            parts = np.array([g[i] for g in grads])
            contribution = float(np.sqrt(np.sum((parts * u) ** 2)))
            note = source.meaning
            if source.per_weight and len(grads) > 1:
                note += f"; {len(grads)} weights, independent, c is their root-sum-square"
            rows[coef].append(
                BudgetRow(
                    f"{name} (±{half_width:g} {source.unit}, rectangular)",
                    "B",
                    source.unit,
                    u,
                    contribution / u if u > 0 else 0.0,
                    contribution,
                    math.inf,
                    note=note,
                )
            )
    if idle:
        notes.append("declared, but reaching no run of this estimate: " + "; ".join(idle))
    return rows


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


def as_fitted(runs: Sequence[RunData], result: TowResult) -> list[RunData]:
    """The runs with the release instants the estimate fitted with: a release found in the
    data was refined by the fit (``estimation.axis.release.fit_release``), and the result's
    window holds the refined instant (refining again would repeat the costliest step of an
    estimate: 95 s on the ship2d record)."""
    out = []
    for r in runs:
        w = result.section.windows.get(r.run_id)
        if w is not None and r.window_found is not None and w != r.window_found:
            r = replace(r, t_release=w.t_release, window_found=w)
        out.append(r)
    return out


def uncertainty_budget(
    runs: Sequence[RunData],
    result: TowResult,
    chain: Chain | None,
    tolerances: Mapping[str, float] | None,
    repeats: RepeatAnalysis | None = None,
) -> Budget:
    """The budget of every coefficient of ``result`` (an output-error estimate of ``runs``).

    ``chain``: the rig constants the runs' drives were computed with (None: runs without a
    rig file, e.g. imported; the note then says so rather than ask for a section of a
    file that does not exist); ``tolerances``: the
    declared half-widths by ``SOURCES`` name (None or empty: Type B not declared, a note
    says so). ``repeats``: the repeat analysis of the runs (its repeat campaigns give the
    repeatability row)."""
    fit = result.fit_after
    if fit is None:
        raise ValueError("result: got an estimate without its fit, allowed: an output-error fit")
    declared = check_tolerances(tolerances or {})
    notes: list[str] = []
    if not declared:  # advice only the user can act on: a rig file exists, or it does not
        notes.append(TYPE_B_NOT_DECLARED if chain is not None else TYPE_B_NO_RIG_FILE)
    runs = as_fitted(runs, result)
    imported = chain is None
    chain = chain or Chain(g=9.81)
    # the drives and reached speeds the combinations are stated at: one for every re-fit
    conditions = combination_conditions(fit, runs)
    type_b = _type_b_rows(runs, result, fit, conditions, chain, declared, notes) if declared else {}
    repeat_std: dict[str, tuple[float, int]] = {}
    if repeats is not None:
        kind = advice_for("import" if imported else "tow")
        repeat_std, why = repeat_campaign_std(runs, fit, repeats, kind)
        if why:
            notes.append(why)
    type_a = type_a_rows(result, fit, repeat_std)
    budgets = {
        name: coefficient_budget(name, fit.value(name), type_a[name] + type_b.get(name, []))
        for name in fit.names
    }
    fit_rows = combination_rows(result, fit, conditions, max(fit.n_samples - fit.n_params, 1))
    combinations = {
        c.name: coefficient_budget(c.name, c.value, [fit_rows[c.name], *type_b.get(c.name, [])])
        for c in result.well_determined
    }
    return Budget(budgets, bool(declared), tuple(notes), declared, combinations)
