"""Pendulum report: result.json, report.md and PNGs (measured vs model before/after the
effect search, residual vs time, peak magnitudes with exponential and linear envelopes)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from estimation.axis.report import _save
from estimation.pendulum.estimate import UNITS, PendulumResult

METHOD_ORDER = (
    "output-error",
    "damped-fit",
    "log-decrement",
    "equation-error",
    "equation-error-linear",
)


def _fit_plot(result: PendulumResult, which: str, path: Path) -> Path:
    fit = result.fit_before if which == "before" else result.fit_after
    n = len(result.decays)
    fig = Figure(figsize=(8, 2.4 * n + 0.5))
    for i, (d, res) in enumerate(zip(result.decays, fit.residuals, strict=True)):
        ax = fig.add_subplot(n, 1, i + 1)
        ax.plot(d.t, d.phi, ".", ms=3, label="measured")
        ax.plot(d.t, d.phi - res, "-", lw=1, label=f"model ({which})")
        ax.set_ylabel(f"{d.run_id} φ [rad]")
        ax.legend(loc="upper right", fontsize=7)
    fig.axes[-1].set_xlabel("t [s]")
    effects = ", ".join(fit.effects) or "base model"
    rmse = result.rmse_before if which == "before" else result.rmse_after
    fig.suptitle(f"measured vs model {which} ({effects}; RMSE {rmse:.3g} rad)")
    return _save(fig, path)


def _residual_plot(result: PendulumResult, path: Path) -> Path:
    fig = Figure(figsize=(8, 5))
    for row, which in enumerate(("before", "after")):
        fit = result.fit_before if which == "before" else result.fit_after
        ax = fig.add_subplot(2, 1, row + 1)
        for d, res in zip(result.decays, fit.residuals, strict=True):
            ax.plot(d.t, res, ".", ms=2, label=d.run_id)
        ax.set_ylabel(f"residual {which} [rad]")
        ax.legend(fontsize=6)
    fig.axes[-1].set_xlabel("t [s]")
    return _save(fig, path)


def _peaks_plot(result: PendulumResult, path: Path) -> Path:
    fig = Figure(figsize=(8, 4))
    ax = fig.add_subplot(1, 1, 1)
    for rid, p in result.peaks.items():
        ax.plot(p.times, p.amplitudes, "o", label=f"{rid} |peak|")
        tt = np.linspace(p.times[0], p.times[-1], 100)
        ax.plot(tt, p.exp_c * np.exp(-p.exp_k * tt), "-", lw=1, label=f"{rid} C·e^(−Kt)")
        ax.plot(tt, p.lin_a0 - p.lin_rate * tt, "--", lw=1, label=f"{rid} linear")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("|peak − midline| [rad]")
    ax.set_title("Peak magnitudes: exponential (viscous) vs linear (dry friction) envelope")
    ax.legend(fontsize=7)
    return _save(fig, path)


def _pm(est: dict | None) -> str:
    if not est or est.get("value") is None:
        return "—"
    std = est.get("std")
    return f"{est['value']:.5g} ± {std:.2g}" if std is not None else f"{est['value']:.5g}"


def pendulum_markdown(result: PendulumResult) -> str:
    """The Markdown summary: methods side by side, effects, error before/after, evidence."""
    doc = result.to_json()
    lines = [
        f"# Pendulum free-decay report — {result.axis}, headline method {result.method}",
        "",
        f"Runs: {', '.join(result.runs)}",
        "",
        "## Coefficients of the vehicle (headline)",
        "",
        "| coefficient | before effects | after effects | unit |",
        "|---|---|---|---|",
    ]
    for name, est in doc["coefficients"].items():
        before = doc["coefficients_before"].get(name)
        lines.append(f"| {name} | {_pm(before)} | {_pm(est)} | {UNITS[name]} |")
    lines += [
        "",
        "## Methods side by side",
        "",
        "| run | method | α [kg] | β [N·s/m] | γ [kg/m] | e [rad²] | RMSE [rad] |",
        "|---|---|---|---|---|---|---|",
    ]
    rows = sorted(doc["methods"], key=lambda m: (m["run_id"], METHOD_ORDER.index(m["method"])))
    for m in rows:
        lines.append(
            f"| {m['run_id']} | {m['method']} | {_pm(m['added_mass'])} | "
            f"{_pm(m['linear_damping'])} | {_pm(m['quadratic_damping'])} | "
            f"{m['mse']:.3g} | {m['rmse']:.3g} |"
            if m["mse"] is not None
            else f"| {m['run_id']} | {m['method']} | {_pm(m['added_mass'])} | "
            f"{_pm(m['linear_damping'])} | {_pm(m['quadratic_damping'])} | — | — |"
        )
    lines += ["", "## Effects found", ""]
    if result.effects:
        lines += [f"- `{e.name}` = {e.value:.5g} ± {e.std:.2g} {e.unit}" for e in result.effects]
    else:
        lines.append("- none (the base model explains the data)")
    for group in result.ambiguous:
        lines.append(f"- ambiguous: {', '.join(group)}")
    wb, wa = doc["diagnostics"]["ljung_box_before"], doc["diagnostics"]["ljung_box_after"]
    ev = doc["evidence"]
    lines += [
        "",
        "## Error before and after",
        "",
        "| run | RMSE before [rad] | RMSE after [rad] |",
        "|---|---|---|",
    ]
    for rid in result.runs:
        lines.append(
            f"| {rid} | {result.rmse_per_run_before[rid]:.4g} | "
            f"{result.rmse_per_run_after[rid]:.4g} |"
        )
    lines += [
        f"| **all** | {result.rmse_before:.4g} | {result.rmse_after:.4g} |",
        "",
        f"Ljung–Box Q {wb['q']:.1f} (p {wb['p_value']:.2g}) → "
        f"{wa['q']:.1f} (p {wa['p_value']:.2g}); "
        f"BIC {ev['bic_before']:.1f} → {ev['bic_after']:.1f}",
        "",
        "| round | effect | ΔBIC | Ljung–Box Q before → after | kept | reason |",
        "|---|---|---|---|---|---|",
    ]
    for s in result.steps:
        lines.append(
            f"| {s.round} | {s.effect} | {s.delta_bic:.1f} | {s.ljung_box_before:.1f} → "
            f"{s.ljung_box_after:.1f} | {'yes' if s.accepted else 'no'} | {s.reason} |"
        )
    if result.warnings:
        lines += ["", "## Warnings", ""] + [f"- {w}" for w in result.warnings]
    if result.advice:
        lines += ["", "## Advice", ""] + [f"- {a}" for a in result.advice]
    return "\n".join(lines) + "\n"


def write_pendulum_report(result: PendulumResult, directory: str | Path) -> list[Path]:
    """Write result.json, report.md, fit_before/fit_after/residuals/peaks PNGs to directory."""
    if not result.decays:
        raise ValueError(
            "result: got a result without its decays, allowed: one made by estimate_pendulum()"
        )
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    json_path = out / "result.json"
    json_path.write_text(json.dumps(result.to_json(), indent=2, ensure_ascii=False))
    md_path = out / "report.md"
    md_path.write_text(pendulum_markdown(result), encoding="utf-8")
    return [
        json_path,
        md_path,
        _fit_plot(result, "before", out / "fit_before.png"),
        _fit_plot(result, "after", out / "fit_after.png"),
        _residual_plot(result, out / "residuals.png"),
        _peaks_plot(result, out / "peaks.png"),
    ]
