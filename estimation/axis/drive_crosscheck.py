"""Cross-check: coefficients from weight-driven runs against those from thruster-driven runs.

Works on two stored estimation result documents (``EstimationResult.to_json()``) of the
same axis. Per coefficient: both values ± σ_total (the fit's σ and, for thruster-driven
runs, the thrust calibration's), their difference and z = Δ / √(σ₁² + σ₂²); verdict
``agree`` (|z| < 2), ``marginal`` (2 ≤ |z| < 3) or ``disagree`` (|z| ≥ 3).

A set that cannot separate K_L from K_Q (one drive level, or |ρ(K_L, K_Q)| above the
estimator's SEPARABILITY_LIMIT; see ``estimation.axis.set_separability``) gets no verdict on them:
they are ``undecided``, with the run that would decide them. Compared instead is what such a
set does fix, the damping K_L + K_Q·|v| at the speed it ran (``damping_at_speed``).
Undecided comparisons take no part in the common factor, the overall verdict or the
diagnosis below.

Diagnosis, in order:

a. A drive scaled by k scales inertia, K_L and K_Q all by k. When the thruster/weight
   ratios are consistent with one common factor (weighted mean k, χ² test; or their
   scatter about k is under a quarter of |k − 1|: k carries the bulk of the disagreement)
   and k differs from 1 by more than 3σ_k, the thrust calibration is off: the estimator was told the
   calibrated thrust F while the vehicle felt F/k, so the thrusters deliver 1/k× the
   calibrated thrust (k > 1: weaker than at calibration). Recalibrate.
b. When the two residual searches kept different effects, the difference is named: the
   effect belongs to one way of driving the rig (e.g. thruster lag seen as a delay).
c. Otherwise any disagreement left is reported as unexplained.

The per-coefficient comparisons and the common factor are
``estimation.axis.crosscheck_comparison``; the report files are written by
``estimation.axis.crosscheck_report``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from estimation.axis.crosscheck_comparison import (
    COEFFICIENTS,
    COMBINED,
    DAMPING,
    LABELS,
    SAME_SPEED,
    SPEED_UNITS,
    UNITS,
    CommonFactor,
    Comparison,
    common_factor,
    finite_or_none,
)
from estimation.axis.effects import EFFECTS
from estimation.axis.set_separability import SetSeparability, damping_at, separability
from estimation.axis.tow_estimate import SEPARABILITY_LIMIT
from estimation.data.driven_axes import DRIVEN_AXES
from estimation.design.advice import separating_load
from estimation.design.planning_envelope import RigEnvelope
from estimation.report_numbers import finite_values


@dataclass(frozen=True)
class CrossCheck:
    """Weight- vs thruster-driven coefficients of one axis, with the diagnosis."""

    axis: str
    weight_result_id: int | None
    thruster_result_id: int | None
    weight_runs: tuple[str, ...]
    thruster_runs: tuple[str, ...]
    comparisons: tuple[Comparison, ...]
    factor: CommonFactor | None
    effects_weight: dict[str, float]
    effects_thruster: dict[str, float]
    rmse: dict[str, dict[str, float | None]]
    diagnosis: tuple[str, ...]
    warnings: tuple[str, ...] = ()
    supply: dict[str, float | None] = field(default_factory=dict)
    combined: tuple[Comparison, ...] = ()  # damping_at_speed when a set cannot split K_L/K_Q

    @property
    def all_comparisons(self) -> tuple[Comparison, ...]:
        return (*self.comparisons, *self.combined)

    @property
    def undecided(self) -> tuple[str, ...]:
        """Names of the coefficients without a verdict."""
        return tuple(c.name for c in self.comparisons if not c.decided)

    @property
    def verdict(self) -> str:
        """The worst verdict over the decided comparisons; ``undecided`` when none is."""
        order = ("agree", "unknown", "marginal", "disagree")
        decided = [c.verdict for c in self.all_comparisons if c.decided]
        return max(decided, key=order.index) if decided else "undecided"

    def to_json(self) -> dict[str, Any]:
        """The stored document (kind ``crosscheck``); see docs/hil.md."""
        return {
            "kind": "crosscheck",
            "axis": self.axis,
            "weight_result_id": self.weight_result_id,
            "thruster_result_id": self.thruster_result_id,
            "weight_runs": list(self.weight_runs),
            "thruster_runs": list(self.thruster_runs),
            "coefficients": {c.name: c.to_json(self.axis) for c in self.comparisons},
            "combined": {c.name: c.to_json(self.axis) for c in self.combined},
            "undecided": list(self.undecided),
            "verdict": self.verdict,
            "common_factor": self.factor.to_json() if self.factor else None,
            "effects": {
                "weight": finite_values(self.effects_weight),
                "thruster": finite_values(self.effects_thruster),
            },
            "rmse": self.rmse,
            "supply_voltage_v": finite_values(self.supply),
            "diagnosis": list(self.diagnosis),
            "warnings": list(self.warnings),
        }


def _check(name: str, doc: Any) -> None:
    # every document names its kind (schema 1: a pendulum's "analysis", a tow's nothing)
    kind = (doc.get("kind") or doc.get("analysis")) if isinstance(doc, dict) else None
    driven = {a.kind for a in DRIVEN_AXES.values()}
    if kind is not None and kind not in driven:  # another estimator's result
        raise ValueError(
            f"{name}: a {kind} estimation; allowed: an estimation of {' or '.join(sorted(driven))}"
        )
    if not isinstance(doc, dict) or not isinstance(doc.get("coefficients"), dict):
        raise ValueError(
            f"{name}: not an estimation result (no 'coefficients'); allowed: a stored "
            "estimation result document"
        )
    missing = [c for c in COEFFICIENTS if c not in doc["coefficients"]]
    if missing:
        raise ValueError(f"{name}.coefficients: missing {missing}; allowed: {list(COEFFICIENTS)}")
    if doc.get("axis") not in UNITS:
        raise ValueError(f"{name}.axis: {doc.get('axis')!r} is not allowed; allowed surge, yaw")


def _value_std(doc: dict, name: str) -> tuple[float, float]:
    """Value and σ: σ_total (fit ⊕ calibration; the fit's σ for results stored before it),
    or the run-level bootstrap σ when that is larger: the fit's σ assumes white residuals,
    the bootstrap sees how much the runs disagree among themselves."""
    c = doc["coefficients"][name]
    value = float("nan") if c.get("value") is None else float(c["value"])
    std = c.get("std")
    total = ((doc.get("uncertainty") or {}).get("parameters") or {}).get(name, {})
    if total.get("std_total") is not None:
        std = total["std_total"]
    std = float("nan") if std is None else float(std)
    boot = ((doc.get("bootstrap") or {}).get("std") or {}).get(name)
    if boot is not None and (boot > std or not math.isfinite(std)):
        std = math.hypot(boot, (total.get("std_calibration") or 0.0))
    return value, std


def _effects(doc: dict) -> dict[str, float]:
    """Effects found (value) or ambiguous (NaN); a base coefficient an ambiguous group
    names (a term inseparable from K_L) is not an effect of the way the rig is driven."""
    found = {e["name"]: e.get("value") for e in doc.get("effects", [])}
    for group in doc.get("ambiguous", []):
        for name in group:
            if name in EFFECTS:
                found.setdefault(name, float("nan"))
    return found


def _calibration_line(factor: CommonFactor, supply: dict[str, float | None]) -> str:
    now, then = supply.get("runs"), supply.get("calibration")
    if now is not None and then is not None:
        volts = f"supply voltage now {now:.2f} V vs {then:.2f} V at calibration"
    else:
        volts = "supply voltage now vs at calibration: not recorded"
    scatter = (
        ""
        if factor.consistent
        else f"; a smaller second discrepancy remains: the ratios scatter by up to "
        f"{factor.spread:.3f} about k, beyond their σ (χ² p = {factor.p_value:.2g})"
    )
    return (
        f"thrust calibration: the thruster-driven {', '.join(LABELS[n] for n in factor.used)} "
        f"are all k = {factor.k:.3f} ± {factor.std:.3f}× the weight-driven ones (one common "
        f"factor), so the thrusters deliver "
        f"{factor.thrust_factor:.3f} ± {factor.thrust_factor_std:.3f}× the calibrated thrust: "
        f"recalibrate the thrusters ({volts}){scatter}"
    )


def cross_check(
    weight_result: dict[str, Any],
    thruster_result: dict[str, Any],
    *,
    supply_voltage_v: dict[str, float | None] | None = None,
    envelope: RigEnvelope | None = None,
) -> CrossCheck:
    """Compare two stored estimation results of one axis (weight- vs thruster-driven).

    ``supply_voltage_v``: optional ``{"calibration": V, "runs": V}`` (mean supply voltage
    during the thrust calibration and while the thruster-driven runs drove), quoted when
    the diagnosis points at the calibration. ``envelope``: the rig's tests (the planner's,
    ``estimation.design``), so advice names a run the rig can make. Raises ``ValueError``
    naming the field when a document is not an estimation result or the axes differ.
    """
    _check("weight_result", weight_result)
    _check("thruster_result", thruster_result)
    axis = weight_result["axis"]
    if thruster_result["axis"] != axis:
        raise ValueError(
            f"thruster_result.axis: {thruster_result['axis']!r} is not allowed; allowed: the "
            f"weight result's axis {axis!r}"
        )
    supply = dict(supply_voltage_v or {})
    sep = {"weight": separability(weight_result), "thruster": separability(thruster_result)}
    reasons = [
        _undecided_reason(side, s, axis, envelope) for side, s in sep.items() if not s.separable
    ]
    comparisons = []
    for name in COEFFICIENTS:
        w, sw = _value_std(weight_result, name)
        t, st = _value_std(thruster_result, name)
        why = "; ".join(reasons) if reasons and name in DAMPING else None
        why = _sigma_unknown(sw, st) or why
        comparisons.append(Comparison(name, w, sw, t, st, undecided=why))
    combined = _combined(weight_result, thruster_result, sep, axis)
    factor = common_factor([*comparisons, *combined])
    eff_w, eff_t = _effects(weight_result), _effects(thruster_result)
    warnings = []
    draws_t = (thruster_result.get("uncertainty") or {}).get("calibration_draws")
    if draws_t == 0:
        warnings.append(
            "the thruster result carries no calibration uncertainty (no drive draws): "
            "were its runs thruster-driven?"
        )
    draws_w = (weight_result.get("uncertainty") or {}).get("calibration_draws")
    if draws_w:
        warnings.append("the weight result has drive draws: were its runs weight-driven?")

    diagnosis = []
    bad = [c for c in (*comparisons, *combined) if c.verdict in ("marginal", "disagree")]
    if factor is not None and factor.significant and (factor.consistent or factor.dominant):
        diagnosis.append(_calibration_line(factor, supply))
    only_w = sorted(set(eff_w) - set(eff_t))
    only_t = sorted(set(eff_t) - set(eff_w))
    if only_w or only_t:
        parts = []
        if only_t:
            parts.append(f"only the thruster-driven runs show {_named(eff_t, only_t, axis)}")
        if only_w:
            parts.append(f"only the weight-driven runs show {_named(eff_w, only_w, axis)}")
        diagnosis.append(
            "the effect searches differ: "
            + "; ".join(parts)
            + " — an effect of the way the rig is driven, not of the vehicle"
        )
    if bad and not diagnosis:
        text = ", ".join(f"{c.label(axis)} (z = {c.z:+.1f})" for c in bad)
        if factor is not None and factor.significant:
            text += (
                f"; the ratios are not one common factor (k = {factor.k:.3f}, χ² p = "
                f"{factor.p_value:.2g}), so not simply the thrust calibration"
            )
        diagnosis.append(f"unexplained: {text}")
    undecided = [c for c in comparisons if not c.decided]
    if not diagnosis:
        if bad:
            diagnosis.append("marginal differences only")
        elif undecided:
            decided = ", ".join(c.label(axis) for c in (*comparisons, *combined) if c.decided)
            diagnosis.append(
                "weight- and thruster-driven sets agree within their uncertainties on what "
                f"both decide ({decided}; all |z| < 2)"
            )
        else:
            diagnosis.append(
                "weight- and thruster-driven coefficients agree within their uncertainties "
                "(all |z| < 2)"
            )
    if undecided:
        names = ", ".join(LABELS[c.name] for c in undecided)
        line = f"{names} undecided: {undecided[0].undecided}"
        for c in combined:
            line += (
                f"; compared instead: {c.label(axis)}, z = {c.z:+.1f} ({c.verdict})"
                if c.decided
                else f"; {c.label(axis)} not compared either: {c.undecided}"
            )
        diagnosis.append(line)
    rmse = {
        side: {
            "before": finite_or_none(doc.get("rmse_before")),
            "after": finite_or_none(doc.get("rmse_after")),
        }
        for side, doc in (("weight", weight_result), ("thruster", thruster_result))
    }
    return CrossCheck(
        axis=axis,
        weight_result_id=weight_result.get("result_id"),
        thruster_result_id=thruster_result.get("result_id"),
        weight_runs=tuple(weight_result.get("runs", [])),
        thruster_runs=tuple(thruster_result.get("runs", [])),
        comparisons=tuple(comparisons),
        factor=factor,
        effects_weight=eff_w,
        effects_thruster=eff_t,
        rmse=rmse,
        diagnosis=tuple(diagnosis),
        warnings=tuple(warnings),
        supply=supply,
        combined=tuple(combined),
    )


def _undecided_reason(
    side: str, sep: SetSeparability, axis: str, envelope: RigEnvelope | None = None
) -> str:
    """Why one set cannot decide K_L and K_Q, and which run would: the planner's separating
    load when the rig's ``envelope`` is known (never beyond its limits or calibration)."""
    force, unit = ("force", "N") if axis == "surge" else ("torque", "N·m")
    run = {
        ("weight", "surge"): "a weight run",
        ("weight", "yaw"): "a weight spin",
        ("thruster", "surge"): "a thruster tow",
        ("thruster", "yaw"): "a thruster spin",
    }[(side, axis)]
    rho = f"ρ = {sep.rho:+.4f}" if sep.rho is not None else "ρ not stored"
    if envelope is not None and sep.drive is not None:
        drive = "weight" if side == "weight" else "thrusters"
        test = separating_load(axis, [sep.drive], envelope, drive)
        if test is None:
            return (
                f"the {side} set's drive levels do not separate K_L from K_Q ({rho}) and the "
                f"rig offers no {force} clearly different within its limits and calibration"
            )
        return (
            f"the {side} set's drive levels do not separate K_L from K_Q ({rho}): add {run} "
            f"at {test.load:.4g} {unit}: run `{test.command}`"
        )
    if sep.one_level:
        now = f" ≈ {sep.drive:.3g} {unit}" if sep.drive is not None else ""
        return (
            f"the {side} set has one drive level (K_L, K_Q correlated {rho}): add {run} at a "
            f"clearly different {force}, e.g. 0.25× or 4× the current{now}"
        )
    return (
        f"the {side} set's drive levels do not separate K_L from K_Q ({rho}, beyond the "
        f"estimator's ±{SEPARABILITY_LIMIT}): add {run} well outside the {force}s it covers "
        f"(e.g. a quarter of the lowest or twice the highest)"
    )


def _combined(
    weight: dict[str, Any], thruster: dict[str, Any], sep: dict[str, SetSeparability], axis: str
) -> list[Comparison]:
    """The damping K_L + K_Q·|v| at the speed of the set that cannot split K_L from K_Q
    (the thruster set's when neither can); none when both sets separate them."""
    stuck = [side for side in ("thruster", "weight") if not sep[side].separable]
    speed = sep[stuck[0]].speed if stuck else None
    if speed is None:
        return []
    why = None
    if len(stuck) == 2:
        other = sep["weight"].speed
        if other is None:
            return []
        if abs(other - speed) > SAME_SPEED * speed:
            unit = SPEED_UNITS[axis]
            why = (
                f"neither set separates K_L from K_Q and they ran at different speeds "
                f"({other:.3g} vs {speed:.3g} {unit}): each fixes the damping at its own only"
            )
    w, sw = damping_at(weight, speed)
    t, st = damping_at(thruster, speed)
    why = why or _sigma_unknown(sw, st)
    return [Comparison(COMBINED, w, sw, t, st, undecided=why, speed=speed)]


def _sigma_unknown(weight_std: float, thruster_std: float) -> str | None:
    """Why a coefficient gets no verdict when a set has no σ for it (its runs do not
    identify it: a z without one would be judged on the other set's σ alone); None when
    both have one."""
    sides = [
        side
        for side, std in (("weight", weight_std), ("thruster", thruster_std))
        if not math.isfinite(std)
    ]
    if not sides:
        return None
    which = " and the ".join(sides) + (" sets have" if len(sides) > 1 else " set has")
    return (
        f"the {which} no σ for it (its runs do not identify it): estimate that set with a run "
        "at another force, or with output-error"
    )


def _named(found: dict[str, float], names: list[str], axis: str) -> str:
    out = []
    for n in names:
        v = found.get(n)
        out.append(f"{n} ({v:.3g})" if v is not None and math.isfinite(v) else n)
    return ", ".join(out)
