"""``rig crosscheck``: weight-driven vs thruster-driven coefficients of one axis."""

from __future__ import annotations

import click

from api.cli.command_table import rig_command
from api.cli.common import (
    db_option,
    echo_json,
    fail,
    flag_names,
    json_option,
    number,
    open_store,
    plus_minus,
    report_folder,
    report_option,
    user_errors,
)
from api.cli.options import request_from, request_options
from api.core.crosscheck_job import crosscheck_results, crosscheck_runs
from api.core.crosscheck_requests import CrossCheckJobRequest, CrossCheckRequest
from estimation.axis.crosscheck_comparison import LABELS


@rig_command()
@request_options(CrossCheckJobRequest, required=False)
@request_options(CrossCheckRequest, required=False)
@report_option("Write report.md and the figure crosscheck.png/.svg here.")
@db_option
@json_option
def crosscheck(report_dir, db_url, as_json, **options):
    """Estimate weight-driven and thruster-driven runs of one axis (or take two stored
    estimation results) and compare the coefficients in σ units; a disagreement points
    at the thrust calibration or at an effect."""
    # POST /api/jobs/crosscheck's body, or POST /api/crosscheck's (api.core.crosscheck_requests)
    results = options["weight_result_id"] is not None or options["thruster_result_id"] is not None
    if results and (options["weight_runs"] or options["thruster_runs"]):
        fail("--weight-result/--thruster-result: give two results or --weight/--thrusters runs, "
             "not both")  # fmt: skip
    if not results and not (options["weight_runs"] and options["thruster_runs"]):
        fail("--weight and --thrusters: give at least one run of each (or --weight-result ID "
             "--thruster-result ID)")  # fmt: skip
    request = request_from(CrossCheckRequest if results else CrossCheckJobRequest, options)
    report_folder(report_dir)
    store = open_store(db_url)
    try:
        with user_errors():
            try:
                if isinstance(request, CrossCheckRequest):
                    data = crosscheck_results(
                        store,
                        request.weight_result_id,
                        request.thruster_result_id,
                        report_dir=report_dir,
                    )
                else:
                    data = crosscheck_runs(
                        store,
                        request.weight_runs,
                        request.thruster_runs,
                        search_effects=request.search_effects,
                        report_dir=report_dir,
                    )
            except ValueError as err:  # named as the command line spells it
                fail(flag_names(click.get_current_context(), str(err)))
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
