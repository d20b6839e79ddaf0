"""The cross-check as files: a Markdown report (table, verdict, figures, common factor,
RMSE) and one figure of each coefficient from both ways of driving the rig, with units."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

from estimation.axis.crosscheck_comparison import LABELS, SPEED_UNITS, UNITS
from estimation.axis.drive_crosscheck import CrossCheck


def _pm(value: float, std: float) -> str:
    """``value ± σ``, or the value with "σ not known"."""
    return f"{value:.5g} ± {std:.2g}" if math.isfinite(std) else f"{value:.5g} (σ not known)"


def markdown(check: CrossCheck, figures: Sequence[tuple[str, Path]] = ()) -> str:
    """The cross-check as a Markdown report (table, verdict, figures, common factor, RMSE,
    diagnosis)."""
    units = UNITS[check.axis]
    lines = [
        f"# Cross-check, {check.axis}: weight-driven vs thruster-driven",
        "",
        f"Weight-driven result #{check.weight_result_id} (runs {', '.join(check.weight_runs)});"
        f" thruster-driven result #{check.thruster_result_id} "
        f"(runs {', '.join(check.thruster_runs)}). σ is σ_total (fit and thrust calibration).",
        "",
        "| coefficient | weight | thrusters | Δ | z | verdict |",
        "|---|---|---|---|---|---|",
    ]
    for c in check.all_comparisons:
        # an undecided coefficient's z is shown in parentheses: computed, not judged
        z = "—" if not math.isfinite(c.z) else f"{c.z:+.2f}" if c.decided else f"({c.z:+.2f})"
        shown = c.verdict if c.decided else "**undecided**"
        lines.append(
            f"| {c.label(check.axis)} ({units[c.name]}) | {_pm(c.weight, c.weight_std)} | "
            f"{_pm(c.thruster, c.thruster_std)} | {c.difference:+.3g} | {z} | {shown} |"
        )
    undecided = [c for c in check.all_comparisons if not c.decided]
    if undecided:
        lines.append("")
        for reason in dict.fromkeys(c.undecided for c in undecided):
            names = ", ".join(c.label(check.axis) for c in undecided if c.undecided == reason)
            lines.append(f"Undecided {names}: {reason}.")
    overall = check.verdict
    if check.undecided and overall != "undecided":
        overall += f" (on what both sets decide; {', '.join(LABELS[n] for n in check.undecided)}"
        overall += " undecided)"
    lines += ["", f"Overall: **{overall}**", ""]
    if figures:
        from estimation.figures import figure_links

        lines += figure_links(figures)
    if check.factor is not None:
        f = check.factor
        lines.append(
            f"Common factor thruster/weight: k = {f.k:.4f} ± {f.std:.4f} over "
            f"{', '.join(LABELS[n] for n in f.used)} (χ² = {f.chi2:.2f}, dof {f.dof}, "
            f"p = {f.p_value:.3g}); delivered/calibrated thrust 1/k = "
            f"{f.thrust_factor:.4f} ± {f.thrust_factor_std:.4f}"
        )
        lines.append("")
    lines.append("| | RMSE before effect search | RMSE after |")
    lines.append("|---|---|---|")
    for side in ("weight", "thruster"):
        r = check.rmse[side]
        lines.append(f"| {side} | {_fmt(r['before'])} | {_fmt(r['after'])} |")
    lines += ["", "## Diagnosis", ""]
    lines += [f"- {d}" for d in check.diagnosis]
    if check.warnings:
        lines += ["", "## Warnings", ""] + [f"- {w}" for w in check.warnings]
    return "\n".join(lines) + "\n"


def _fmt(x: float | None) -> str:
    return "—" if x is None else f"{x:.3g}"


def write_crosscheck_report(check: CrossCheck, folder: str | Path) -> list[Path]:
    """``report.md`` and the figure ``crosscheck`` (150 dpi PNG and SVG): each coefficient
    weight vs thrusters with ±1σ_total bars, its name and unit on the y axis; undecided ones
    titled so, the combined damping as a fourth panel when compared."""
    from estimation.figures import new_figure, save_figure

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    shown = check.all_comparisons
    fig = new_figure(4.6, max(10.0, 3.4 * len(shown)))
    fig.subplots_adjust(wspace=0.45)
    units = UNITS[check.axis]
    for i, c in enumerate(shown):
        ax = fig.add_subplot(1, len(shown), i + 1)
        ax.errorbar(
            [0, 1],
            [c.weight, c.thruster],
            yerr=[_bar(c.weight_std), _bar(c.thruster_std)],
            fmt="o",
            capsize=6,
            color="k",
        )
        ax.set_xticks([0, 1], ["weight-driven", "thruster-driven"])
        ax.set_xlim(-0.6, 1.6)
        ax.set_ylabel(f"{LABELS[c.name]} [{units[c.name]}]")
        if c.speed is not None:
            ax.set_xlabel(f"at |v| = {c.speed:.3g} {SPEED_UNITS[check.axis]}", fontsize=9)
        if c.decided:
            ax.set_title(f"{LABELS[c.name]}: z = {c.z:+.1f} ({c.verdict})", fontsize=10)
        else:
            ax.set_title(f"{LABELS[c.name]}: UNDECIDED", fontsize=10, color="tab:red")
            ax.set_xlabel("a set cannot separate K_L from K_Q", fontsize=9, color="tab:red")
    fig.suptitle(
        f"{check.axis}: weight- vs thruster-driven coefficients (±1σ_total), "
        f"overall: {check.verdict}",
        fontsize=11,
    )
    paths = save_figure(fig, out, "crosscheck")
    caption = "Coefficients from weight-driven and thruster-driven runs, ±1σ_total"
    md = out / "report.md"
    md.write_text(markdown(check, [(caption, paths[0])]), encoding="utf-8")
    return [md, *paths]


def _bar(s: float) -> float:
    return s if math.isfinite(s) else 0.0
