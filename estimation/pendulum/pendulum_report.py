"""Pendulum report: result.json, report.md (the one report, ``fit_report.report_markdown``, with
the methods side by side) and the figures:
measured vs model before/after the effect search against time from release with residuals,
residual vs angular rate, peak magnitudes with exponential and linear envelopes."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from estimation.figures import (
    TIME_LABEL,
    FitRow,
    effects_text,
    fit_over_measurements,
    new_figure,
    prefixed,
    run_label,
    save_figure,
)
from estimation.fit_report import report_markdown, write_result_and_markdown
from estimation.motion.output_error_fit import MotionFit
from estimation.pendulum.methods import UNCERTAINTY_NOTE
from estimation.pendulum.pendulum_estimate import PendulumResult
from estimation.stats.method_bias import DISAGREES_SIGMAS
from estimation.uncertainty.text import value_with_u

COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")

METHOD_ORDER = (
    "output-error",
    "damped-fit",
    "log-decrement",
    "equation-error",
    "equation-error-linear",
)


def run_labels(result: PendulumResult) -> dict[str, str]:
    """``run 1 (a1b2c3d4), swing 12.3°``: order, id prefix and the largest swing angle."""
    return {
        d.run_id: run_label(i, d.run_id, f"swing {np.degrees(np.max(np.abs(d.phi))):.3g}°")
        for i, d in enumerate(result.section.decays, start=1)
    }


def _fits(result: PendulumResult) -> tuple[MotionFit, MotionFit]:
    """The fits before and after the search (a result made by ``estimate_pendulum``)."""
    if result.fit_before is None or result.fit_after is None:
        raise ValueError(
            "result: got a result without its fits, allowed: one made by estimate_pendulum()"
        )
    return result.fit_before, result.fit_after


def fit_figure(result: PendulumResult, labels: dict[str, str]) -> Figure:
    """The fit over the measurements (:func:`estimation.figures.fit_over_measurements`)."""
    # the samples fitted: each swing as the engine windowed it (it ends where the body
    # comes to rest), on the time from its release
    fitted = result.records or tuple(d.record() for d in result.section.decays)
    before, after = _fits(result)
    rows = [
        FitRow(
            labels[d.run_id],
            np.asarray(r.t, dtype=float) - d.t[0],
            np.asarray(r.x, dtype=float),
            before.residuals[i],
            after.residuals[i],
        )
        for i, (d, r) in enumerate(zip(result.section.decays, fitted, strict=True))
    ]
    title = (
        f"pendulum, {result.method}: before = {effects_text(before.effects)} "
        f"(RMSE {result.rmse_before:.3g} rad), after = "
        f"{effects_text(after.effects)} (RMSE {result.rmse_after:.3g} rad)"
    )
    return fit_over_measurements(rows, "angle φ", "rad", title, legend_loc="upper right")


def rate_figure(result: PendulumResult, labels: dict[str, str]) -> Figure:
    """Residual against the model's angular rate, before and after the effect search: dry
    friction shows as a step at zero rate, quadratic damping as an odd curve."""
    fig = new_figure(4.6)
    axes = fig.subplots(1, 2)
    for ax, which, fit in zip(axes, ("before", "after"), _fits(result), strict=True):
        scale, unit = prefixed(fit.residuals, "rad")
        for d, res, rate in zip(result.section.decays, fit.residuals, fit.velocities, strict=True):
            ax.plot(rate, res / scale, ".", ms=3, label=labels[d.run_id])
        ax.axhline(0.0, color="0.6", lw=0.8)
        ax.set_title(f"{which}: {effects_text(fit.effects)}", loc="left", fontsize=10)
        ax.set_xlabel("model angular rate φ̇ [rad/s]")
        ax.set_ylabel(f"residual [{unit}]")
    axes[1].legend(loc="best", fontsize=8)
    fig.suptitle("pendulum: residual vs angular rate (a pattern = a missing effect)", fontsize=11)
    return fig


def peaks_figure(result: PendulumResult, labels: dict[str, str]) -> Figure:
    """Peak magnitudes with the exponential (viscous) and linear (dry friction) envelopes."""
    fig = new_figure(5.0)
    ax = fig.add_subplot(1, 1, 1)
    start = {d.run_id: float(d.t[0]) for d in result.section.decays}
    for (rid, p), colour in zip(result.section.peaks.items(), COLOURS, strict=False):
        t0 = start.get(rid, 0.0)
        tt = np.linspace(p.times[0], p.times[-1], 100)
        ax.plot(p.times - t0, p.amplitudes, "o", ms=4, color=colour, label=f"{labels[rid]}: |peak|")
        ax.plot(tt - t0, p.exp_c * np.exp(-p.exp_k * tt), "-", lw=1.2, color=colour,
                label="C·e^(−Kt) (viscous)")  # fmt: skip
        ax.plot(tt - t0, p.lin_a0 - p.lin_rate * tt, ":", lw=1.5, color=colour,
                label="A₀ − r·t (dry friction)")  # fmt: skip
    ax.set_xlabel(TIME_LABEL)
    ax.set_ylabel("|peak − midline| [rad]")
    fig.suptitle(
        "pendulum: peak magnitudes, exponential (viscous) vs linear (dry friction) envelope",
        fontsize=11,
    )
    ax.legend(fontsize=8, ncols=max(1, len(result.section.peaks)))
    return fig


def pendulum_markdown(
    result: PendulumResult,
    figures: Sequence[tuple[str, Path]] = (),
    budget: Mapping[str, Any] | None = None,
) -> str:
    """The one report (``fit_report.report_markdown``); the pendulum's own section: the
    methods side by side, per run."""
    labels = run_labels(result) if result.section.decays else {r: r for r in result.runs}
    lines = [
        "",
        "## Methods side by side",
        "",
        "Each value ± σ; a seed method's row with its own U (95 %, k = t_0.975(ν)): "
        + UNCERTAINTY_NOTE
        + "; the output-error row's U is its uncertainty budget's. *vs output error*: the "
        f"row's largest z from the output-error row of its run; beyond {DISAGREES_SIGMAS:g} σ "
        "the warnings name it.",
        "",
        "| run | method | α [kg] | β [N·s/m] | γ [kg/m] | e [rad²] | RMSE [rad] "
        "| vs output error |",
        "|---|---|---|---|---|---|---|---|",
    ]
    rows = sorted(
        (m.to_json() for m in result.section.methods),
        key=lambda m: (m["run_id"], METHOD_ORDER.index(m["method"])),
    )
    for m in rows:
        shown = [value_with_u(m[k]) for k in ("added_mass", "linear_damping", "quadratic_damping")]
        errors = "— | —" if m["mse"] is None else f"{m['mse']:.3g} | {m['rmse']:.3g}"
        lines.append(
            f"| {m['run_id']} | {m['method']} | {' | '.join(shown)} | {errors} | "
            f"{m['vs_output_error']} |"
        )
    return report_markdown(
        result,
        f"Pendulum free-decay report — {result.axis}, headline method {result.method}",
        labels,
        figures,
        lines,
        coefficients_heading="Coefficients of the vehicle (headline)",
        budget=budget,
    )


def write_pendulum_report(
    result: PendulumResult, directory: str | Path, budget: Mapping[str, Any] | None = None
) -> list[Path]:
    """Write result.json, report.md and the figures ``fit``, ``residual_vs_rate`` and
    ``peaks`` (each a 150 dpi PNG and an SVG) to directory; ``budget``: the result's
    uncertainty budget document, shown in report.md. Returns the paths written."""
    if not result.section.decays:
        raise ValueError(
            "result: got a result without its decays, allowed: one made by estimate_pendulum()"
        )
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    labels = run_labels(result)
    fit = save_figure(fit_figure(result, labels), out, "fit")
    rate = save_figure(rate_figure(result, labels), out, "residual_vs_rate")
    peaks = save_figure(peaks_figure(result, labels), out, "peaks")
    figures = [
        ("Measured vs model before and after the effect search, and residuals, per run", fit[0]),
        ("Residual vs model angular rate, before and after", rate[0]),
        ("Peak magnitudes with the viscous and dry-friction envelopes", peaks[0]),
    ]
    markdown = pendulum_markdown(result, figures, budget)
    written = write_result_and_markdown(out, result, markdown, budget)
    return [*written, *fit, *rate, *peaks]
