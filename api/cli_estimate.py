"""``rig estimate``: hydrodynamic coefficients from stored runs."""

from __future__ import annotations

import click

from api.cli_common import db_option, echo_json, fail, json_option, open_store, user_errors
from api.estimation_job import run_estimation
from estimation import METHODS


def _pm(c: dict) -> str:
    return f"{c['value']:.5g} ± {c['std']:.2g}" if c.get("std") is not None else f"{c['value']:.5g}"


@click.command("estimate")
@click.argument("run_ids", nargs=-1, required=True, metavar="RUN_ID...")
@click.option(
    "--method",
    type=click.Choice(METHODS),
    default="output-error",
    show_default=True,
    help="output-error (joint over runs, default) or one of seed 000's least-squares approaches.",
)
@click.option(
    "--no-effects",
    is_flag=True,
    help="Fit the base model only; skip the search for missing effects.",
)
@click.option(
    "--report",
    "report_dir",
    type=click.Path(file_okay=False),
    help="Write report plots (PNG) here.",
)
@db_option
@json_option
def estimate(run_ids, method, no_effects, report_dir, db_url, as_json):
    """Fit (m + m_a) v̇ + K_L v + K_Q |v| v = τ to stored tow or spin runs, trace the
    residual to missing effects, and report the error before and after."""
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
                )
            except ValueError as err:
                fail(str(err))
        if as_json:
            echo_json(data)
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
            click.echo(f"  {label:<28} {_pm(data['coefficients'][name])} {unit}")
        for eff in data.get("effects", []):
            click.echo(f"  effect {eff['name']:<21} {_pm(eff)} {eff['unit']}")
        for group in data.get("ambiguous", []):
            click.echo(f"  ambiguous: {' / '.join(group)}")
        for warning in data.get("warnings", []):
            click.echo(f"  warning: {warning}")
        click.echo(
            f"  RMSE before {data['rmse_before']:.3g} {u[3]}, after {data['rmse_after']:.3g} {u[3]}"
        )
        click.echo(f"  stored as result #{data['result_id']}")
    finally:
        store.close()
