"""The uncertainty budget of every fitted coefficient, in the form of ITTC 7.5-02-01-01 and
the GUM (JCGM 100:2008).

Per coefficient θ, each source i has a standard uncertainty u_i (in its own unit), a
sensitivity c_i = ∂θ/∂x_i and a contribution c_i·u_i. Combined standard uncertainty
u_c = √Σ(c_i u_i)² (sources independent), effective degrees of freedom by
Welch–Satterthwaite ν_eff = u_c⁴ / Σ (c_i u_i)⁴/ν_i, coverage factor k = t_0.975(ν_eff)
and expanded uncertainty U = k·u_c at 95 %, reported to 2 significant digits (rounded up,
GUM 7.2.6, so the stated U is never smaller than computed) with the value rounded to the
same decimal place.

Type A (evaluated from the data): the fit's white σ (σ̂²(JᵀJ)⁻¹: the noise of the samples;
not the estimate's σ with the residual's within-run correlation, ``estimation.stats.serial``:
a structured residual here is mostly what the declared sources below do to the runs, and
counting it in the fit's σ too counts them twice — on the 12 kg chain of
tests/estimation/test_uncertainty_chain.py U of the inertia became 0.22 kg against 0.13 kg
from a Monte Carlo of the whole chain), the run-level bootstrap, the
repeatability of repeat campaigns (``estimation.uncertainty.repeats``). All three estimate
the same random error of θ, so only the largest enters u_c (the others are listed, marked
"not combined"): adding them would count it two or three times; taking the largest keeps
a σ never smaller than the data support. The release-timing refit and the thrust
calibration draws (``estimation.axis.drive_uncertainty``) are separate random sources and
enter as they are.

Type B (declared tolerances, ``estimation.uncertainty.sources``): the sensitivity is a
central finite difference of a re-fit, c = (θ(x + u) − θ(x − u)) / 2u, with the fit's
own model and effects. Chosen over a Monte Carlo through the fit because it costs two
re-fits per source (a Monte Carlo needs hundreds for a stable spread), is deterministic,
and gives the per-source sensitivity the ITTC table asks for; the Monte Carlo is used in
the tests to check it (tests/estimation/test_uncertainty_chain.py). Declared tolerances
are taken as exactly known: ν_i = ∞.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy import stats

from estimation.axis.model import prepare
from estimation.axis.output_error import FitResult, fit_output_error
from estimation.axis.result import EstimationResult
from estimation.data.runs import RunData
from estimation.motion.terms import LIBRARY
from estimation.numbers import finite_or_none
from estimation.uncertainty.repeats import RepeatAnalysis, repeat_campaign_std
from estimation.uncertainty.sources import (
    SOURCES,
    Chain,
    check_tolerances,
    perturbed,
    reaches,
    standard_uncertainty,
    weight_groups,
)

COVERAGE = 0.95
TYPE_B_NOT_DECLARED = (
    "Type B not declared: the rig file has no [tolerances] section, so U covers the Type A "
    "sources only (add [tolerances] to the rig file, README 'Declaring tolerances')"
)


@dataclass(frozen=True)
class BudgetRow:
    """One source of one coefficient: u in the source's unit, c = ∂θ/∂x, contribution c·u."""

    source: str
    kind: str  # "A" or "B"
    unit: str
    standard_uncertainty: float
    sensitivity: float
    contribution: float  # |c·u|, coefficient unit
    dof: float  # ν_i (inf: taken as exact)
    combined: bool = True
    note: str = ""
    share: float = 0.0  # (c·u)² / u_c², of the combined sources

    def to_json(self) -> dict[str, Any]:
        return {
            "source": self.source,
            "type": self.kind,
            "unit": self.unit,
            "standard_uncertainty": finite_or_none(self.standard_uncertainty),
            "sensitivity": finite_or_none(self.sensitivity),
            "contribution": finite_or_none(self.contribution),
            "dof": None if math.isinf(self.dof) else finite_or_none(self.dof),
            "combined": self.combined,
            "share": finite_or_none(self.share),
            "note": self.note,
        }


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
            "reported": f"{self.reported_value} ± {self.reported_expanded}",
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

    def to_json(self) -> dict[str, Any]:
        return {
            "method": "GUM / ITTC 7.5-02-01-01; Type B sensitivities by central finite-"
            "difference re-fit",
            "coverage": COVERAGE,
            "type_b_declared": self.type_b_declared,
            "tolerances": dict(self.tolerances),
            "notes": list(self.notes),
            "coefficients": {k: b.to_json() for k, b in self.coefficients.items()},
        }


def effective_dof(contributions: Sequence[float], dofs: Sequence[float]) -> float:
    """Welch–Satterthwaite: ν_eff = u_c⁴ / Σ (c_i u_i)⁴/ν_i (ν_i = inf drops out)."""
    u_c2 = float(np.sum(np.square(contributions)))
    denom = sum(c**4 / v for c, v in zip(contributions, dofs, strict=True) if math.isfinite(v))
    if denom <= 0 or u_c2 <= 0:
        return math.inf
    return u_c2**2 / denom


def coverage_factor(dof: float, coverage: float = COVERAGE) -> float:
    """k = t_{(1+p)/2}(ν) of Student's t (1.960 for ν = ∞)."""
    q = 0.5 + coverage / 2
    return float(stats.norm.ppf(q) if math.isinf(dof) else stats.t.ppf(q, dof))


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
    runs: Sequence[RunData], fit: FitResult, chain: Chain, source: str, u: float
) -> list[np.ndarray]:
    """∂θ/∂x per independent input of ``source`` (one per hung weight for weights)."""
    groups: list[list[int]] = weight_groups(runs) if SOURCES[source].per_weight else [[]]
    out = []
    for only in groups:
        values = []
        for delta in (u, -u):
            moved = [prepare(r) for r in perturbed(runs, chain, source, delta, only)]
            values.append(fit_output_error(moved, fit.effects, start=fit.values).values)
        out.append((values[0] - values[1]) / (2 * u))
    return out


def _type_b_rows(
    runs: Sequence[RunData],
    fit: FitResult,
    chain: Chain,
    tolerances: Mapping[str, float],
    notes: list[str],
) -> dict[str, list[BudgetRow]]:
    """Type B rows per coefficient; a declared input that reaches no run is named in
    ``notes`` instead (a thrust calibration in a weight-driven estimate, the water
    temperature, which enters only ρ and ν)."""
    axis = runs[0].axis
    rows: dict[str, list[BudgetRow]] = {n: [] for n in fit.names}
    idle = []
    for name, half_width in tolerances.items():
        source = SOURCES[name]
        if axis not in source.axes or half_width <= 0:
            continue
        u = standard_uncertainty(half_width)
        if not reaches(runs, chain, name, u):
            idle.append(f"{name} (±{half_width:g} {source.unit}: {source.meaning})")
            continue
        grads = _type_b_sensitivity(runs, fit, chain, name, u)
        for i, coef in enumerate(fit.names):
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


def coefficient_unit(name: str, axis: str) -> str:
    """The SI unit of a fitted coefficient or effect on ``axis``."""
    if name == "inertia":
        return "kg" if axis == "surge" else "kg·m²"
    return LIBRARY[name].unit(axis) if name in LIBRARY else ""


def _type_a_rows(
    result: EstimationResult, fit: FitResult, repeat_std: Mapping[str, tuple[float, int]]
) -> dict[str, list[BudgetRow]]:
    rows: dict[str, list[BudgetRow]] = {}
    dof_fit = max(fit.n_samples - fit.n_params, 1)
    boot = result.bootstrap
    drive = result.uncertainty
    for i, name in enumerate(fit.names):
        unit = coefficient_unit(name, result.axis)
        noise = fit.std if fit.std_white is None else fit.std_white
        random = [BudgetRow("fit (σ̂²(JᵀJ)⁻¹)", "A", unit, float(noise[i]), 1.0, 0.0, dof_fit)]
        if boot is not None and boot.used > 1 and math.isfinite(boot.std.get(name, math.nan)):
            random.append(
                BudgetRow(
                    f"bootstrap over runs ({boot.used} resamples)",
                    "A",
                    unit,
                    boot.std[name],
                    1.0,
                    0.0,
                    max(len(result.runs) - 1, 1),
                )
            )
        if name in repeat_std:
            s, n = repeat_std[name]
            random.append(
                BudgetRow(f"repeatability ({n} repeat campaigns, s/√N)", "A", unit, s, 1, 0, n - 1)
            )
        finite = [r for r in random if math.isfinite(r.standard_uncertainty)]
        largest = max(finite, key=lambda r: r.standard_uncertainty) if finite else None
        out = []
        for r in random:
            used = r is largest
            note = (
                "the random error, counted once"
                if used
                else "overlaps " + (largest.source if largest else "—") + ": not combined"
            )
            out.append(
                BudgetRow(
                    r.source,
                    "A",
                    r.unit,
                    r.standard_uncertainty,
                    1.0,
                    abs(r.standard_uncertainty) if used else 0.0,
                    r.dof,
                    combined=used,
                    note=note,
                )
            )
        if drive is not None and drive.std_release_timing.get(name, 0.0) > 0:
            u = drive.std_release_timing[name]
            out.append(
                BudgetRow(
                    "release timing (refit with each release moved by its σ_t)",
                    "A",
                    unit,
                    u,
                    1.0,
                    u,
                    math.inf,
                    note="σ_t from the release write's bracket and the clock",
                )
            )
        if drive is not None and drive.draws > 1 and drive.std_calibration.get(name, 0.0) > 0:
            u = drive.std_calibration[name]
            out.append(
                BudgetRow(
                    f"thrust calibration ({drive.draws} curve draws)",
                    "A",
                    unit,
                    u,
                    1.0,
                    u,
                    drive.draws - 1,
                    note="the calibration fit's covariance",
                )
            )
        rows[name] = out
    return rows


def _finish(name: str, value: float, rows: list[BudgetRow]) -> CoefficientBudget:
    used = [r for r in rows if r.combined and math.isfinite(r.contribution)]
    u_c = float(np.sqrt(sum(r.contribution**2 for r in used)))
    dof = effective_dof([r.contribution for r in used], [r.dof for r in used])
    k = coverage_factor(dof)
    shared = tuple(
        BudgetRow(
            **{**r.__dict__, "share": (r.contribution / u_c) ** 2 if r.combined and u_c else 0}
        )
        for r in rows
    )
    expanded = k * u_c
    shown_value, shown_u = round_reported(value, expanded)
    return CoefficientBudget(name, value, shared, u_c, dof, k, expanded, shown_value, shown_u)


def as_fitted(runs: Sequence[RunData], result: EstimationResult) -> list[RunData]:
    """The runs with the release instants the estimate fitted with: a release found in the
    data was refined by the fit (``estimation.axis.release.fit_release``), and the result's
    window holds the refined instant (refining again would repeat the costliest step of an
    estimate: 95 s on the ship2d record)."""
    out = []
    for r in runs:
        w = result.windows.get(r.run_id)
        if w is not None and r.window_found is not None and w != r.window_found:
            r = replace(r, t_release=w.t_release, window_found=w)
        out.append(r)
    return out


def uncertainty_budget(
    runs: Sequence[RunData],
    result: EstimationResult,
    chain: Chain | None,
    tolerances: Mapping[str, float] | None,
    repeats: RepeatAnalysis | None = None,
) -> Budget:
    """The budget of every coefficient of ``result`` (an output-error estimate of ``runs``).

    ``chain``: the rig constants the runs' drives were computed with; ``tolerances``: the
    declared half-widths by ``SOURCES`` name (None or empty: Type B not declared, a note
    says so). ``repeats``: the repeat analysis of the runs (its repeat campaigns give the
    repeatability row)."""
    fit = result.fit_after
    if fit is None:
        raise ValueError("result: got an estimate without its fit, allowed: an output-error fit")
    declared = check_tolerances(tolerances or {})
    notes: list[str] = []
    if not declared:
        notes.append(TYPE_B_NOT_DECLARED)
    runs = as_fitted(runs, result)
    chain = chain or Chain(g=9.81)
    type_b = _type_b_rows(runs, fit, chain, declared, notes) if declared else {}
    repeat_std: dict[str, tuple[float, int]] = {}
    if repeats is not None:
        repeat_std, why = repeat_campaign_std(runs, fit, repeats)
        if why:
            notes.append(why)
    type_a = _type_a_rows(result, fit, repeat_std)
    budgets = {
        name: _finish(name, fit.value(name), type_a[name] + type_b.get(name, []))
        for name in fit.names
    }
    return Budget(budgets, bool(declared), tuple(notes), declared)
