"""Coefficient sensitivity and model reduction (seed 004) on the 6-DOF model.

For a vehicle and a set of responses (``estimation.vehicle.responses``), per coefficient H and
response R:

- normalized sensitivity ``S = (ΔR/R_ref)/(ΔH/H)`` by central difference, H·(1 ± δ);
- knock-out index ``Sc = |(R_ref − R)/R_ref|`` with H set to 0;
- composite index ``R_i = Σ_j Sc_ij·Y_j`` with response weights Y (AHP or given; default
  equal) and the ranking by it;
- ±σ change: ``max(|R(H ± σ) − R_ref|)/|R_ref|`` with σ from ``vehicle.sigma``;
- a threshold sweep: every candidate below the threshold removed *jointly*, the reduced
  model re-simulated, its error per response, the largest one and the weighted one. Each
  threshold is swept twice: on the composite index (the seed's rule) and on the largest
  single-response Sc (a weighted sum can hide a coefficient that matters to one response);
- weight stability: which removals change when one response's weight is doubled or halved
  (AHP weights are judgements).

When |R_ref| is ≈ 0 the relative change is undefined: that response's changes are divided
by the largest |R| seen in the analysis instead ("range" mode, reported per response).

The report's types and the weight-stability check (which needs no simulation) are
``estimation.vehicle.sensitivity_report``.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from estimation.vehicle.ahp import Hierarchy, Judgement, normalise_weights
from estimation.vehicle.description import Vehicle6
from estimation.vehicle.responses import (
    Plan,
    ResponseValue,
    attitude_warnings,
    evaluate,
    measure,
    plan,
    simulate_plan,
)
from estimation.vehicle.sensitivity_report import (
    CoefficientRow,
    SensitivityReport,
    SweepRow,
    weight_stability,
)

DEFAULT_DELTA = 0.01
DEFAULT_THRESHOLDS: tuple[float, ...] = (0.005, 0.0075, 0.01)
#: |R_ref| below this fraction of the largest |R| seen → "range" mode for that response.
ZERO_RESPONSE = 1e-6
CRITERIA = ("composite", "max")


class SensitivityError(ValueError):
    """Bad analysis input; the message names the field, the value and what is allowed."""


def _weights(
    weights: Mapping[str, float] | Judgement | Hierarchy | None, names: Sequence[str]
) -> tuple[dict[str, float], dict | None]:
    if weights is None:
        return {n: 1.0 / len(names) for n in names}, None
    if isinstance(weights, Hierarchy):
        return normalise_weights(weights.weights, names), weights.to_json()
    if isinstance(weights, Judgement):
        given = dict(zip(weights.labels, weights.weights, strict=True))
        return normalise_weights(given, names), weights.to_json()
    return normalise_weights(dict(weights), names), None


def _check(vehicle: Vehicle6, delta: float, thresholds, keep, candidates) -> None:
    names = vehicle.coefficients()
    if not (np.isfinite(delta) and 0 < delta < 0.5):
        raise SensitivityError(f"delta: {delta!r} is not allowed; give 0 < delta < 0.5")
    for t in thresholds:
        if not (np.isfinite(t) and t > 0):
            raise SensitivityError(f"thresholds: {t!r} is not allowed; give thresholds > 0")
    for field_name, given in (("keep", keep), ("candidates", candidates or ())):
        for n in given:
            if n not in names:
                raise SensitivityError(
                    f"{field_name}: {n!r} is not allowed; allowed: {', '.join(names)}"
                )


class _Evaluator:
    """Evaluates the plan on changed vehicles, counting simulations."""

    def __init__(
        self,
        vehicle: Vehicle6,
        the_plan: Plan,
        max_evaluations: int | None,
        deadline: float | None,
        time_limit_s: float | None,
    ) -> None:
        self.vehicle = vehicle
        self.plan = the_plan
        self.max_evaluations = max_evaluations
        self.deadline = deadline
        self.time_limit_s = time_limit_s
        self.simulations = 0
        self.notes: list[str] = []

    def __call__(self, changes: Mapping[str, float], label: str) -> dict[str, ResponseValue]:
        """Responses of the changed vehicle; a failed simulation (e.g. the vehicle pitched
        to ±90°) gives NaN responses and a note naming ``label``."""
        if self.deadline is not None and time.perf_counter() > self.deadline:
            raise SensitivityError(
                f"time_limit_s: the analysis took longer than {self.time_limit_s:g} s "
                f"(at {label}); ask for fewer responses or thresholds, or smaller forces"
            )
        self.simulations += len(self.plan.manoeuvres)
        v = self.vehicle.with_coefficients(dict(changes)) if changes else self.vehicle
        try:
            return evaluate(v, self.plan, max_evaluations=self.max_evaluations)
        except (ValueError, RuntimeError) as exc:
            self.notes.append(f"{label}: simulation failed ({exc}); its changes count as ∞")
            return {r.name: ResponseValue(float("nan"), False) for r in self.plan.responses}


def analyse(
    vehicle: Vehicle6,
    responses: Sequence[str] | None = None,
    *,
    weights: Mapping[str, float] | Judgement | Hierarchy | None = None,
    delta: float = DEFAULT_DELTA,
    thresholds: Iterable[float] = (),
    keep: Iterable[str] = (),
    candidates: Iterable[str] | None = None,
    forces: Mapping[str, float] | None = None,
    distance_time_s: float | None = None,
    max_evaluations: int | None = None,
    time_limit_s: float | None = None,
) -> SensitivityReport:
    """Sensitivity, knock-out, composite ranking, ±σ and the threshold sweep of ``vehicle``.

    ``thresholds`` are added to ``DEFAULT_THRESHOLDS``. ``keep`` names coefficients never
    removed; ``candidates`` limits the removable ones (default: every non-zero one).
    ``weights`` are per-response weights (renormalised) or an AHP judgement/hierarchy whose
    labels are the response names; default equal weights. ``max_evaluations`` bounds each
    simulation's cost (a variant past it counts as failed); past ``time_limit_s`` the
    analysis stops with a SensitivityError.
    """
    start = time.perf_counter()
    keep = tuple(keep)
    candidates = None if candidates is None else tuple(candidates)
    thresholds = tuple(sorted(set(DEFAULT_THRESHOLDS) | {float(t) for t in thresholds}))
    _check(vehicle, delta, thresholds, keep, candidates)
    the_plan = plan(vehicle, responses, forces=forces, distance_time_s=distance_time_s)
    names = [r.name for r in the_plan.responses]
    y, ahp_info = _weights(weights, names)
    deadline = None if time_limit_s is None else start + time_limit_s
    run = _Evaluator(vehicle, the_plan, max_evaluations, deadline, time_limit_s)
    notes: list[str] = []

    ref_trajectories = simulate_plan(vehicle, the_plan, max_evaluations=max_evaluations)
    run.simulations += len(the_plan.manoeuvres)
    ref = measure(the_plan, ref_trajectories)
    notes.extend(attitude_warnings(the_plan, ref_trajectories))
    coefficients = vehicle.coefficients()
    sigma = {k: float(v) for k, v in (vehicle.sigma or {}).items() if k in coefficients}
    raw: dict[str, dict[str, dict[str, ResponseValue]]] = {}
    zero = tuple(n for n, h in coefficients.items() if h == 0)
    for name, h in coefficients.items():
        if h == 0:
            continue
        raw[name] = {
            "plus": run({name: h * (1 + delta)}, f"{name} × (1 + δ)"),
            "minus": run({name: h * (1 - delta)}, f"{name} × (1 − δ)"),
            "zero": run({name: 0.0}, f"{name} = 0"),
        }
        s = sigma.get(name)
        if s is not None and s > 0:
            low = h - s if h - s >= 0 or h < 0 else 0.0
            if low != h - s:
                notes.append(f"{name}: H − σ = {h - s:.4g} < 0; the −σ case uses 0")
            raw[name]["sigma_plus"] = run({name: h + s}, f"{name} + σ")
            raw[name]["sigma_minus"] = run({name: low}, f"{name} − σ")

    scales, modes = _scales(ref, raw, names)
    for n in names:
        if modes[n] == "range":
            notes.append(
                f"{n}: reference value ≈ 0, so changes are divided by the largest |{n}| seen "
                f"({scales[n]:.4g}) instead of by the reference (range mode)"
            )
        if not ref[n].settled:
            notes.append(f"{n}: not settled at the end of the reference manoeuvre")

    def change(n: str, value: ResponseValue) -> float:
        if not np.isfinite(value.value):
            return float("inf")
        return abs(value.value - ref[n].value) / scales[n] if scales[n] > 0 else 0.0

    rows = []
    removable = set(candidates) if candidates is not None else set(coefficients)
    for name, h in coefficients.items():
        if h == 0:
            continue
        r = raw[name]
        s_val: dict[str, float | None] = {}
        sc: dict[str, float] = {}
        for n in names:
            diff = r["plus"][n].value - r["minus"][n].value
            slope = (diff / (2 * scales[n])) / delta if scales[n] > 0 else 0.0
            # S is relative to the signed reference
            s_val[n] = -slope if modes[n] == "relative" and ref[n].value < 0 else slope
            sc[n] = change(n, r["zero"][n])
        sig_change = None
        if "sigma_plus" in r:
            sig_change = {
                n: max(change(n, r["sigma_plus"][n]), change(n, r["sigma_minus"][n])) for n in names
            }
        composite = float(sum(sc[n] * y[n] for n in names))
        rows.append(
            CoefficientRow(
                name=name,
                value=float(h),
                sigma=sigma.get(name),
                candidate=name in removable and name not in keep,
                keep=name in keep,
                s=s_val,
                sc=sc,
                composite=composite,
                max_sc=max(sc.values()),
                sigma_change=sig_change,
            )
        )
    rows.sort(key=lambda row: (-row.composite, row.name))

    sweep = []
    for criterion in CRITERIA:
        for t in thresholds:
            removed = tuple(
                row.name
                for row in rows
                if row.candidate and (row.composite if criterion == "composite" else row.max_sc) < t
            )
            label = f"reduced model ({criterion} < {t:g})"
            reduced = run(dict.fromkeys(removed, 0.0), label) if removed else ref
            errors = {n: change(n, reduced[n]) for n in names}
            worst = max(names, key=lambda n: errors[n])
            sweep.append(
                SweepRow(
                    criterion=criterion,
                    threshold=t,
                    removed=removed,
                    errors=errors,
                    max_error=errors[worst],
                    worst_response=worst,
                    weighted_error=float(sum(errors[n] * y[n] for n in names)),
                    settled=all(v.settled for v in reduced.values()),
                )
            )
    return SensitivityReport(
        vehicle=vehicle.name,
        plan=the_plan,
        reference={n: ref[n].value for n in names},
        modes=modes,
        scales=scales,
        weights=y,
        ahp=ahp_info,
        delta=delta,
        rows=tuple(rows),
        zero=zero,
        sweep=tuple(sweep),
        notes=tuple(notes + run.notes),
        simulations=run.simulations,
        elapsed_s=time.perf_counter() - start,
        weight_stability=tuple(weight_stability(rows, y, thresholds)),
    )


def _scales(
    ref: Mapping[str, ResponseValue],
    raw: Mapping[str, Mapping[str, Mapping[str, ResponseValue]]],
    names: Sequence[str],
) -> tuple[dict[str, float], dict[str, str]]:
    """Divisor per response: |R_ref|, or the largest |R| seen when R_ref ≈ 0."""
    scales, modes = {}, {}
    for n in names:
        seen = [abs(ref[n].value)] + [
            abs(case[n].value) for cases in raw.values() for case in cases.values()
        ]
        largest = max((x for x in seen if np.isfinite(x)), default=0.0)
        r0 = abs(ref[n].value)
        if np.isfinite(r0) and r0 > ZERO_RESPONSE * largest and r0 > 0:
            scales[n], modes[n] = r0, "relative"
        else:
            scales[n], modes[n] = largest, "range"
    return scales, modes
