"""``rig sixdof``: simulate a vehicle file in 6 DOF with constant thruster commands or a
generalized force, and print the steady values."""

from __future__ import annotations

import click

from api.cli.command_table import rig_command
from api.cli.common import (
    db_option,
    echo_json,
    estimate_option,
    fail,
    flag_names,
    json_option,
    open_store,
)
from api.cli.options import request_from, request_options
from api.core import sixdof as sixdof_common
from api.core import vehicle_files
from daq.store import ResultNotFound


@rig_command()
@click.argument("vehicle")
@request_options(sixdof_common.SimulateRequest)
@estimate_option("Plug a stored surge/yaw estimation result in (repeatable).")
@db_option
@json_option
def sixdof(vehicle, estimates, db_url, as_json, **options):
    """Simulate VEHICLE (a name from fixtures/vehicles or $RIG_VEHICLES_DIR, or a .toml
    file) with (M_RB + M_A) ν̇ + C(ν)ν + D(ν)ν + g(η) = τ; print the steady ν (body
    frame: x forward, y starboard, z down) and, with --json, the trajectory."""
    # the request as POST /api/sixdof/simulate takes it (api.core.sixdof.SimulateRequest)
    request = request_from(
        sixdof_common.SimulateRequest, options, vehicle=vehicle, estimates=list(estimates)
    )
    try:
        veh = vehicle_files.find_vehicle(request.vehicle, allow_path=True)
        if request.estimates:
            store = open_store(db_url)
            try:
                found = sixdof_common.stored_estimates(store, request.estimates)
            finally:
                store.close()
            veh, _ = sixdof_common.apply_results(veh, found)
        _, summary = sixdof_common.run(
            veh,
            request.duration_s,
            commands=request.commands,
            force=request.force,
            dt=request.dt,
            max_evaluations=sixdof_common.MAX_EVALUATIONS,
        )
    except (KeyError, ResultNotFound) as err:
        fail(str(err.args[0]) if err.args else str(err))
    except ValueError as err:
        fail(flag_names(click.get_current_context(), str(err)))
    if as_json:
        echo_json(summary)
        return
    steady = summary["steady"]
    click.echo(f"{veh.name}: {summary['duration_s']:g} s simulated")
    applied = ", ".join(f"{k} {v:.4g}" for k, v in summary["tau"].items() if v != 0)
    click.echo(f"tau (N, N·m): {applied or 'none'}")
    units = {"u": "m/s", "v": "m/s", "w": "m/s", "p": "rad/s", "q": "rad/s", "r": "rad/s"}
    for k, v in steady["nu"].items():
        click.echo(f"  {k} = {v: .6g} {units[k]}")
    click.echo(
        f"settled: {'yes' if steady['settled'] else 'no'} "
        f"(largest |dν/dt| over the last second {steady['max_acceleration']:.2g})"
    )
    if steady["turn_radius_m"] is not None:
        click.echo(f"turn radius: {steady['turn_radius_m']:.4g} m")
    pose = summary["final_eta"]
    click.echo(
        f"final position: x {pose['x']:.4g} m, y {pose['y']:.4g} m, z {pose['z']:.4g} m; "
        f"heading ψ {pose['psi']:.4g} rad"
    )
