"""``rig estimate``: hydrodynamic coefficients from stored runs."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import click

from api.cli.command_table import rig_command
from api.cli.common import (
    db_option,
    echo_json,
    fail,
    json_option,
    open_store,
    plus_minus,
    report_folder,
    report_option,
    user_errors,
)
from api.cli.options import request_from, request_options
from api.core.estimation_failure import EstimationFailure
from api.core.estimation_job import run_estimation
from api.core.estimation_request import EstimationRequest
from daq.collector import hold_full_collections
from estimation.data.left_out import LeftOut
from estimation.uncertainty.text import (
    budget_source_lines,
    budget_summary_lines,
    plus_minus_u,
    value_with_u,
)

#: Why full collections are held (``daq.collector``): the fit loads its own modules
#: (scipy.optimize, numba and its registries) as it goes, and they live to the end of the
#: process; the one full collection that walked them was 0.04-0.08 s of a ``rig estimate``'s
#: CPU (issue 33). Young collections go on, freeing the fit's short-lived cycles.
ESTIMATING = "an estimate running"

#: How the summary words one item of each list a result may carry.
_FINDING_LINES: dict[str, Callable[[Any], str]] = {
    # an effect with its value, every estimator's alike
    "effects": lambda eff: f"effect {eff['name']:<21} {plus_minus(eff)} {eff['unit']}",
    "ambiguous": lambda group: f"ambiguous: {' / '.join(group)}",
    "warnings": lambda warning: f"warning: {warning}",
    "advice": lambda advice: f"advice: {advice}",
}


def _finding_lines(data: dict, lists: tuple[str, ...]) -> list[str]:
    """One indented line per item of the result's ``lists`` (effects, warnings, …), in order."""
    return [f"  {_FINDING_LINES[key](item)}" for key in lists for item in data.get(key) or []]


@rig_command()
@click.argument("run_ids", nargs=-1, required=True, metavar="RUN_ID...")
@request_options(EstimationRequest)
@report_option("Write report.md, result.json and the figures (PNG 150 dpi + SVG) here.")
@db_option
@json_option
def estimate(run_ids, report_dir, db_url, as_json, **options):
    """Fit (m + m_a) v̇ + K_L v + K_Q |v| v = τ to stored tow or spin runs (or α, β of the
    vehicle to pendulum free-decay runs, or a free decay's single-DOF equation), trace the
    residual to missing effects, and report the error before and after."""
    # the request as POST /api/jobs/estimation takes it (api.core.estimation_request)
    request = request_from(EstimationRequest, options, run_ids=list(run_ids))
    report_folder(report_dir)
    store = open_store(db_url)
    hold_full_collections(True, ESTIMATING)
    try:
        with user_errors():
            try:
                data = run_estimation(
                    store,
                    request.run_ids,
                    method=request.method,
                    search_effects=request.search_effects,
                    report_dir=report_dir,
                    exclude_outliers=request.exclude_outliers,
                )
            except ValueError as err:  # bad input, found before fitting
                fail(str(err))
            except EstimationFailure as err:  # ours, not the user's
                fail(str(err), code=1)
        if as_json:
            echo_json(data)
            return
        for line in summary_lines(data):
            click.echo(line)
    finally:
        hold_full_collections(False, ESTIMATING)
        store.close()


def summary_lines(data: dict) -> list[str]:
    """A result document in words, section by section as the document has them (no
    estimator is named: an axis fit, a pendulum's swing and a free decay differ in which
    sections they carry): its subject, each coefficient ± σ with its unit ("not
    identified" when the data do not determine it), the methods side by side, the findings,
    the error before and after, the budget's value ± U of each quantity, the windows, each
    quantity's uncertainty by source, the theory, the id."""
    # what it is of in GET /api/results' words (``api.core.result_subject``): a tow's heave
    lines = [f"{data.get('subject') or 'estimate'} from {len(data['runs'])} run(s)"]
    units, labels = data.get("units") or {}, data.get("labels") or {}
    for name, c in data["coefficients"].items():
        shown = plus_minus(c) + (" (not identified)" if c.get("std") is None else "")
        label = labels.get(name, name)  # a decay's added inertia
        lines.append(f"  {label:<28} {shown} {c.get('unit') or units.get(name, '')}")
    lines += [  # what the record determines well, beside the raw coefficients
        f"  {c['name']:<28} {plus_minus(c)} {c['unit']}".rstrip()
        for c in data.get("well_determined") or []
    ]
    lines += _bootstrap_lines(data.get("bootstrap"), units)
    lines += _method_lines(data.get("methods") or [], units)
    lines += _finding_lines(data, ("effects", "ambiguous", "warnings", "advice"))
    if data.get("rmse_before") is not None and data.get("rmse_after") is not None:
        unit = units.get("position", "")
        lines.append(
            f"  RMSE before {data['rmse_before']:.3g} {unit}, after {data['rmse_after']:.3g} {unit}"
        )
    if data.get("budget"):  # value ± U beside the σ above (the fit's alone), as report.md has it
        lines += [f"  {line}" for line in budget_summary_lines(data["budget"], labels)]
    lines += [_window_line(run_id, w) for run_id, w in (data.get("windows") or {}).items()]
    lines += [
        f"  run {run_id[:8]}: {_left_out_text(gap)}"
        for run_id, w in (data.get("windows") or {}).items()
        for gap in w.get("left_out") or []
    ]
    lines += _equivalent_lines(data.get("equivalent_linear_damping") or [], units)
    if data.get("budget"):  # each quantity's sources
        lines += [
            f"  {line}" for line in budget_source_lines(data["budget"], data.get("repeats"), labels)
        ]
    lines += _theory_lines(data.get("theory"))
    lines.append(f"  stored as result #{data['result_id']}")
    return lines


def _bootstrap_lines(boot: dict | None, units: dict[str, str]) -> list[str]:
    """The record-level bootstrap's spread of each coefficient (every kind's, with three
    records or more: ``estimation.motion.record_bootstrap``), beside the fit's σ above."""
    if not boot or not boot.get("used"):
        return []
    spread = ", ".join(
        f"{name} {std:.2g}{' ' + units[name] if units.get(name) else ''}"
        for name, std in (boot.get("std") or {}).items()
        if std is not None
    )
    return [f"  bootstrap σ ({boot['used']} of {boot['requested']} draws): {spread}"]


def _method_lines(methods: list[dict], units: dict[str, str]) -> list[str]:
    """Each method's estimate per run, side by side (a pendulum's seed-002 methods), each
    seed row's coefficient with its U."""
    lines = []
    for m in methods:
        values = "  ".join(
            f"{k} {value_with_u(v)} {units.get(k, '')}".rstrip()
            for k, v in m.items()
            if isinstance(v, dict) and "value" in v
        )
        e = "" if m.get("mse") is None else f"  e {m['mse']:.3g}"
        lines.append(f"  {m['method']:<22} {m['run_id'][:8]:<10} {values}{e}")
    return lines


def _equivalent_lines(rows: list[dict], units: dict[str, str]) -> list[str]:
    """A decay's equivalent linear damping B_e at the amplitudes its swings cover, each
    amplitude in the position's unit and, in rad, in degrees too (as the damping ratios and
    report.md name them)."""
    if not rows:
        return []
    unit, position = rows[0]["unit"], units.get("position", "")

    def where(amplitude: float) -> str:
        degrees = f" ({math.degrees(amplitude):.3g}°)" if position == "rad" else ""
        return f"{amplitude:.3g} {position}".rstrip() + degrees

    shown = ", ".join(f"{plus_minus(r)} at {where(r['amplitude'])}" for r in rows)
    return [f"  equivalent linear damping B_e ({unit}) by amplitude: {shown}"]


def _window_line(run_id: str, w: dict) -> str:
    """Where the fit's window of a run starts and ends, and what it dropped."""
    end = (
        "at the last sample"
        if w["end_time_s"] is None
        else f"{w['end_from_release_s']:.3f} s after it"
    )
    return (
        f"  window {run_id[:8]}: release {w['release_from_start_s']:.3f} s after the "
        f"first sample ({w['release_source']}; run clock {w['release_time_s']:.3f} s), "
        f"end {end} ({w['end_source']}); dropped "
        f"{w['samples_dropped_before']} before, {w['samples_dropped_after']} after, "
        f"{w['spikes_dropped']} spike(s)"
    )


def _left_out_text(gap: dict) -> str:
    """ "4 samples left out at 12.3–12.7 s (PLC read failed)" (``estimation.data.left_out``)."""
    return LeftOut(gap["start_s"], gap["end_s"], gap["count"], gap["reason"]).describe()


def _theory_lines(theory: dict | None) -> list[str]:
    """The added part, its dimensionless form and the verdict against the hull's theory."""
    if not theory or "added" not in theory:
        if theory and theory.get("missing"):
            return [f"  theory: not compared ({theory['missing']})"]
        return []
    a = theory["added"]
    lines = [
        f"  added (fitted − body {a['body']:.4g}): {a['value']:.4g}"
        f"{plus_minus_u(a['expanded_uncertainty'])} {a['unit']}; "
        + ", ".join(
            f"{name.split(' = ')[0]} {c['value']:.4g}"
            for name, c in theory["dimensionless"].items()
        )
    ]
    verdict = theory.get("theory")
    if verdict is not None:
        flag = "plausible" if verdict["plausible"] else "FLAGGED"
        lines.append(f"  measured vs predicted added mass: {flag}: {verdict['message']}")
    return lines
