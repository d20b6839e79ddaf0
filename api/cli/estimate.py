"""``rig estimate``: hydrodynamic coefficients from stored runs."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import click

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
from api.core.estimation_failure import EstimationFailure
from api.core.estimation_job import run_estimation
from daq.procedures.kinds import all_methods
from estimation.uncertainty.text import budget_lines

ALL_METHODS = all_methods()
#: How the summary words one item of each list a result may carry.
_FINDING_LINES: dict[str, Callable[[Any], str]] = {
    "effects": lambda eff: f"effect {eff['name']:<21} {plus_minus(eff)} {eff['unit']}",
    "ambiguous": lambda group: f"ambiguous: {' / '.join(group)}",
    "warnings": lambda warning: f"warning: {warning}",
    "advice": lambda advice: f"advice: {advice}",
}


def _echo_findings(data: dict, lists: tuple[str, ...]) -> None:
    """One indented line per item of the result's ``lists`` (effects, warnings, …), in order."""
    for key in lists:
        for item in data.get(key, []):
            click.echo(f"  {_FINDING_LINES[key](item)}")


@click.command("estimate")
@click.argument("run_ids", nargs=-1, required=True, metavar="RUN_ID...")
@click.option(
    "--method",
    type=click.Choice(ALL_METHODS),
    default="output-error",
    show_default=True,
    help="output-error (joint over runs, default); for tow/spin runs one of seed 000's "
    "least-squares approaches, for pendulum runs one of seed 002's damped-fit, "
    "log-decrement, equation-error (all are reported; this picks the headline).",
)
@click.option(
    "--no-effects",
    is_flag=True,
    help="Fit the base model only; skip the search for missing effects.",
)
@click.option(
    "--exclude-outliers",
    is_flag=True,
    help="Leave repeats that Chauvenet's criterion flags out of the fit (they are always "
    "reported; without this flag they stay in).",
)
@report_option("Write report.md, result.json and the figures (PNG 150 dpi + SVG) here.")
@db_option
@json_option
def estimate(run_ids, method, no_effects, exclude_outliers, report_dir, db_url, as_json):
    """Fit (m + m_a) v̇ + K_L v + K_Q |v| v = τ to stored tow or spin runs (or α, β of the
    vehicle to pendulum free-decay runs), trace the residual to missing effects, and report
    the error before and after."""
    report_folder(report_dir)
    store = open_store(db_url)
    try:
        with user_errors():
            try:
                data = run_estimation(
                    store,
                    run_ids,
                    method=method,
                    search_effects=not no_effects,
                    report_dir=report_dir,
                    exclude_outliers=exclude_outliers,
                )
            except ValueError as err:  # bad input, found before fitting
                fail(str(err))
            except EstimationFailure as err:  # ours, not the user's
                fail(str(err), code=1)
        if as_json:
            echo_json(data)
            return
        if data.get("analysis") == "pendulum":
            _echo_pendulum(data)
            return
        if "axis" not in data:  # a result with {value, std, unit} coefficients (a decay)
            _echo_coefficients(data)
            return
        units = {
            "surge": ("kg", "N·s/m", "N·s²/m²", "m"),
            "yaw": ("kg·m²", "N·m·s/rad", "N·m·s²/rad²", "rad"),
        }
        u = units[data["axis"]]
        click.echo(f"{data['axis']} from {len(data['runs'])} run(s), method {data['method']}")
        for (name, label), unit in zip(
            (
                ("inertia", "inertia (vehicle + added)"),
                ("linear_damping", "linear damping K_L"),
                ("quadratic_damping", "quadratic damping K_Q"),
            ),
            u[:3],
            strict=True,
        ):
            click.echo(f"  {label:<28} {plus_minus(data['coefficients'][name])} {unit}")
        _echo_findings(data, ("effects", "ambiguous", "warnings"))
        click.echo(
            f"  RMSE before {data['rmse_before']:.3g} {u[3]}, after {data['rmse_after']:.3g} {u[3]}"
        )
        for run_id, w in data.get("windows", {}).items():
            end = (
                "at the last sample"
                if w["end_time_s"] is None
                else f"{w['end_from_release_s']:.3f} s after it"
            )
            click.echo(
                f"  window {run_id[:8]}: release {w['release_from_start_s']:.3f} s after the "
                f"first sample ({w['release_source']}; run clock {w['release_time_s']:.3f} s), "
                f"end {end} ({w['end_source']}); dropped "
                f"{w['samples_dropped_before']} before, {w['samples_dropped_after']} after, "
                f"{w['spikes_dropped']} spike(s)"
            )
        if data.get("budget"):
            for line in budget_lines(data["budget"], data.get("repeats")):
                click.echo(f"  {line}")
        _echo_theory(data.get("theory"))
        click.echo(f"  stored as result #{data['result_id']}")
    finally:
        store.close()


def _echo_coefficients(data: dict) -> None:
    """Human summary of a result whose coefficients carry their units: each with its σ
    ("not identified" when the data do not determine it), the effects kept, warnings."""
    what = " ".join(str(data[k]) for k in ("dof", "kind") if data.get(k))
    click.echo(f"{what or 'estimate'} from {len(data['runs'])} run(s)")
    for name, c in data["coefficients"].items():
        shown = plus_minus(c) + (" (not identified)" if c.get("std") is None else "")
        click.echo(f"  {name:<28} {shown} {c.get('unit', '')}")
    for key in ("effects", "warnings"):
        for item in data.get(key) or []:
            click.echo(f"  {key[:-1]}: {item}")
    if data.get("rmse_before") is not None and data.get("rmse_after") is not None:
        click.echo(f"  RMSE before {data['rmse_before']:.3g}, after {data['rmse_after']:.3g}")
    click.echo(f"  stored as result #{data['result_id']}")


def _echo_pendulum(data: dict) -> None:
    """Human summary of a pendulum result: methods side by side, effects, error."""
    click.echo(
        f"pendulum free decay, {data['axis']} from {len(data['runs'])} run(s), "
        f"headline {data['method']}"
    )
    units = data["units"]
    for name, est in data["coefficients"].items():
        click.echo(f"  {name:<28} {plus_minus(est)} {units[name]}")
    click.echo(f"  {'method':<22} {'run':<10} {'α [kg]':<22} {'β [N·s/m]':<22} e [rad²]")
    for m in data["methods"]:
        e = "—" if m["mse"] is None else f"{m['mse']:.3g}"
        click.echo(
            f"  {m['method']:<22} {m['run_id'][:8]:<10} {plus_minus(m['added_mass']):<22} "
            f"{plus_minus(m['linear_damping']):<22} {e}"
        )
    _echo_findings(data, ("effects", "warnings", "advice"))
    click.echo(f"  RMSE before {data['rmse_before']:.3g} rad, after {data['rmse_after']:.3g} rad")
    click.echo(f"  stored as result #{data['result_id']}")


def _echo_theory(theory: dict | None) -> None:
    """The added part, its dimensionless form and the verdict against the hull's theory."""
    if not theory or "added" not in theory:
        if theory and theory.get("missing"):
            click.echo(f"  theory: not compared ({theory['missing']})")
        return
    a = theory["added"]
    click.echo(
        f"  added (fitted − body {a['body']:.4g}): {a['value']:.4g} ± "
        f"{a['expanded_uncertainty']:.2g} {a['unit']}; "
        + ", ".join(
            f"{name.split(' = ')[0]} {c['value']:.4g}"
            for name, c in theory["dimensionless"].items()
        )
    )
    verdict = theory.get("theory")
    if verdict is not None:
        flag = "plausible" if verdict["plausible"] else "FLAGGED"
        click.echo(f"  measured vs predicted added mass: {flag}: {verdict['message']}")
