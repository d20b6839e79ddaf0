"""``rig crosscheck``: weight-driven vs thruster-driven coefficients of one axis."""

from __future__ import annotations

import click

from api.cli.common import (
    db_option,
    echo_json,
    fail,
    json_option,
    number,
    open_store,
    plus_minus,
    report_folder,
    report_option,
    user_errors,
)
from api.core.crosscheck_job import crosscheck_results, crosscheck_runs
from estimation.axis.crosscheck_comparison import LABELS


@click.command("crosscheck")
@click.option(
    "--weight", "weight_runs", multiple=True, metavar="RUN", help="A weight-driven run (repeat)."
)
@click.option(
    "--thrusters",
    "thruster_runs",
    multiple=True,
    metavar="RUN",
    help="A thruster-driven run (repeat).",
)
@click.option(
    "--results",
    nargs=2,
    type=int,
    default=None,
    metavar="WEIGHT_RESULT_ID THRUSTER_RESULT_ID",
    help="Compare two stored estimation results instead (no fitting).",
)
@click.option("--no-effects", is_flag=True, help="Estimate the base model only (with --weight).")
@report_option("Write report.md and the figure crosscheck.png/.svg here.")
@db_option
@json_option
def crosscheck(weight_runs, thruster_runs, results, no_effects, report_dir, db_url, as_json):
    """Estimate weight-driven and thruster-driven runs of one axis (or take two stored
    estimation results) and compare the coefficients in σ units; a disagreement points
    at the thrust calibration or at an effect."""
    if results and (weight_runs or thruster_runs):
        fail("--results: give either --results or --weight/--thrusters runs, not both")
    if not results and not (weight_runs and thruster_runs):
        fail("--weight and --thrusters: give at least one run of each (or --results A B)")
    report_folder(report_dir)
    store = open_store(db_url)
    try:
        with user_errors():
            try:
                if results:
                    data = crosscheck_results(store, *results, report_dir=report_dir)
                else:
                    data = crosscheck_runs(
                        store,
                        list(weight_runs),
                        list(thruster_runs),
                        search_effects=not no_effects,
                        report_dir=report_dir,
                    )
            except ValueError as err:  # the API's field names are the order of --results
                message = str(err).replace("weight_result_id", "--results (first)")
                fail(message.replace("thruster_result_id", "--results (second)"))
        if as_json:
            echo_json(data)
            return
        click.echo(
            f"{data['axis']}: weight result #{data['weight_result_id']} vs thruster result "
            f"#{data['thruster_result_id']}  (σ = σ_total)"
        )
        click.echo(f"  {'':<13} {'weight':>22} {'thrusters':>22} {'z':>9}  verdict")
        rows = {**data["coefficients"], **data.get("combined", {})}
        for name, c in rows.items():
            z = "—" if c["z"] is None else f"{c['z']:+.2f}"
            if c["verdict"] == "undecided":  # computed, not judged
                z = f"({z})"
            speed = f"  at |v| = {c['speed']:.3g}" if c.get("speed") is not None else ""
            click.echo(
                f"  {LABELS[name]:<13} {plus_minus(c['weight']):>22} "
                f"{plus_minus(c['thruster']):>22} {z:>9}  {c['verdict']}{speed}"
            )
        for side in ("weight", "thruster"):
            r = data["rmse"][side]
            click.echo(f"  RMSE {side:<8} before {number(r['before'])}, after {number(r['after'])}")
        click.echo(f"  verdict: {data['verdict']}")
        for line in data["diagnosis"]:
            click.echo(f"  diagnosis: {line}")
        for line in data["warnings"]:
            click.echo(f"  warning: {line}")
        click.echo(f"  stored as result #{data['result_id']}")
    finally:
        store.close()
