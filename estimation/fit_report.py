"""The one report of every estimate (``report_markdown``), whose sections every kind's result
fills alike — what the record determines, the summary, the figures, the coefficients before
and after, the kind's own sections, the repeats, the effects found, the error before and
after per run and the search's evidence — and the result.json + report.md pair. A kind's
report module gives the title, its figures and its own sections."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from estimation.figures import figure_links
from estimation.motion.equivalent import EquivalentDamping
from estimation.motion.estimation_result import EffectEstimate, EstimationResult
from estimation.motion.term_search import Step
from estimation.motion.well_determined import Combination
from estimation.stats.acceptance_rules import RuleSet
from estimation.stats.misfit import ABOVE_FLOOR, WHITE_P
from estimation.uncertainty.text import (
    budget_sources_markdown,
    budget_summary_markdown,
    repeats_markdown,
)


def report_markdown(
    result: EstimationResult[Any],
    title: str,
    labels: Mapping[str, str],
    figures: Sequence[tuple[str, Path]] = (),
    own_sections: Sequence[str] = (),
    coefficients_heading: str = "Coefficients",
    budget: Mapping[str, Any] | None = None,
) -> str:
    """The Markdown report of ``result``, every kind's sections in one order: ``title``, what
    the record determines (B_e by amplitude where the result has it), the summary, the
    ``budget``'s value ± U of each quantity (where the estimate has a budget), the figures,
    the coefficients before and after the search (and those given), then the kind's
    ``own_sections`` (lines), the repeats, the effects found with the ambiguity, the error
    before and after per run (``labels``: each run's label in the figures), the evidence and
    the budget's sources."""
    unit = result.units.get("position", "")
    digits = 6
    lines = [f"# {title}", ""]
    lines += determined_section(result.well_determined, result.equivalent, unit)
    lines += ["## Summary", "", "| quantity | value ± σ | unit |", "|---|---|---|"]
    lines += [
        f"| {result.labels.get(name, name)} | {value_and_sigma(c.value, c.std)} | {c.unit} |"
        for name, c in result.coefficients.items()
    ]
    lines += summary_rows(result, unit, labels)
    if budget:  # U beside the σ above: the fit's σ is one of the budget's sources
        lines += budget_summary_markdown(budget, result.labels)
    if figures:
        lines += figure_links(figures)
    lines += [
        f"## {coefficients_heading}",
        "",
        "| coefficient | before the search | after | unit |",
        "|---|---|---|---|",
    ]
    for name, after in result.coefficients.items():
        before = result.coefficients_before.get(name)
        shown = "—" if before is None else value_and_sigma(before.value, before.std, digits)
        lines.append(
            f"| {result.labels.get(name, name)} | {shown} | "
            f"{value_and_sigma(after.value, after.std, digits)} | {after.unit} |"
        )
    lines += [
        f"| {name} (given) | {c.value:.{digits}g} | {c.value:.{digits}g} | {c.unit} |"
        for name, c in result.known.items()
    ]
    if result.possibly_biased:
        lines += ["", "**The coefficients may be biased** (the warnings say why)."]
    lines += list(own_sections)
    if result.repeats is not None and result.repeats.conditions:  # N per condition, outliers
        lines += ["", *repeats_markdown(result.repeats.to_json())]
    lines += effects_found(result.effects, digits=digits)
    lines += ambiguity_lines(result.ambiguous, result.advice)
    lines += error_before_after(result, unit, labels)
    lines += evidence_section(result, unit)
    if budget:
        lines += budget_sources_markdown(budget, result.labels)
    return "\n".join(lines) + "\n"


def evidence_section(result: EstimationResult[Any], unit: str) -> list[str]:
    """The "Evidence" section: BIC, the leave-one-record-out RMSE and the residual's Ljung–Box
    Q before → after the search, then every trial (``evidence_table``)."""
    cv = [f"{x:.4g}" if x is not None else "n/a" for x in (result.cv_before, result.cv_after)]
    bic = [
        f"{f.bic:.1f}" if f is not None and math.isfinite(f.bic) else "n/a"
        for f in (result.fit_before, result.fit_after)
    ]
    q = [
        f"{w.q_statistic:.1f} (p {w.p_value:.2g})" if math.isfinite(w.q_statistic) else "n/a"
        for w in (result.whiteness_before, result.whiteness_after)
    ]
    return [
        "",
        "## Evidence",
        "",
        f"BIC {bic[0]} → {bic[1]}; leave-one-record-out RMSE {cv[0]} → {cv[1]} {unit}; "
        f"Ljung–Box Q {q[0]} → {q[1]}{misfit_verdict(result)}",
        "",
        *evidence_table(result.rules, result.steps, unit),
    ]


def misfit_verdict(result: EstimationResult[Any]) -> str:
    """What the final residual says, by the misfit rule every kind uses
    (``estimation.stats.misfit``): a sentence after the Ljung–Box Q, so a Q that rejects
    whiteness is read as the rule reads it ("" where nothing judged the residual)."""
    if result.possibly_biased is None:
        return ""
    if result.possibly_biased:
        return (
            ". The residual holds structure no kept term explains: the coefficients may be "
            "biased by it (the warnings say how)."
        )
    w = result.whiteness_after
    if w is not None and math.isfinite(w.p_value) and w.p_value < WHITE_P:
        return (
            f". The residual is not white (p < {WHITE_P:g}) but within {ABOVE_FLOOR:g}× its "
            "noise floor: an encoder's quantization or a sensor's filtering correlates a "
            "residual that lacks no force, and the misfit rule reads it as noise "
            "(docs/estimation.md)."
        )
    return ". The misfit rule reads the residual as noise."


def summary_rows(result: EstimationResult[Any], unit: str, labels: Mapping[str, str]) -> list[str]:
    """The summary table's rows after the coefficients (effects, RMSE in ``unit``, warnings),
    the warnings in full, then which run each figure label stands for."""
    lines = [
        f"| effect `{e.name}` | {value_and_sigma(e.value, e.std)} | {e.unit} |"
        for e in result.effects
    ]
    if not result.effects:
        lines.append("| effects found | none (the base model explains the data) | |")
    lines += [
        f"| RMSE before → after | {result.rmse_before:.3g} → {result.rmse_after:.3g} | {unit} |",
        *(
            [f"| noise floor | {result.noise:.3g} | {unit} |"]
            if result.noise is not None and math.isfinite(result.noise)
            else []
        ),
        f"| warnings | {len(result.warnings)} (below) | |"
        if result.warnings
        else "| warnings | none | |",
        "",
    ]
    lines += [f"- **Warning:** {w}" for w in result.warnings]
    if result.warnings:
        lines.append("")
    lines += ["| run (as labelled in the figures) | run id |", "|---|---|"]
    lines += [f"| {labels[rid]} | `{rid}` |" for rid in result.runs]
    return [*lines, ""]


def effects_found(effects: tuple[EffectEstimate, ...], digits: int) -> list[str]:
    """The "Effects found" section: each effect's value ± σ (``digits`` significant)."""
    lines = ["", "## Effects found", ""]
    if effects:
        lines += [
            f"- `{e.name}` = {value_and_sigma(e.value, e.std, digits)} {e.unit}" for e in effects
        ]
    else:
        lines.append("- none (the base model explains the data)")
    return lines


def ambiguity_lines(groups: Sequence[Sequence[str]], advice: Sequence[str]) -> list[str]:
    """Under "Effects found", every kind alike: each group of terms the records cannot tell
    apart with the experiment that would (the search gives one advice per group, in order),
    then any further advice the kind adds."""
    lines = [f"- ambiguous: {', '.join(g)} — {a}" for g, a in zip(groups, advice, strict=False)]
    lines += [f"- ambiguous: {', '.join(g)}" for g in groups[len(advice) :]]
    return lines + [f"- advice: {a}" for a in advice[len(groups) :]]


def error_before_after(
    result: EstimationResult[Any], unit: str, labels: Mapping[str, str]
) -> list[str]:
    """The "Error before and after" table: RMSE in ``unit`` per run and over all runs."""
    lines = [
        "",
        "## Error before and after",
        "",
        f"| run | RMSE before [{unit}] | RMSE after [{unit}] |",
        "|---|---|---|",
    ]
    lines += [
        f"| {labels[rid]} | {result.rmse_per_run_before[rid]:.4g} | "
        f"{result.rmse_per_run_after[rid]:.4g} |"
        for rid in result.runs
    ]
    lines.append(f"| **all** | {result.rmse_before:.4g} | {result.rmse_after:.4g} |")
    return lines


def value_and_sigma(value: float | None, std: float | None, digits: int = 5) -> str:
    """``value ± σ`` (``digits`` significant), "… (not identified)" without a finite σ,
    "—" without a value."""
    if value is None or not math.isfinite(value):
        return "—"
    if std is None or not math.isfinite(std):
        return f"{value:.{digits}g} (not identified)"
    return f"{value:.{digits}g} ± {std:.2g}"


def determined_section(
    combinations: Sequence[Combination],
    equivalent: Sequence[EquivalentDamping] = (),
    amplitude_unit: str = "",
) -> list[str]:
    """The report's first section, "What the record determines": each well-determined
    combination (``motion.well_determined``) with its σ, before any raw coefficient, then a
    decay's or a swing's B_e at each amplitude (``amplitude_unit``: m or rad); a line saying
    there is none when the result has none."""
    lines = ["## What the record determines", ""]
    if not combinations:
        return [
            *lines,
            "No combination of the coefficients is determined better than they are "
            "(no terminal speed, drag at a tested speed or natural period: see below).",
            "",
        ]
    lines += [
        "Read these first: combinations of the raw coefficients (below) that the record "
        "determines closely even where the coefficients alone are not (σ by the delta method "
        "from the fit's covariance, the fit's alone: value ± U with every source is under "
        "*Uncertainty*; docs/estimation.md, *What the record determines well*).",
        "",
        "| quantity | value ± σ | unit |",
        "|---|---|---|",
    ]
    for c in combinations:
        lines.append(f"| {c.name} | {value_and_sigma(c.value, c.std)} | {c.unit or '—'} |")
    lines.append("")
    if equivalent:  # B_e over the swings, at the amplitudes of the damping ratios above
        lines += ["| amplitude | equivalent linear damping B_e | unit |", "|---|---|---|"]
        for e in equivalent:
            shown = value_and_sigma(e.value, e.std, 4)
            where = f"{e.amplitude:.4g} {amplitude_unit}"
            if amplitude_unit == "rad":  # as the damping ratios name it
                where += f" ({math.degrees(e.amplitude):.3g}°)"
            lines.append(f"| {where} | {shown} | {e.unit} |")
        lines.append("")
    return lines


def rule_lines(rules: RuleSet) -> list[str]:
    """The rules that judged every candidate, and those this kind leaves out with why."""
    applied = ", ".join(r.name for r in rules.rules)
    return [
        f"Each candidate was judged, in order, by: {applied} (each rule's statement is in "
        "result.json, `acceptance_rules`; docs/estimation.md, *Selection rules*). Not "
        "applied to this kind of record:",
        "",
        *(f"- {name}: {why}" for name, why in rules.omitted.items()),
        "",
    ]


def evidence_table(rules: RuleSet, steps: Sequence[Step], unit: str) -> list[str]:
    """The search's evidence, every kind alike: the rules that judged each trial (and those
    the kind leaves out), then one row per step: ΔBIC, the residual it explains against the
    position noise, the leave-one-record-out RMSE without → with it, the Ljung–Box Q of the
    round's model → the trial's (— where not fitted or not computed) and the verdict: yes
    (added), passed, not chosen (passed the rules, lost its round), no, or the backward
    check's kept or removed."""

    def pair(a: float, b: float, fmt: str) -> str:
        return " → ".join("—" if not math.isfinite(v) else format(v, fmt) for v in (a, b))

    lines = [
        *rule_lines(rules),
        "Whiteness is a verdict, not a rule of the search: each step's Ljung–Box Q is "
        "evidence beside the rules (docs/estimation.md, *Selection rules*).",
        "",
        f"| round | trial | ΔBIC | explained vs noise [{unit}] | leave-one-out RMSE "
        f"[{unit}] | Ljung–Box Q | kept | reason |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for s in steps:
        if s.backward:
            verdict = "kept (backward check)" if s.accepted else "removed (backward check)"
        else:
            verdict = "yes" if s.added else "passed, not chosen" if s.accepted else "no"
        delta = "—" if not math.isfinite(s.delta_bic) else f"{s.delta_bic:.1f}"
        explained = (
            "—" if not math.isfinite(s.explained_rms) else f"{s.explained_rms:.3g} vs {s.noise:.3g}"
        )
        lines.append(
            f"| {s.round} | {s.term} | {delta} | {explained} | "
            f"{pair(s.loro_before, s.loro_after, '.4g')} | {pair(s.q_before, s.q_after, '.1f')} "
            f"| {verdict} | {s.reason} |"
        )
    return lines


def write_result_and_markdown(
    out: Path,
    result: EstimationResult[Any],
    markdown: str,
    budget: Mapping[str, Any] | None = None,
) -> list[Path]:
    """Write ``result``'s document, with its ``budget`` where it has one, as result.json and
    ``markdown`` as report.md into ``out``; their paths."""
    doc = result.to_json() | ({"budget": budget} if budget else {})
    json_path = out / "result.json"
    json_path.write_text(json.dumps(doc, indent=2, ensure_ascii=False))
    md_path = out / "report.md"
    md_path.write_text(markdown, encoding="utf-8")
    return [json_path, md_path]
