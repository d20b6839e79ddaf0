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

from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from estimation.axis.result import EffectEstimate
from estimation.blas_threads import one_blas_thread
from estimation.data.run_arrays import validate_run_set
from estimation.errors import EstimationFailed
from estimation.motion.decay_estimate import estimate_records
from estimation.motion.decay_result import DecayResult
from estimation.motion.output_error_fit import MotionFit
from estimation.motion.term_search import Step, evidence_json
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
    MethodEstimate,
    damped_fit,
    equation_error,
    log_decrement,
    row_value,
)
from estimation.pendulum.swing_extrema import Decay, Peaks, find_peaks, prepare_decay
from estimation.report_numbers import Coefficient, finite_or_none, finite_values
from estimation.stats.acceptance_rules import DECAY_RULES
from estimation.stats.diagnostics import Whiteness, ljung_box
from estimation.uncertainty.budget import Budget
from estimation.uncertainty.motion_budget import motion_budget

SCHEMA_VERSION = 1
GEOMETRY_EXACT = (
    "Type B not declared: the rig file's pendulum geometry (rod, arm, buoyancy) is taken as "
    "exact, so U covers the fit alone"
)
#: The coefficients the result reports (α, β and the vehicle's candidate terms).
COEFFICIENTS = (INERTIA, *BASE_TERMS, *(c for c in CANDIDATES if not at_pivot(c)))
#: α and β, the fields every method row reports (``MethodEstimate``).
BASE_NAMES: tuple[str, ...] = (ADDED_MASS, *BASE_TERMS)


@dataclass(frozen=True)
class PendulumResult:
    """Everything one pendulum estimation produced; ``to_json()`` is the documented document."""

    axis: str
    method: str
    runs: tuple[str, ...]
    coefficients: dict[str, Coefficient]
    coefficients_before: dict[str, Coefficient]
    effects: tuple[EffectEstimate, ...]
    ambiguous: tuple[tuple[str, ...], ...]
    methods: tuple[MethodEstimate, ...]
    peaks: dict[str, Peaks]
    rmse_before: float
    rmse_after: float
    rmse_per_run_before: dict[str, float]
    rmse_per_run_after: dict[str, float]
    whiteness_before: Whiteness
    whiteness_after: Whiteness
    steps: tuple[Step, ...]
    warnings: tuple[str, ...]
    advice: tuple[str, ...]
    geometry: dict[str, dict[str, float]]
    fit_before: MotionFit = field(repr=False, compare=False)
    fit_after: MotionFit = field(repr=False, compare=False)
    decays: tuple[Decay, ...] = field(default=(), repr=False, compare=False)
    #: The one engine's result (``motion.decay_estimate``): B_e, what is well determined,
    #: the budget.
    motion: DecayResult | None = field(default=None, repr=False, compare=False)

    def budget(self) -> Budget:
        """The GUM budget of the output-error coefficients (``uncertainty.motion_budget``,
        the one engine's), named and in the units this result reports them."""
        if self.motion is None or self.motion.fit is None:
            raise ValueError("result: got a pendulum estimate without its fit")
        names = self.motion.fit.names
        b = motion_budget(self.motion, units={n: unit(n, self.axis) for n in names})
        return replace(
            b,
            notes=(GEOMETRY_EXACT,),
            coefficients={
                reported(n): replace(c, name=reported(n)) for n, c in b.coefficients.items()
            },
        )

    def method_estimate(self, method: str, run_id: str | None = None) -> MethodEstimate:
        """The row of ``method`` (on ``run_id``, default the first run)."""
        rid = run_id or self.runs[0]
        for m in self.methods:
            if m.method == method and m.run_id == rid:
                return m
        raise KeyError(f"method {method!r} on run {rid!r} not in this result")

    def to_json(self) -> dict[str, Any]:
        """The JSON document (schema in docs/pendulum.md); each run's peaks carry the
        release (its decay's first sample) on the run's clock, so a plot can show the time
        from the release."""
        start = {d.run_id: float(d.t[0]) for d in self.decays}
        return {
            "schema_version": SCHEMA_VERSION,
            "analysis": "pendulum",
            "axis": self.axis,
            "method": self.method,
            "runs": list(self.runs),
            "coefficients": {k: v.to_json() for k, v in self.coefficients.items()},
            "coefficients_before": {k: v.to_json() for k, v in self.coefficients_before.items()},
            "units": {reported(n): unit(n, self.axis) for n in COEFFICIENTS} | {"position": "rad"},
            "effects": [e.to_json() for e in self.effects],
            "ambiguous": [list(g) for g in self.ambiguous],
            "methods": [m.to_json() for m in self.methods],
            "peaks": {
                rid: p.to_json() | {"release_time_s": start.get(rid)}
                for rid, p in self.peaks.items()
            },
            "rmse_before": finite_or_none(self.rmse_before),
            "rmse_after": finite_or_none(self.rmse_after),
            "rmse_per_run_before": finite_values(self.rmse_per_run_before),
            "rmse_per_run_after": finite_values(self.rmse_per_run_after),
            "warnings": list(self.warnings),
            "advice": list(self.advice),
            "equivalent_linear_damping": [
                e.to_json() for e in (self.motion.equivalent if self.motion else ())
            ],
            "well_determined": [
                c.to_json() for c in (self.motion.well_determined if self.motion else ())
            ],
            "coefficients_possibly_biased": bool(self.motion and self.motion.possibly_biased),
            "bootstrap": (
                self.motion.bootstrap.to_json(reported)
                if self.motion and self.motion.bootstrap
                else None
            ),
            # the runs' repeats, a decay's and a tow set's shape (``motion.decay_repeats``)
            "repeats": self.motion.repeats.to_json()
            if self.motion and self.motion.repeats
            else None,
            "next_release": [
                p.to_json(reported) for p in (self.motion.next_release if self.motion else ())
            ],
            "geometry": self.geometry,
            "diagnostics": {
                "ljung_box_before": self.whiteness_before.to_json(),
                "ljung_box_after": self.whiteness_after.to_json(),
            },
            "evidence": evidence_json(
                self.fit_before,
                self.fit_after,
                None if self.motion is None else self.motion.cv_before,
                None if self.motion is None else self.motion.cv_after,
                self.steps,
            ),
            "acceptance_rules": DECAY_RULES.to_json(),
            "nuisance": {
                rid: {
                    "initial_angle": finite_or_none(a),
                    "initial_rate": finite_or_none(r),
                    "offset": finite_or_none(o),
                }
                for rid, a, r, o in zip(
                    self.runs,
                    self.fit_after.initial[:, 0],
                    self.fit_after.initial[:, 1],
                    self.fit_after.equilibrium,
                    strict=True,
                )
            },
        }


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
    """Inverse-variance mean of one method's α and β over runs."""
    out = {}
    for name in BASE_NAMES:
        est = [getattr(m, name) for m in rows]
        w = np.array([1 / e.std**2 if e.std is not None and e.std > 0 else 0.0 for e in est])
        vals = np.array([e.value for e in est])
        if w.sum() > 0:
            mean, std = float(w @ vals / w.sum()), float(1 / np.sqrt(w.sum()))
        else:
            mean, std = float(vals.mean()), float("nan")
        out[name] = Coefficient(mean, std, est[0].unit)
    return out


def _warnings(
    methods: Sequence[MethodEstimate],
    peaks: dict[str, Peaks],
    decays: Sequence[Decay],
    final: MotionFit,
) -> list[str]:
    out = []
    for m in methods:
        q = m.quadratic_damping
        if m.method != "equation-error" or q is None or q.std is None:
            continue
        if q.value < -2 * q.std:
            out.append(
                f"equation-error γ = {q.value:.4g} ± {q.std:.2g} kg/m < 0 on run {m.run_id}: "
                f"the signature of dry friction in the pivot (least squares puts sgn φ̇ into a "
                f"too-large β, {m.linear_damping.value:.4g} N·s/m, and a negative γ)"
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
    if motion.base is None or motion.fit is None:
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
    base, final = motion.base, motion.fit
    steps: tuple[Step, ...] = motion.steps
    ambiguous: tuple[tuple[str, ...], ...] = tuple(motion.ambiguous)
    advice = list(motion.advice)
    ids = tuple(d.run_id for d in decays)
    rows += _output_error_rows(decays, final)
    white_before, white_after = ljung_box(base.residuals), ljung_box(final.residuals)
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
    effects = tuple(
        EffectEstimate(e, final.value(e), final.sigma(e), unit(e, axis)) for e in final.effects
    )
    return PendulumResult(
        axis=axis,
        method=method,
        runs=ids,
        coefficients=coefficients,
        coefficients_before=_coefficients(base, axis),
        effects=effects,
        ambiguous=tuple(ambiguous),
        methods=tuple(rows),
        peaks=peaks,
        rmse_before=base.rmse,
        rmse_after=final.rmse,
        rmse_per_run_before=dict(zip(ids, base.rmse_per_run(), strict=True)),
        rmse_per_run_after=dict(zip(ids, final.rmse_per_run(), strict=True)),
        whiteness_before=white_before,
        whiteness_after=white_after,
        steps=tuple(steps),
        warnings=tuple(warnings),
        advice=tuple(advice),
        geometry={d.run_id: asdict(d.geometry) for d in decays},
        fit_before=base,
        fit_after=final,
        decays=tuple(decays),
        motion=motion,
    )


def _output_error_rows(decays: Sequence[Decay], fit: MotionFit) -> list[MethodEstimate]:
    """The output-error fit as one row per run (coefficients are joint over runs)."""
    rows = []
    gamma = (
        row_value(
            "quadratic_damping", fit.value("quadratic_damping"), fit.sigma("quadratic_damping")
        )
        if "quadratic_damping" in fit.names
        else None
    )
    for d, res in zip(decays, fit.residuals, strict=True):
        g, arm = d.geometry, d.geometry.pivot_to_vehicle_m
        alpha = row_value("added_mass", fit.value(INERTIA), fit.sigma(INERTIA))
        beta = row_value("linear_damping", fit.value("linear_damping"), fit.sigma("linear_damping"))
        inertia = row_value(
            "total_inertia", g.known_inertia() + alpha.value * arm**2, fit.sigma(INERTIA) * arm**2
        )
        damping = row_value(
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
