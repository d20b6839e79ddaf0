"""How well the recorded runs determine each coefficient, and which test would help most.

From stored estimation results (``EstimationResult.to_json()``: per axis ``inertia``,
``linear_damping``, ``quadratic_damping`` with value and std, and their correlation) and a
sensitivity analysis of the vehicle they were plugged into:

- relative σ of each coefficient, σ/|H|;
- its contribution to each response's uncertainty, ``c_ij = |S_ij|·σ_i/|H_i|`` (first-order
  relative change of R_j for a 1σ change of H_i), their weighted sum ``Σ_j Y_j·c_ij`` and
  its share of each response's variance ``c_ij² / Σ_k c_kj²`` (correlations ignored);
- pairs of fitted coefficients correlated beyond ``HIGH_CORRELATION``;
- the next test: for the coefficient with the largest weighted contribution, the tow/spin
  (or pendulum) test that pins it down, with the reason in one line. Coefficients of axes
  the rig never identified are listed as placeholders.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from estimation.data.driven_axes import DRIVEN_AXES
from estimation.data.run_arrays import RunData
from estimation.vehicle.apply_estimates import apply_result_json
from estimation.vehicle.description import DOFS, Vehicle6
from estimation.vehicle.sensitivity import SensitivityReport, analyse

#: Result JSON names → vehicle coefficient kinds.
RESULT_KINDS = {
    "inertia": "added_mass",
    "linear_damping": "linear_damping",
    "quadratic_damping": "quadratic_damping",
}
#: Axes the rig can identify: those its tows and spins drive (``driven_axes``).
MEASURED_AXES = tuple(DRIVEN_AXES)
HIGH_CORRELATION = 0.9


class IdentifiabilityError(ValueError):
    """A result document that cannot be used; the message names the field."""


def plug_results(vehicle: Vehicle6, results: Sequence[Mapping[str, Any]]) -> Vehicle6:
    """The vehicle with each result's identified axis model (value and σ) plugged in
    (:func:`estimation.vehicle.apply_estimates.apply_result_json`); one result per axis."""
    seen: dict[str, int] = {}
    for k, doc in enumerate(results):
        where = f"results[{k}]" + (f" (id {doc['result_id']})" if "result_id" in doc else "")
        axis = str(doc.get("dof") or doc.get("axis"))  # the line it moved along
        if axis in seen:
            raise IdentifiabilityError(
                f"{where}: axis: a second result for {axis!r} (the first is results[{seen[axis]}]);"
                " give one result per axis"
            )
        vehicle = apply_result_json(vehicle, doc, where)
        seen[axis] = k
    return vehicle


def run_speed(run: RunData) -> float:
    """Speed at the end of a run's usable motion (m/s or rad/s): the mean over its last
    quarter, robust to encoder quantization."""
    mask = run.window() & (run.t >= run.t_release)
    t, x = run.t[mask], run.position[mask]
    if len(t) < 3 or t[-1] <= t[0]:
        return 0.0
    start = t[-1] - 0.25 * (t[-1] - t[0])
    k = int(np.searchsorted(t, start))
    k = min(k, len(t) - 2)
    return float(abs(x[-1] - x[k]) / (t[-1] - t[k]))


def _correlations(results: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    out = []
    for doc in results:
        corr = doc.get("correlation") or {}
        names, matrix = corr.get("names") or [], corr.get("matrix") or []
        for i in range(len(names)):
            for j in range(i + 1, len(names)):
                rho = matrix[i][j] if i < len(matrix) and j < len(matrix[i]) else None
                if isinstance(rho, (int, float)) and abs(rho) >= HIGH_CORRELATION:
                    out.append(
                        {
                            "axis": doc["axis"],
                            "a": _coefficient_name(names[i], doc["axis"]),
                            "b": _coefficient_name(names[j], doc["axis"]),
                            "rho": float(rho),
                        }
                    )
    return out


def _coefficient_name(result_name: str, axis: str) -> str:
    kind = RESULT_KINDS.get(result_name)
    return f"{kind}.{axis}" if kind else f"{result_name} ({axis})"


def assess(
    report: SensitivityReport,
    vehicle: Vehicle6,
    results: Sequence[Mapping[str, Any]] = (),
    run_speeds: Mapping[str, Sequence[float]] | None = None,
) -> dict[str, Any]:
    """Identifiability ranking and next-test suggestion (a JSON-ready dict).

    ``vehicle`` is the one analysed (σ in ``vehicle.sigma``); ``results`` the estimation
    documents plugged into it (for correlations); ``run_speeds`` per axis the end speeds of
    the runs behind them (m/s or rad/s), when known.
    """
    names = [r.name for r in report.plan.responses]
    y = report.weights
    units = {r.name: r.unit for r in report.plan.responses}
    contributions: dict[str, dict[str, float]] = {}
    rows: list[dict[str, Any]] = []
    for row in report.rows:
        sigma = vehicle.sigma.get(row.name)
        if sigma is None or row.value == 0:
            continue
        rel = sigma / abs(row.value)
        c = {n: float("nan") if (s := row.s[n]) is None else abs(s) * rel for n in names}
        contributions[row.name] = c
        rows.append(
            {
                "name": row.name,
                "value": row.value,
                "sigma": sigma,
                "relative_sigma": rel,
                "contribution": c,
                "weighted": float(np.nansum([c[n] * y[n] for n in names])),
            }
        )
    for r in rows:
        share = {}
        for n in names:
            total = sum(cc[n] ** 2 for cc in contributions.values() if np.isfinite(cc[n]))
            share[n] = r["contribution"][n] ** 2 / total if total > 0 else 0.0
        r["share"] = share
    rows.sort(key=lambda r: -r["weighted"])
    by_rel = [r["name"] for r in sorted(rows, key=lambda r: -r["relative_sigma"])]
    measured_axes = {doc["axis"] for doc in results} | {
        name.split(".")[1] for name in vehicle.sigma
    }
    unmeasured: list[dict[str, Any]] = [
        {
            "name": row.name,
            "composite": row.composite if np.isfinite(row.composite) else None,  # None: ∞
            "note": _unmeasured_note(row.name.split(".")[1], measured_axes),
        }
        for row in report.rows
        if row.name not in contributions
    ]
    correlations = _correlations(results)
    next_test = _next_test(rows, vehicle, correlations, run_speeds or {}, units, y)
    influential = [u for u in unmeasured if u["composite"] is None or u["composite"] > 0]
    if influential:
        top = influential[0]
        next_test["unmeasured"] = (
            f"the most influential coefficient without σ is {top['name']} (composite "
            f"{_composite(top['composite'])}): {top['note']}"
        )
    return {
        "coefficients": [_clean(r) for r in rows],
        "by_relative_sigma": by_rel,
        "correlations": correlations,
        "unmeasured": unmeasured,
        "next_test": next_test,
    }


def _composite(x: float | None) -> str:
    return "∞: the model fails without it" if x is None else f"{x:.3g}"


def _unmeasured_note(axis: str, measured_axes: set[str]) -> str:
    if axis in measured_axes:
        return "no σ for this coefficient"
    if axis in MEASURED_AXES:
        side = "tows" if axis == "surge" else "spins"
        return f"no {axis} result plugged in: its value is unverified (the rig can run {side})"
    return "not measured: values are placeholders"


def _clean(row: dict[str, Any]) -> dict[str, Any]:
    def num(x: Any) -> Any:
        if isinstance(x, dict):
            return {k: num(v) for k, v in x.items()}
        if isinstance(x, float) and not np.isfinite(x):
            return None
        return x

    return {k: num(v) for k, v in row.items()}


def _speed_unit(axis: str) -> str:
    return "m/s" if DOFS.index(axis) < 3 else "rad/s"


def _next_test(
    rows: Sequence[dict[str, Any]],
    vehicle: Vehicle6,
    correlations: Sequence[dict[str, Any]],
    run_speeds: Mapping[str, Sequence[float]],
    units: Mapping[str, str],
    y: Mapping[str, float],
) -> dict[str, Any]:
    if not rows or rows[0]["weighted"] <= 0:
        return {
            "coefficient": None,
            "test": None,
            "reason": "no coefficient has a σ that moves a response: plug in estimation "
            "results (their std) or give σ in the vehicle file",
        }
    top = rows[0]
    name = top["name"]
    kind, axis = name.split(".")
    response = max(top["share"], key=lambda n: top["share"][n] * y[n])
    share = top["share"][response]
    reason = [
        f"{name} contributes {100 * share:.0f} % of the {response} uncertainty "
        f"(σ/|H| = {100 * top['relative_sigma']:.2g} %)"
    ]
    unit = _speed_unit(axis)
    i = DOFS.index(axis)
    k_l, k_q = vehicle.linear_damping[i], vehicle.quadratic_damping[i]
    crossover = k_l / k_q if k_q > 0 else None
    speeds = [float(s) for s in run_speeds.get(axis, ()) if np.isfinite(s)]
    words = DRIVEN_AXES.get(axis)  # None: an axis the rig does not drive
    drive = words.load_name if words is not None else "load"
    run = words.kind if words is not None else "run"
    if axis not in MEASURED_AXES:
        test = (
            "not measured: values are placeholders (the rig identifies "
            f"{' and '.join(MEASURED_AXES)} only)"
        )
    elif kind == "added_mass":
        test = (
            f"a short, acceleration-dominated {run} with a large {drive} (heavy weight; the "
            "first second carries the inertia), or a pendulum free-decay run"
        )
    elif kind == "linear_damping":
        where = f" below {crossover:.3g} {unit}" if crossover else ""
        test = f"a low-{drive} {run} (slow speed{where}, where K_L·v dominates K_Q·v²)"
        if speeds and crossover and min(speeds) > crossover:
            reason.append(
                f"the runs' speeds {min(speeds):.3g}–{max(speeds):.3g} {unit} all lie above "
                f"K_L/K_Q = {crossover:.3g} {unit}, where K_Q·v² dominates"
            )
    else:
        where = f" well above K_L/K_Q = {crossover:.3g} {unit}" if crossover else ""
        test = f"a high-{drive} {run} (speeds{where}, where K_Q·v² dominates)"
        if speeds and crossover and max(speeds) < 3 * crossover:
            reason.append(
                f"the runs' speeds {min(speeds):.3g}–{max(speeds):.3g} {unit} barely reach "
                f"the quadratic regime (K_Q·v² > K_L·v above {crossover:.3g} {unit})"
            )
    for c in correlations:
        if name in (c["a"], c["b"]):
            other = c["b"] if c["a"] == name else c["a"]
            reason.append(
                f"it is correlated with {other} (ρ = {c['rho']:.2f}): runs over a wider "
                f"range of {drive}s separate them"
            )
            break
    return {"coefficient": name, "test": test, "reason": "; ".join(reason)}


def analyse_identified(
    vehicle: Vehicle6,
    results: Sequence[Mapping[str, Any]] = (),
    *,
    run_speeds: Mapping[str, Sequence[float]] | None = None,
    **kwargs: Any,
) -> SensitivityReport:
    """Plug the results into the vehicle, run :func:`estimation.vehicle.sensitivity.analyse` on it
    (``kwargs``) and attach the identifiability assessment."""
    identified = plug_results(vehicle, results)
    report = analyse(identified, **kwargs)
    return replace(report, identifiability=assess(report, identified, results, run_speeds))
