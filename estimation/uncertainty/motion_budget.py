"""The uncertainty budget of a single-DOF record's estimate (a free decay), in the same GUM /
ITTC 7.5-02-01-01 form as a tow's (``estimation.uncertainty.budget``): rows, u_c, ν_eff by
Welch–Satterthwaite, k = t_0.975(ν_eff), U = k·u_c, reported to two digits rounded up.

**Type A**: the fit's σ (its serial-correlation σ, never below the white one), with
ν = n_eff − p degrees of freedom, n_eff the residual's effective sample size
(``stats.misfit``): a correlated residual holds fewer independent samples than it has
points, and the t-factor widens with it (KVLCC2's roll decays: n 1335, n_eff 74).
With repeat records (``motion.decay_repeats``: every condition released N ≥ 2 times) a
second Type A row, the **repeatability**, as a tow's (``uncertainty.repeats``): campaign k
takes the k-th record of every condition and is refitted on its own; u = s/√N, ν = N − 1.
The fit's σ and the repeatability estimate the same random error: only the larger enters
u_c, the other is listed "overlaps …: not combined" (docs/uncertainty.md).
**Type B**: the inputs the estimate was given as known — the linear ``stiffness`` (ρ·g·A_w,
Δ·g·GM) and the ``known_inertia`` — with a declared half-width a (rectangular, u = a/√3);
the sensitivity c = ∂θ/∂x is a central difference of two re-fits with the final model's
terms, ν = ∞. A free decay scales every coefficient alike, so a stiffness known to 1 % makes
every identified coefficient uncertain by about 1 % whatever the record.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from estimation.errors import EstimationFailed
from estimation.kind_advice import advice_for
from estimation.motion.equivalent import equivalent_damping
from estimation.motion.estimation_result import EstimationResult
from estimation.motion.output_error_fit import MotionFit, fit_motion, parameters_of
from estimation.motion.records import Setup, known_terms_of
from estimation.motion.term_search import TRIAL_NFEV
from estimation.motion.terms import DOFS
from estimation.motion.well_determined import decay_combinations, inertia_and_stiffness
from estimation.stats.misfit import effective_sample_size
from estimation.stats.repeatability import campaign_repeatability
from estimation.uncertainty.budget import Budget, coefficient_budget
from estimation.uncertainty.rows import BudgetRow, counted_once, repeatability_row

#: The inputs of a decay a tolerance can be declared for: (meaning, unit on a
#: translational DOF, on a rotational one).
DECLARABLE: dict[str, tuple[str, str, str]] = {
    "stiffness": ("the given linear restoring stiffness", "N/m", "N·m/rad"),
    "known_inertia": ("the given mass or inertia of the body", "kg", "kg·m²"),
}
FIT_ROW = "fit (σ; ν = n_eff − p)"
NOT_DECLARED = (
    "Type B not declared: the stiffness and known inertia are taken as exact, so U covers the "
    f"fit alone ({advice_for('decay').declare_tolerances})"
)


def _moved(setup: Setup, source: str, delta: float) -> Setup | None:
    """``setup`` with the declared input ``source`` moved by ``delta`` (None: not given)."""
    if source == "stiffness":
        known = dict(setup.known_terms)
        if "restoring_spring" not in known:
            return None
        known["restoring_spring"] += delta
        return replace(setup, known_terms=known)
    return replace(setup, known_inertia=setup.known_inertia + delta)


def motion_budget(
    result: EstimationResult[Any],
    tolerances: Mapping[str, float] | None = None,
    units: Mapping[str, str] | None = None,
) -> Budget:
    """The budget of every identified coefficient of ``result`` (module doc); ``tolerances``:
    declared half-widths by ``DECLARABLE`` name; ``units``: a coefficient's unit where the
    result's own is not the one reported (a pendulum's vehicle terms). ``ValueError``
    naming the field for an unknown name or a negative half-width."""
    fit, setup = result.fit_after, result.setup
    if fit is None or setup is None:
        raise ValueError("result: got an estimate without its fit, allowed: a fitted decay")
    declared = {}
    for name, half_width in (tolerances or {}).items():
        if name not in DECLARABLE:
            raise ValueError(f"tolerances.{name}: unknown, allowed: {', '.join(DECLARABLE)}")
        if not (math.isfinite(half_width) and half_width >= 0):
            raise ValueError(f"tolerances.{name}: got {half_width!r}, allowed: a finite ≥ 0")
        if half_width > 0:
            declared[name] = float(half_width)
    n_eff = effective_sample_size(fit.residuals)
    dof_fit = max(n_eff - fit.n_params, 1.0)
    units = {n: c.unit for n, c in result.coefficients.items()} | dict(units or {})
    rows: dict[str, list[BudgetRow]] = {
        n: [
            BudgetRow(
                FIT_ROW,
                "A",
                units.get(n, ""),
                float(fit.std[i]) if math.isfinite(float(fit.std[i])) else math.nan,
                1.0,
                float(fit.std[i]) if math.isfinite(float(fit.std[i])) else math.nan,
                dof_fit,
                note=f"n = {fit.n_samples}, n_eff = {n_eff:.0f}, p = {fit.n_params}"
                if math.isfinite(float(fit.std[i]))
                else "not identified by these records: no σ, so no U",
            )
        ]
        for i, n in enumerate(fit.names)
    }
    notes = [] if declared else [NOT_DECLARED]
    repeat_std, why = _repeatability(result, fit, setup)
    if why:
        notes.append(why)
    for i, n in enumerate(fit.names):
        if n in repeat_std and math.isfinite(float(fit.std[i])):
            rows[n] = counted_once(
                [rows[n][0], repeatability_row(units.get(n, ""), *repeat_std[n])]
            )
    combination_rows: dict[str, list[BudgetRow]] = {
        c.name: [_fit_row(c.unit, c.std, dof_fit, fit.n_samples, n_eff, fit.n_params)]
        for c in result.well_determined
    }
    moved_combinations: list[dict[str, float]] = []
    rotational = DOFS[setup.dof]
    for source, half_width in declared.items():
        meaning, unit_t, unit_r = DECLARABLE[source]
        unit = unit_r if rotational else unit_t
        u = half_width / math.sqrt(3.0)
        refits = []
        for delta in (u, -u):
            moved = _moved(setup, source, delta)
            if moved is None:
                break
            try:
                refit = fit_motion(
                    result.records,
                    moved,
                    fit.effects,
                    start=parameters_of(fit),
                    max_nfev=TRIAL_NFEV,
                )
            except EstimationFailed:
                break
            refits.append(refit.values)
            moved_combinations.append(_combinations_on(moved, result, refit))
        if len(refits) != 2:
            notes.append(f"{source}: declared, but not an input of this estimate (not given)")
            moved_combinations.clear()
            continue
        for c in result.well_determined:  # a decay scales M, B and k alike: T₀ and ζ stay
            up, down = (m.get(c.name, math.nan) for m in moved_combinations)
            c_slope = (up - down) / (2 * u)
            combination_rows[c.name].append(
                BudgetRow(
                    f"{source} (±{half_width:g} {unit}, rectangular)",
                    "B",
                    unit,
                    u,
                    c_slope,
                    abs(c_slope * u),
                    math.inf,
                    note=meaning,
                )
            )
        moved_combinations.clear()
        slope = (np.asarray(refits[0]) - np.asarray(refits[1])) / (2 * u)
        for i, n in enumerate(fit.names):
            rows[n].append(
                BudgetRow(
                    f"{source} (±{half_width:g} {unit}, rectangular)",
                    "B",
                    unit,
                    u,
                    float(slope[i]),
                    abs(float(slope[i]) * u),
                    math.inf,
                    note=meaning,
                )
            )
    budgets = {n: coefficient_budget(n, fit.value(n), rows[n]) for n in fit.names}
    combinations = {
        c.name: coefficient_budget(c.name, c.value, combination_rows[c.name])
        for c in result.well_determined
    }
    return Budget(budgets, bool(declared), tuple(notes), declared, combinations)


def _fit_row(
    unit: str, std: float | None, dof_fit: float, n: int, n_eff: float, p: int
) -> BudgetRow:
    """The Type A row of a combination: its delta-method σ (``motion.well_determined``)
    with the fit's ν = n_eff − p."""
    known = std is not None and math.isfinite(std)
    sigma = float(std) if known and std is not None else math.nan
    return BudgetRow(
        FIT_ROW,
        "A",
        unit,
        sigma,
        1.0,
        sigma,
        dof_fit,
        note=f"n = {n}, n_eff = {n_eff:.0f}, p = {p}"
        if known
        else "not identified by these records: no σ, so no U",
    )


def _combinations_on(
    setup: Setup, result: EstimationResult[Any], fit: MotionFit
) -> dict[str, float]:
    """The result's well-determined combinations recomputed on ``fit`` with ``setup`` (a
    re-fit with a declared input moved), at the same amplitudes, by name."""
    first = result.records[0]
    total, k = inertia_and_stiffness(setup, first, fit)
    if not (total > 0 and k > 0):
        return {}
    omega = float(np.sqrt(k / total))
    known = known_terms_of(first, setup)
    equivalent = [
        equivalent_damping(fit, known, setup.dof, e.amplitude, omega, first.weights)
        for e in result.equivalent
    ]
    return {c.name: c.value for c in decay_combinations(setup, first, fit, equivalent)}


def _repeatability(
    result: EstimationResult[Any], fit: MotionFit, setup: Setup
) -> tuple[dict[str, tuple[float, int]], str]:
    """{name: (s/√N, N)} from N repeat campaigns of ``result``'s records (module doc), and a
    note when repeats exist but cannot be evaluated ({} and "" without repeats)."""
    repeats = result.repeats
    if repeats is None or not repeats.repeated:
        return {}, ""
    index = {r.run_id: i for i, r in enumerate(result.records)}
    groups = [[index[r] for r in c.run_ids if r in index] for c in repeats.conditions]

    def refit(members: list[int]) -> np.ndarray:
        return fit_motion(
            [result.records[i] for i in members],
            setup,
            fit.effects,
            start=parameters_of(fit, members),
            max_nfev=TRIAL_NFEV,
        ).values

    try:
        spread, n = campaign_repeatability(groups, fit.names, refit)
    except EstimationFailed as err:
        return {}, f"repeatability not evaluated: a repeat campaign did not fit ({err.why})"
    if n < 2:
        return {}, "repeatability not evaluated: some conditions were released only once"
    return spread, ""
