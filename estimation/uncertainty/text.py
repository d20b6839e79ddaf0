"""The budget and the repeats as text: report.md's sections and plain lines for the CLI,
both from the JSON documents (``Budget.to_json``, ``RepeatAnalysis.to_json``)."""

from __future__ import annotations

import textwrap
from collections.abc import Mapping
from typing import Any


def _g(x: float | None, fmt: str = ".3g") -> str:
    return "—" if x is None else format(x, fmt)


#: ν_eff at or above this prints as ∞: k is then 1.960 to four digits (a budget that a
#: declared, exactly known Type B source dominates reaches 10¹⁰).
DOF_SHOWN_AS_INFINITE = 1e4


def _dof(x: float | None) -> str:
    return "∞" if x is None or x >= DOF_SHOWN_AS_INFINITE else f"{x:.3g}"


def plus_minus_u(expanded: float | None) -> str:
    """`` ± U`` of an expanded uncertainty, or `` (U not known)`` when it rests on a σ the
    data do not give (a coefficient not identified)."""
    return " (U not known)" if expanded is None else f" ± {expanded:.2g}"


def value_with_u(estimate: dict[str, Any] | None) -> str:
    """``value ± σ`` of a {value, std} document (``—`` without a value), and where it
    carries its own U (a seed method's row, ``report_numbers.CoefficientWithU``) its U
    (95 %), k and ν: ``30.13 ± 0.032 (U 0.11, k 3.33, ν 2.8)``."""
    if not estimate or estimate.get("value") is None:
        return "—"
    std = estimate.get("std")
    shown = f"{estimate['value']:.5g}" + ("" if std is None else f" ± {std:.2g}")
    if "U" not in estimate:
        return shown
    if estimate["U"] is None:
        return f"{shown} (no U)"
    return f"{shown} (U {estimate['U']:.2g}, k {estimate['k']:.3g}, ν {_dof(estimate.get('nu'))})"


def _budgeted(budget: Mapping[str, Any], labels: Mapping[str, str] | None = None) -> dict[str, Any]:
    """Every budgeted quantity of a budget document: the coefficients, then the
    combinations the record determines well (a decay's T₀, ω₀, ζ), by the name a reader is
    shown: the result's ``labels`` where it has one (a decay's added inertia), else its key."""
    both = {**budget["coefficients"], **(budget.get("combinations") or {})}
    return {(labels or {}).get(name, name): c for name, c in both.items()}


def _summary_row(c: dict[str, Any]) -> tuple[str, str, str, str, str]:
    """(value ± U, k, ν_eff, u_c, dominant source) of one budgeted quantity, as printed."""
    if c["expanded_uncertainty"] is None:  # not identified: no budget
        return c["reported"], "—", "—", "—", "—"
    return (c["reported"], _g(c["coverage_factor"], ".3f"), _dof(c["effective_dof"]),
            _g(c["combined_standard_uncertainty"]), c["dominant_source"])  # fmt: skip


def budget_summary_markdown(
    budget: Mapping[str, Any], labels: Mapping[str, str] | None = None
) -> list[str]:
    """report.md's "Uncertainty" section, read beside the summary: the budget's notes, then
    one row per coefficient and well-determined combination (value ± U, k, ν_eff, u_c, the
    dominant source); a quantity named as the result's ``labels`` name it (a decay's added
    inertia)."""
    lines = ["## Uncertainty (ITTC 7.5-02-01-01 / GUM, 95 %)"]
    for note in budget["notes"]:  # each its own paragraph (adjacent lines would run together)
        lines += ["", f"**{note}**"]
    lines += ["", "| quantity | value ± U (95 %) | k | ν_eff | u_c | dominant source |",
              "|---|---|---|---|---|---|"]  # fmt: skip
    lines += [f"| {name} | " + " | ".join(_summary_row(c)) + " |"
              for name, c in _budgeted(budget, labels).items()]  # fmt: skip
    return [*lines, ""]


def budget_sources_markdown(
    budget: Mapping[str, Any], labels: Mapping[str, str] | None = None
) -> list[str]:
    """report.md's last section: each quantity's budget table (every source's u, sensitivity,
    contribution and share), named as in :func:`budget_summary_markdown`."""
    lines = ["", "## Uncertainty budget by source"]
    for name, c in _budgeted(budget, labels).items():
        if c["expanded_uncertainty"] is None:  # not identified: no budget to show
            lines += ["", f"### {name}: {c['reported']}"]
            continue
        lines += [
            "",
            f"### {name}: {c['reported']} (k = {_g(c['coverage_factor'], '.3f')}, "
            f"ν_eff = {_dof(c['effective_dof'])}, u_c = {_g(c['combined_standard_uncertainty'])}; "
            f"dominant: {c['dominant_source']})",
            "",
            "| source | type | u (unit) | sensitivity c | contribution c·u | share | note |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in c["rows"]:
            share = f"{100 * r['share']:.1f} %" if r["combined"] else "not combined"
            lines.append(
                f"| {r['source']} | {r['type']} | {_g(r['standard_uncertainty'])} {r['unit']} "
                f"| {_g(r['sensitivity'])} | {_g(r['contribution'])} | {share} | {r['note']} |"
            )
    return lines


def _with_unit(value: str, unit: str | None) -> str:
    """``value`` with its unit (none for a dimensionless "1")."""
    return value if not unit or unit == "1" or value == "—" else f"{value} {unit}"


def repeats_markdown(repeats: dict[str, Any], heading: str = "##") -> list[str]:
    """The repeats document (``RepeatAnalysis.to_json``) as report.md lines: per condition N,
    the mean of the compared quantity with its unit, t·s/√N and the outliers, each marked
    left out or kept; then which were left out of the fit (every kind's, tows to decays)."""
    lines = [f"{heading} Repeat runs", "", f"Outlier test: {repeats['outlier_test']}.", ""]
    quantity = repeats.get("quantity") or "terminal speed"  # documents before it was named
    excluded = set(repeats["excluded"])
    lines += [
        f"| condition | N | {quantity} (mean) | ± t·s/√N | outliers |",
        "|---|---|---|---|---|",
    ]
    for c in repeats["conditions"]:
        unit = c.get("unit")
        flagged = ", ".join(
            f"{r} ({'left out' if r in excluded else 'kept'})" for r in c["outliers"]
        )
        lines.append(
            f"| {c['condition']} | {c['n']} | {_with_unit(_g(c['mean'], '.5g'), unit)} | "
            f"{_with_unit(_g(c['repeatability_95']), unit)} | {flagged or '—'} |"
        )
    if repeats["excluded"]:
        lines.append(
            f"\nLeft out of the fit at the user's request (exclude_outliers): "
            f"{', '.join(repeats['excluded'])}."
        )
    elif repeats["outliers"]:
        lines.append(
            f"\nFlagged but kept (ask `--exclude-outliers` to leave them out): "
            f"{', '.join(repeats['outliers'])}."
        )
    return lines


#: The terminal budget table's source column, characters (a longer name wraps below).
SOURCE_WIDTH = 52


def budget_lines(
    budget: Mapping[str, Any],
    repeats: Mapping[str, Any] | None = None,
    labels: Mapping[str, str] | None = None,
) -> list[str]:
    """Plain lines for the terminal: :func:`budget_summary_lines`, then
    :func:`budget_source_lines`."""
    return budget_summary_lines(budget, labels) + budget_source_lines(budget, repeats, labels)


def budget_summary_lines(
    budget: Mapping[str, Any], labels: Mapping[str, str] | None = None
) -> list[str]:
    """The terminal's summary of a budget: its notes, then one line per coefficient (and
    well-determined combination) — value ± U, k, ν_eff, the dominant source; a quantity
    named as the result's ``labels`` name it (a decay's added inertia)."""
    out = ["uncertainty (95 %, ITTC/GUM):"] + [f"  {n}" for n in budget["notes"]]
    budgeted = _budgeted(budget, labels)
    width = max((len(name) for name in budgeted), default=8) + 2
    out.append(f"  {'quantity':<{width}} {'value ± U':<24} {'k':>6} {'ν_eff':>6}  dominant source")
    for name, c in budgeted.items():
        reported, k, dof, _, dominant = _summary_row(c)
        out.append(f"  {name:<{width}} {reported:<24} {k:>6} {dof:>6}  {dominant}")
    return out


def budget_source_lines(
    budget: Mapping[str, Any],
    repeats: Mapping[str, Any] | None = None,
    labels: Mapping[str, str] | None = None,
) -> list[str]:
    """The terminal's budget table of each quantity with more than one source (a single
    source is its summary line again), under a heading, then the ``repeats`` per condition."""
    out: list[str] = []
    for name, c in _budgeted(budget, labels).items():
        if c["expanded_uncertainty"] is None or len(c["rows"]) < 2:
            continue
        if not out:  # the heading, above the first table
            out.append("uncertainty by source:")
        out.append(
            f"  {name} = {c['reported']} "
            f"(k = {_g(c['coverage_factor'], '.3f')}, ν_eff = {_dof(c['effective_dof'])}); "
            f"dominant: {c['dominant_source']}"
        )
        head = f"{'type':<4} {'u':>10} {'c':>10} {'c·u':>10} {'share':>7}"
        out.append(f"    {'source':<{SOURCE_WIDTH}} {head}")
        for r in c["rows"]:
            share = f"{100 * r['share']:6.1f}%" if r["combined"] else "    —  "
            # a long source name goes on over the next lines of its column, never cut
            first, *rest = textwrap.wrap(r["source"], SOURCE_WIDTH) or [""]
            out.append(
                f"    {first:<{SOURCE_WIDTH}} {r['type']:<4} {_g(r['standard_uncertainty']):>10} "
                f"{_g(r['sensitivity']):>10} {_g(r['contribution']):>10} {share:>7}"
            )
            out += [f"      {more}" for more in rest]
    if repeats is not None:
        for c in repeats["conditions"]:
            if c["n"] > 1:
                out.append(
                    f"  repeats {c['condition']}: N = {c['n']}, {_g(c['mean'], '.5g')} ± "
                    f"{_g(c['repeatability_95'])} (t·s/√N)"
                    + (f", outlier(s) {', '.join(c['outliers'])}" if c["outliers"] else "")
                )
        if repeats["excluded"]:
            out.append(f"  left out (--exclude-outliers): {', '.join(repeats['excluded'])}")
    return out
