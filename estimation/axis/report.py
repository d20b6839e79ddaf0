"""Estimation report: JSON, Markdown summary and PNG plots (matplotlib Agg, no global state)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from estimation.axis.model import prepare
from estimation.axis.result import EstimationResult
from estimation.data.runs import RunData

UNITS = {
    "surge": {
        "inertia": "kg",
        "linear_damping": "N·s/m",
        "quadratic_damping": "N·s²/m²",
        "position": "m",
        "velocity": "m/s",
    },
    "yaw": {
        "inertia": "kg·m²",
        "linear_damping": "N·m·s/rad",
        "quadratic_damping": "N·m·s²/rad²",
        "position": "rad",
        "velocity": "rad/s",
    },
}


def _save(fig: Figure, path: Path) -> Path:
    FigureCanvasAgg(fig)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    return path


def _fit_plot(result: EstimationResult, runs, which: str, path: Path) -> Path:
    fit = result.fit_before if which == "before" else result.fit_after
    unit = UNITS[result.axis]["position"]
    fig = Figure(figsize=(8, 2.2 * len(runs) + 0.5))
    for i, (r, res) in enumerate(zip(runs, fit.residuals, strict=True)):
        ax = fig.add_subplot(len(runs), 1, i + 1)
        ax.plot(r.t, r.x, ".", ms=3, label="measured")
        ax.plot(r.t, r.x - res, "-", lw=1, label=f"model ({which})")
        ax.set_ylabel(f"{r.run_id} [{unit}]")
        ax.legend(loc="upper left", fontsize=7)
    fig.axes[-1].set_xlabel("t [s]")
    fig.suptitle(
        f"{result.axis}: measured vs model {which} (RMSE "
        f"{getattr(result, 'rmse_' + which):.3g} {unit})"
    )
    return _save(fig, path)


def _residual_plot(result: EstimationResult, runs, path: Path) -> Path:
    units = UNITS[result.axis]
    fig = Figure(figsize=(10, 6))
    for row, which in enumerate(("before", "after")):
        fit = result.fit_before if which == "before" else result.fit_after
        ax_t = fig.add_subplot(2, 2, 2 * row + 1)
        ax_v = fig.add_subplot(2, 2, 2 * row + 2)
        for r, res, v in zip(runs, fit.residuals, fit.velocities, strict=True):
            ax_t.plot(r.t, res, ".", ms=2, label=r.run_id)
            ax_v.plot(v, res, ".", ms=2)
        ax_t.set_ylabel(f"residual {which} [{units['position']}]")
        ax_t.set_xlabel("t [s]")
        ax_v.set_xlabel(f"model velocity [{units['velocity']}]")
        ax_t.legend(fontsize=6)
    return _save(fig, path)


def _markdown(result: EstimationResult) -> str:
    units = UNITS[result.axis]
    doc = result.to_json()
    lines = [
        f"# Estimation report — {result.axis}, {result.method}",
        "",
        f"Runs: {', '.join(result.runs)}",
        "",
        "## Coefficients (vehicle alone)",
        "",
        "| coefficient | before | after | unit |",
        "|---|---|---|---|",
    ]
    for name, after in result.coefficients.items():
        before = result.coefficients_before[name]
        lines.append(
            f"| {name} | {before.value:.6g} ± {before.std:.2g} | "
            f"{after.value:.6g} ± {after.std:.2g} | {units[name]} |"
        )
    lines += ["", "## Effects found", ""]
    if result.effects:
        lines += [f"- `{e.name}` = {e.value:.6g} ± {e.std:.2g} {e.unit}" for e in result.effects]
    else:
        lines.append("- none (the base model explains the data)")
    for group, advice in zip(result.ambiguous, result.advice, strict=False):
        lines.append(f"- ambiguous: {', '.join(group)} — {advice}")
    lines += [
        "",
        "## Error before and after",
        "",
        f"| run | RMSE before [{units['position']}] | RMSE after [{units['position']}] |",
        "|---|---|---|",
    ]
    for rid in result.runs:
        lines.append(
            f"| {rid} | {result.rmse_per_run_before[rid]:.4g} | "
            f"{result.rmse_per_run_after[rid]:.4g} |"
        )
    lines.append(f"| **all** | {result.rmse_before:.4g} | {result.rmse_after:.4g} |")
    ev = doc["evidence"]
    cv = [f"{x:.4g}" if x is not None else "n/a" for x in (result.cv_before, result.cv_after)]
    lines += [
        "",
        "## Evidence",
        "",
        f"BIC {ev['bic_before']:.1f} → {ev['bic_after']:.1f}; "
        f"leave-one-run-out RMSE {cv[0]} → {cv[1]} {units['position']}",
        "",
        "| round | effect | ΔBIC | LORO RMSE after | Ljung–Box Q before → after | kept | reason |",
        "|---|---|---|---|---|---|---|",
    ]
    for s in result.steps:
        cv = "—" if s.cv_after is None else f"{s.cv_after:.4g}"
        lines.append(
            f"| {s.round} | {s.effect} | {s.delta_bic:.1f} | {cv} | {s.ljung_box_before:.1f} → "
            f"{s.ljung_box_after:.1f} | {'yes' if s.accepted else 'no'} | {s.reason} |"
        )
    if result.warnings:
        lines += ["", "## Warnings", ""] + [f"- {w}" for w in result.warnings]
    return "\n".join(lines) + "\n"


def write_report(
    result: EstimationResult, runs: Sequence[RunData], directory: str | Path
) -> list[Path]:
    """Write result.json, report.md and PNG plots (fit before/after, residuals) to directory."""
    if result.fit_before is None or result.fit_after is None:
        raise ValueError("result: got a result without fits, allowed: one made by estimate()")
    if tuple(r.run_id for r in runs) != result.runs:
        raise ValueError(
            f"runs: got {[r.run_id for r in runs]}, allowed: the result's runs "
            f"{list(result.runs)} in the same order"
        )
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    prepared = [prepare(r) for r in runs]
    json_path = out / "result.json"
    json_path.write_text(json.dumps(result.to_json(), indent=2, ensure_ascii=False))
    md_path = out / "report.md"
    md_path.write_text(_markdown(result), encoding="utf-8")
    paths = [json_path, md_path]
    paths.append(_fit_plot(result, prepared, "before", out / "fit_before.png"))
    paths.append(_fit_plot(result, prepared, "after", out / "fit_after.png"))
    paths.append(_residual_plot(result, prepared, out / "residuals.png"))
    return paths
