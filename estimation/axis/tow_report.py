"""Estimation report: result.json, report.md (summary table first, figures linked) and the
figures: measured vs model before/after against time from release with residuals, and the
force-domain residual against velocity (see docs/estimation.md, "Report")."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from estimation.axis.force_residual import force_residuals
from estimation.axis.prepared_run import PreparedRun, prepare
from estimation.axis.tow_section import UNITS, TowResult
from estimation.data.run_arrays import RunData
from estimation.figures import (
    FitRow,
    effects_text,
    fit_over_measurements,
    new_figure,
    prefixed,
    run_label,
    save_figure,
    signed,
)
from estimation.fit_report import report_markdown, write_result_and_markdown

AXIS_LABELS = {
    "surge": {"position": "position", "velocity": "velocity", "drive": "force", "force": "N"},
    "yaw": {"position": "angle", "velocity": "yaw rate", "drive": "torque", "force": "N·m"},
}


def run_labels(runs: Sequence[PreparedRun], axis: str) -> dict[str, str]:
    """Short label per run: ``run 1 (a1b2c3d4), +15 N`` (weight-driven) or
    ``run 2 (…), thrusters, mean +12 N`` (thruster-driven)."""
    unit = AXIS_LABELS[axis]["force"]
    labels = {}
    for i, r in enumerate(runs, start=1):
        if r.constant_drive is not None:
            detail = signed(r.constant_drive, unit)
        else:
            moving = r.t > r.t_release
            mean = float(np.mean(r.drive[moving])) if moving.any() else 0.0
            detail = f"thrusters, mean {signed(mean, unit)}"
        labels[r.run_id] = run_label(i, r.run_id, detail)
    return labels


def fit_figure(result: TowResult, runs: Sequence[PreparedRun], labels: dict[str, str]) -> Figure:
    """The fit over the measurements (:func:`estimation.figures.fit_over_measurements`)."""
    units, names = UNITS[result.axis], AXIS_LABELS[result.axis]
    before, after = result.fit_before, result.fit_after
    assert before is not None and after is not None
    rows = [
        FitRow(labels[r.run_id], r.t - r.t_release, r.x, before.residuals[i], after.residuals[i])
        for i, r in enumerate(runs)
    ]
    unit = units["position"]
    title = (
        f"{result.subject}, {result.method}: before = {effects_text(before.effects)} "
        f"(RMSE {result.rmse_before:.3g} {unit}), after = "
        f"{effects_text(after.effects)} (RMSE {result.rmse_after:.3g} {unit})"
    )
    return fit_over_measurements(rows, names["position"], unit, title)


def force_figure(result: TowResult, runs: Sequence[PreparedRun], labels: dict[str, str]) -> Figure:
    """Force-domain residual (the force the model misses) against model velocity, before and
    after the effect search, moving samples of every run."""
    units, names = UNITS[result.axis], AXIS_LABELS[result.axis]
    fig = new_figure(4.6)
    axes = fig.subplots(1, 2)
    for ax, which in zip(axes, ("before", "after"), strict=True):
        fit = result.fit_before if which == "before" else result.fit_after
        assert fit is not None
        moving = [r.t > r.t_release for r in runs]
        forces = [f[m] for f, m in zip(force_residuals(fit, runs), moving, strict=True)]
        scale, unit = prefixed(forces, names["force"])
        for r, force, v, m in zip(runs, forces, fit.velocities, moving, strict=True):
            ax.plot(v[m], force / scale, ".", ms=3, label=labels[r.run_id])
        ax.axhline(0.0, color="0.6", lw=0.8)
        ax.set_title(f"{which}: {effects_text(fit.effects)}", loc="left", fontsize=10)
        ax.set_xlabel(f"model {names['velocity']} [{units['velocity']}]")
        ax.set_ylabel(f"{names['drive']} residual [{unit}]")
    axes[1].legend(loc="best", fontsize=8)
    fig.suptitle(
        f"{result.subject}: force-domain residual vs velocity (a pattern = a missing effect)",
        fontsize=11,
    )
    return fig


def _markdown(
    result: TowResult,
    labels: dict[str, str],
    figures: Sequence[tuple[str, Path]],
    budget: Mapping[str, Any] | None = None,
) -> str:
    """The one report (``fit_report.report_markdown``); the tow's own section: the samples
    each run's fit left out (values or times that could not be trusted)."""
    left_out = [
        f"- {labels.get(rid, rid)}: {gap.describe()}"
        for rid, w in result.section.windows.items()
        for gap in w.left_out
    ]
    return report_markdown(
        result,
        f"Estimation report — {result.subject}, {result.method}",
        labels,
        figures,
        ["", "## Samples left out", "", *left_out] if left_out else [],
        coefficients_heading="Coefficients (vehicle alone)",
        budget=budget,
    )


def write_report(
    result: TowResult,
    runs: Sequence[RunData],
    directory: str | Path,
    budget: Mapping[str, Any] | None = None,
) -> list[Path]:
    """Write result.json, report.md and the figures (``fit`` and ``force_residual``, each as
    a 150 dpi PNG and an SVG) to directory; ``budget``: the result's uncertainty budget
    document, shown in report.md. Returns the paths written."""
    if result.fit_before is None or result.fit_after is None:
        raise ValueError("result: got a result without fits, allowed: one made by estimate()")
    if tuple(r.run_id for r in runs) != result.runs:
        raise ValueError(
            f"runs: got {[r.run_id for r in runs]}, allowed: the result's runs "
            f"{list(result.runs)} in the same order"
        )
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    # the samples the result fitted: a release found in the data was refined by the fit and
    # may fall on the other side of a sample (one more or one fewer sample than ``runs``)
    fitted = {rid: w.t_release for rid, w in result.section.windows.items()}
    prepared = [prepare(replace(r, t_release=fitted.get(r.run_id, r.t_release))) for r in runs]
    labels = run_labels(prepared, result.axis)
    fit = save_figure(fit_figure(result, prepared, labels), out, "fit")
    force = save_figure(force_figure(result, prepared, labels), out, "force_residual")
    figures = [
        ("Measured vs model before and after the effect search, and residuals, per run", fit[0]),
        ("Force-domain residual vs model velocity, before and after", force[0]),
    ]
    markdown = _markdown(result, labels, figures, budget)
    written = write_result_and_markdown(out, result, markdown, budget)
    return [*written, *fit, *force]
