"""``rig sixdof``: simulate a vehicle file in 6 DOF with constant thruster commands or a
generalized force, and print the steady values."""

from __future__ import annotations

import click

from api.cli.common import db_option, echo_json, estimate_option, fail, json_option, open_store
from api.core import sixdof as sixdof_common
from daq.store import ResultNotFound


def _numbers(text: str | None, option: str) -> list[float] | None:
    if text is None:
        return None
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        fail(f"{option}: got {text!r}, allowed: comma-separated numbers, e.g. 0.5,0.5")
    return None  # pragma: no cover - fail() exits


@click.command("sixdof")
@click.argument("vehicle")
@click.option("--commands", metavar="U1,U2,...", help="One command per thruster (held constant).")
@click.option("--force", metavar="X,Y,Z,K,M,N", help="Generalized body force (N, N·m).")
@click.option("--duration", "duration_s", type=float, default=30.0, show_default=True,
              help="Simulated time, s.")  # fmt: skip
@click.option("--dt", type=float, default=0.01, show_default=True, help="Output step, s.")
@estimate_option("Plug a stored surge/yaw estimation result in (repeatable).")
@db_option
@json_option
def sixdof(vehicle, commands, force, duration_s, dt, estimates, db_url, as_json):
    """Simulate VEHICLE (a name from fixtures/vehicles or $RIG_VEHICLES_DIR, or a .toml
    file) with (M_RB + M_A) ν̇ + C(ν)ν + D(ν)ν + g(η) = τ; print the steady ν (body
    frame: x forward, y starboard, z down) and, with --json, the trajectory."""
    try:
        veh = sixdof_common.find_vehicle(vehicle, allow_path=True)
        if estimates:
            store = open_store(db_url)
            try:
                found = []
                for result_id in estimates:
                    result = store.result(result_id)
                    if result.kind != "estimation":
                        fail(f"--estimate: result {result_id} is a {result.kind!r} result")
                    found.append((result_id, result.data))
            finally:
                store.close()
            veh, _ = sixdof_common.apply_results(veh, found)
        _, summary = sixdof_common.run(
            veh,
            duration_s,
            commands=_numbers(commands, "--commands"),
            force=_numbers(force, "--force"),
            dt=dt,
        )
    except (KeyError, ResultNotFound) as err:
        fail(str(err.args[0]) if err.args else str(err))
    except ValueError as err:
        fail(str(err))
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
