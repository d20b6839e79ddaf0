"""Pendulum free-decay estimation: α (added mass) and β (linear damping) of the vehicle along
the swing axis, by the thesis's three methods and by output error, with the effect search.

    (J_t + m_z·l² + J_v + α·l²)·φ̈ = −[(m_z − ρV)·l + m_t·r]·g·sin φ − (β·l² + b)·φ̇
                                     [− γ·l³·|φ̇|·φ̇] [− τ_c·sgn φ̇]

The output error and the effect search are those of every record (``estimation.motion``):
the pendulum is a configuration of the one equation (``configuration``). One entry point,
``estimate_pendulum(runs, method, search_effects)``; the result's
``to_json()`` is documented in docs/pendulum.md.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from estimation.blas_threads import one_blas_thread
from estimation.data.run_arrays import validate_run_set
from estimation.errors import EstimationFailed
from estimation.motion.decay_estimate import estimate_records
from estimation.motion.estimation_result import EffectEstimate, EstimationResult
from estimation.motion.output_error_fit import MotionFit
from estimation.motion.terms import LIBRARY
from estimation.pendulum import PENDULUM_METHODS
from estimation.pendulum.configuration import (
    ADDED_MASS,
    BASE_TERMS,
    CANDIDATES,
    INERTIA,
    PIVOT_DOF,
    at_pivot,
    reported,
    unit,
)
from estimation.pendulum.data import PendulumRun, validate_pendulum_run
from estimation.pendulum.methods import (
    ROW_UNITS,
    UNCERTAINTY_NOTE,
    MethodEstimate,
    damped_fit,
    equation_error,
    log_decrement,
)
from estimation.pendulum.swing_extrema import Decay, Peaks, find_peaks, prepare_decay
from estimation.report_numbers import Coefficient, finite_or_none
from estimation.stats.method_bias import DISAGREES_SIGMAS, apart, method_bias, z_scores
from estimation.uncertainty.budget import Budget, coefficient_budget, uncertainty_budget
from estimation.uncertainty.record_refits import RecordRefits
from estimation.uncertainty.rows import BudgetRow

GEOMETRY_EXACT = (
    "Type B not declared: the rig file's pendulum geometry (rod, arm, buoyancy) is taken as "
    "exact, so U covers the fit alone"
)
#: The coefficients the result reports (α, β and the vehicle's candidate terms).
COEFFICIENTS = (INERTIA, *BASE_TERMS, *(c for c in CANDIDATES if not at_pivot(c)))
#: α and β, the fields every method row reports (``MethodEstimate``).
BASE_NAMES: tuple[str, ...] = (ADDED_MASS, *BASE_TERMS)


@dataclass(frozen=True)
class PendulumSection:
    """What a pendulum's result adds to the one result (``motion.estimation_result``): the
    thesis's methods side by side, each run's extrema, its geometry and its decay as
    prepared (the swing's release is its first sample)."""

    methods: tuple[MethodEstimate, ...]
    peaks: dict[str, Peaks]
    geometry: dict[str, dict[str, float]]
    decays: tuple[Decay, ...] = field(default=(), repr=False, compare=False)

    def method_estimate(self, method: str, run_id: str) -> MethodEstimate:
        """The row of ``method`` on ``run_id``."""
        for m in self.methods:
            if m.method == method and m.run_id == run_id:
                return m
        raise KeyError(f"method {method!r} on run {run_id!r} not in this result")

    def to_json(self, result: EstimationResult[Any]) -> dict[str, Any]:
        """The pendulum's keys (docs/pendulum.md): its analysis and swing axis, the methods,
        each run's peaks with its release on the run's clock (a plot's time origin), the
        geometry, and each run's fitted initial angle, rate and offset."""
        start = {d.run_id: float(d.t[0]) for d in self.decays}
        fit = result.fit_after
        nuisance = (
            {}
            if fit is None
            else {
                rid: {
                    "initial_angle": finite_or_none(a),
                    "initial_rate": finite_or_none(r),
                    "offset": finite_or_none(o),
                }
                for rid, a, r, o in zip(
                    result.runs, fit.initial[:, 0], fit.initial[:, 1], fit.equilibrium, strict=True
                )
            }
        )
        return {
            "kind": "pendulum",
            "analysis": "pendulum",  # schema 1's name of the kind, kept for its readers
            "axis": result.axis,
            "methods": [m.to_json() for m in self.methods],
            "peaks": {
                rid: p.to_json() | {"release_time_s": start.get(rid)}
                for rid, p in self.peaks.items()
            },
            "geometry": self.geometry,
            "nuisance": nuisance,
        }


#: A pendulum's result.
PendulumResult = EstimationResult[PendulumSection]


def pendulum_budget(result: PendulumResult) -> Budget:
    """The GUM budget of a pendulum's headline coefficients (``uncertainty.budget``, every
    kind's), named and in the units the result reports them: the output-error fit's, or a
    seed method's pooled over runs (``seed_budget``)."""
    if result.method != "output-error":
        return seed_budget(result)
    if result.fit_after is None:
        raise ValueError("result: got a pendulum estimate without its fit")
    names = result.fit_after.names
    refits = RecordRefits(result, "pendulum", GEOMETRY_EXACT)
    units = {n: unit(n, result.axis) for n in names}
    b = uncertainty_budget(result, refits, repeats=result.repeats, units=units)
    return replace(
        b,
        coefficients={reported(n): replace(c, name=reported(n)) for n, c in b.coefficients.items()},
    )


#: The seed headline's row for runs that disagree beyond their own σ (``_scatter``).
SCATTER_ROW = "scatter between runs beyond their σ (Birge ratio; ν = runs − 1)"


def seed_budget(result: PendulumResult) -> Budget:
    """The budget of a seed method's headline α, β: their inverse-variance mean over runs
    (``_pooled``), so each run's row is a Type A source of sensitivity w_r/Σw (u_c = 1/√Σw,
    the pooled σ) on its own ν (``methods.row_value``), and the runs' scatter beyond their σ
    (``_scatter``) as one more, combined by Welch–Satterthwaite. No
    Type B: a pendulum declares none (``GEOMETRY_EXACT``); no combinations: the seed methods
    give none."""
    rows = [m for m in result.section.methods if m.method == result.method]
    budgets = {}
    for name in BASE_NAMES:
        est = [getattr(m, name) for m in rows]
        weights = np.array([_weight(e) for e in est])
        total = float(weights.sum())
        lines = [
            BudgetRow(
                f"{result.method} on run {m.run_id[:8]} (inverse-variance weight)",
                "A",
                e.unit,
                float(e.std) if e.std is not None else math.nan,
                w / total if total > 0 else math.nan,
                w * float(e.std) / total if total > 0 and e.std is not None else math.nan,
                float(getattr(e, "dof", math.inf)),
                note=UNCERTAINTY_NOTE,
            )
            for m, e, w in zip(rows, est, weights, strict=True)
        ]
        scatter, dof = _scatter(np.array([e.value for e in est]), weights)
        if scatter > 0:
            unit = est[0].unit
            lines.append(BudgetRow(SCATTER_ROW, "A", unit, scatter, 1.0, scatter, dof))
        budgets[name] = coefficient_budget(name, result.coefficients[name].value, lines)
    return Budget(budgets, False, (GEOMETRY_EXACT,))


def _weight(estimate: Coefficient) -> float:
    """1/σ² of one run's estimate; 0 without a σ (it does not count in the mean)."""
    std = estimate.std
    return 1 / std**2 if std is not None and math.isfinite(std) and std > 0 else 0.0


def validate_pendulum_runs(runs: Sequence[PendulumRun]) -> str:
    """Validate runs for a joint fit; returns their common swing axis."""
    return validate_run_set(runs, validate_pendulum_run, "pendulum run", "one swing axis per fit")


def _coefficients(fit: MotionFit, axis: str) -> dict[str, Coefficient]:
    """α, β and the vehicle's terms the fit carries, each with its σ (NaN: not identified)
    and its unit along the swing ``axis``."""
    return {
        reported(n): Coefficient(fit.value(n), fit.sigma(n), unit(n, axis))
        for n in COEFFICIENTS
        if n in fit.names
    }


def _pooled(rows: Sequence[MethodEstimate]) -> dict[str, Coefficient]:
    """Inverse-variance mean of one method's α and β over runs, its σ 1/√Σw times the
    runs' Birge ratio where above 1 (``_scatter``)."""
    out = {}
    for name in BASE_NAMES:
        est = [getattr(m, name) for m in rows]
        w = np.array([_weight(e) for e in est])
        vals = np.array([e.value for e in est])
        if w.sum() > 0:
            mean, std = float(w @ vals / w.sum()), float(1 / np.sqrt(w.sum()))
            std = float(np.hypot(std, _scatter(vals, w)[0]))
        else:
            mean, std = float(vals.mean()), float("nan")
        out[name] = Coefficient(mean, std, est[0].unit)
    return out


def _scatter(values: np.ndarray, weights: np.ndarray) -> tuple[float, int]:
    """The runs' scatter beyond their own σ, as a standard uncertainty of their weighted
    mean, and its ν: with χ² = Σ wᵣ(θᵣ − θ̄)² over the n runs that have a σ, the Birge ratio
    R_B = √(χ²/(n − 1)); above 1 the runs disagree more than their σ allow (a drift between
    runs, a σ too small), and the mean's σ 1/√Σw is raised to R_B/√Σw (Birge 1932; the
    weighted-mean practice of CODATA and the PDG): this is the part √(R_B² − 1)/√Σw, on
    ν = n − 1. Zero for one run or runs that agree within their σ."""
    used = weights > 0
    n = int(used.sum())
    if n < 2:
        return 0.0, max(n - 1, 1)
    w, v = weights[used], values[used]
    mean = float(w @ v / w.sum())
    birge2 = float(w @ (v - mean) ** 2) / (n - 1)
    return float(np.sqrt(max(birge2 - 1.0, 0.0) / w.sum())), n - 1


def _warnings(
    methods: Sequence[MethodEstimate],
    peaks: dict[str, Peaks],
    decays: Sequence[Decay],
    final: MotionFit,
) -> list[str]:
    out = []
    # a negative γ beyond 2σ, or one beside the dry friction the output-error search kept: its
    # σ counts the residual's correlation (``methods``), which the friction it misses puts there
    friction = any(LIBRARY[e].set_valued_at_rest for e in final.effects)
    for m in methods:
        q = m.quadratic_damping
        if m.method != "equation-error" or q is None or q.std is None:
            continue
        if q.value < -2 * q.std or (friction and q.value < 0):
            out.append(
                f"equation-error γ = {q.value:.4g} ± {q.std:.2g} kg/m < 0 on run {m.run_id}: "
                f"the signature of dry friction in the pivot (least squares puts sgn φ̇ into a "
                f"too-large β, {m.linear_damping.value:.4g} N·s/m, and a negative γ)"
            )
    # every seed row against the output-error fit of its run (``stats.method_bias``)
    reference = {m.run_id: m.coefficients for m in methods if m.method == "output-error"}
    far = [
        f"{m.method} on run {m.run_id}: {'; '.join(pieces)}"
        for m in methods
        if m.method != "output-error" and (pieces := apart(m.coefficients, reference[m.run_id]))
    ]
    if far:
        out.append(
            "method rows further than "
            f"{DISAGREES_SIGMAS:g} σ from the output-error fit of the same run (each "
            "method's own model of the record, which its U does not cover): " + " | ".join(far)
        )
    for rid, p in peaks.items():
        if p.decays_linearly:
            out.append(
                f"run {rid}: the peaks decrease linearly rather than geometrically "
                f"({p.lin_rate:.3g} rad/s): the envelope of dry friction"
            )
    for d in decays:
        fit = next(m for m in methods if m.method == "damped-fit" and m.run_id == d.run_id)
        if fit.rmse > 5 * d.noise:
            out.append(
                f"run {d.run_id}: the damped sinusoid misses the record (RMSE {fit.rmse:.2g} rad,"
                f" {fit.rmse / d.noise:.0f}× the sample noise): its σ understates the error "
                f"(sin φ, dry friction or quadratic drag are outside that model)"
            )
    for name in (e for e in final.effects if LIBRARY[e].set_valued_at_rest):
        tau = final.value(name)
        for d in decays:
            k = d.geometry.restoring_stiffness()
            out.append(
                f"run {d.run_id}: pivot {name} τ_c = {tau:.3g} N·m takes "
                f"4τ_c/k = {4 * tau / k:.3g} rad off the swing per cycle and "
                f"stops the pendulum within ±{tau / k:.3g} rad of rest"
            )
    return out


@one_blas_thread
def estimate_pendulum(
    runs: Sequence[PendulumRun],
    method: str = "output-error",
    search: bool = True,
    exclude_outliers: bool = False,
) -> PendulumResult:
    """α, β of the vehicle from free-decay runs, all methods side by side, effects searched.

    ``method`` picks the headline coefficients: "output-error" (default: nonlinear model,
    joint over runs, after the effect search), or "damped-fit", "log-decrement",
    "equation-error" (pooled over runs by inverse variance). The effect search always
    runs on the output-error fit when ``search`` is true. The runs' repeats are compared as
    every decay's (``motion.decay_repeats``): a Chauvenet outlier is named in the warnings and
    kept, or with ``exclude_outliers`` left out of every method (the result's ``runs`` are
    then the others).
    """
    if method not in PENDULUM_METHODS:
        raise ValueError(f"method: got {method!r}, allowed: {', '.join(PENDULUM_METHODS)}")
    axis = validate_pendulum_runs(runs)
    decays = [prepare_decay(r) for r in runs]
    # each run's extrema first: a run without swings is refused naming it, before any fit
    found = {d.run_id: find_peaks(d) for d in decays}
    # the one engine of every single-DOF record: window, repeats, search, rules, flags, B_e, U
    motion = estimate_records(
        [d.record() for d in decays],
        PIVOT_DOF,
        restoring_known=True,
        candidates=CANDIDATES if search else (),
        exclude_outliers=exclude_outliers,
        subject=f"{axis} swing",
        names={INERTIA: reported(INERTIA)},
    )
    if motion.fit_before is None or motion.fit_after is None:
        raise EstimationFailed(f"the {axis} swing", "the one engine returned no model")
    decays = [d for d in decays if d.run_id in motion.runs]  # a left-out repeat: no method
    peaks: dict[str, Peaks] = {d.run_id: found[d.run_id] for d in decays}
    rows: list[MethodEstimate] = []
    for d in decays:
        p = peaks[d.run_id]
        rows += [
            damped_fit(d, p),
            log_decrement(d, p),
            equation_error(d, p),
            equation_error(d, p, quadratic=False),
        ]
    base, final = motion.fit_before, motion.fit_after
    advice = list(motion.advice)
    ids = tuple(d.run_id for d in decays)
    rows = _against_output_error([*rows, *_output_error_rows(decays, final)])
    warnings = [*_warnings(rows, peaks, decays, final), *motion.warnings]
    if final.effects and len({round(float(np.max(np.abs(d.phi))), 2) for d in decays}) < 2:
        advice.append(
            "to confirm "
            + ", ".join(final.effects)
            + ": "
            + "; ".join(LIBRARY[e].separation(True) for e in final.effects)
        )
    if method == "output-error":
        coefficients = _coefficients(final, axis)
    else:
        coefficients = _pooled([m for m in rows if m.method == method])
        warnings = [*method_bias(method, coefficients, _coefficients(final, axis)), *warnings]
    effects = tuple(
        EffectEstimate(e, final.value(e), final.sigma(e), unit(e, axis)) for e in final.effects
    )
    return EstimationResult(
        **{
            **motion.__dict__,
            "axis": axis,
            "method": method,
            "runs": ids,
            "coefficients": coefficients,
            "coefficients_before": _coefficients(base, axis),
            "units": {reported(n): unit(n, axis) for n in COEFFICIENTS} | {"position": "rad"},
            "effects": effects,
            "warnings": tuple(warnings),
            "advice": tuple(advice),
            "section": PendulumSection(
                methods=tuple(rows),
                peaks=peaks,
                geometry={d.run_id: asdict(d.geometry) for d in decays},
                decays=tuple(decays),
            ),
        }
    )


def _against_output_error(rows: Sequence[MethodEstimate]) -> list[MethodEstimate]:
    """Each seed method's row with the z of its coefficients from the output-error row of
    the same run (``stats.method_bias``: the result a user is told to sign)."""
    reference = {m.run_id: m.coefficients for m in rows if m.method == "output-error"}
    return [
        m
        if m.method == "output-error"
        else replace(m, against_output_error=z_scores(m.coefficients, reference[m.run_id]))
        for m in rows
    ]


def _output_error_rows(decays: Sequence[Decay], fit: MotionFit) -> list[MethodEstimate]:
    """The output-error fit as one row per run (coefficients are joint over runs; their U
    is the budget's, ``pendulum_budget``)."""

    def row(name: str, value: float, std: float) -> Coefficient:
        return Coefficient(value, std, ROW_UNITS[name])

    rows = []
    gamma = (
        row("quadratic_damping", fit.value("quadratic_damping"), fit.sigma("quadratic_damping"))
        if "quadratic_damping" in fit.names
        else None
    )
    for d, res in zip(decays, fit.residuals, strict=True):
        g, arm = d.geometry, d.geometry.pivot_to_vehicle_m
        alpha = row("added_mass", fit.value(INERTIA), fit.sigma(INERTIA))
        beta = row("linear_damping", fit.value("linear_damping"), fit.sigma("linear_damping"))
        inertia = row(
            "total_inertia", g.known_inertia() + alpha.value * arm**2, fit.sigma(INERTIA) * arm**2
        )
        damping = row(
            "total_damping",
            beta.value * arm**2 + g.pivot_damping_nm_s,
            fit.sigma("linear_damping") * arm**2,
        )
        effects = {e: fit.value(e) for e in fit.effects}
        mse = float(np.mean(res**2))
        rows.append(
            MethodEstimate(
                "output-error", d.run_id, alpha, beta, gamma, inertia, damping, effects, mse,
                float(np.sqrt(mse)),
                "nonlinear model (sin φ) integrated and fitted to the angle"
                + (f", with {', '.join(fit.effects)}" if fit.effects else ""),
            )
        )  # fmt: skip
    return rows
