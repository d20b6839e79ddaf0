"""``rig predict-added-mass`` and ``rig water``: theory beside measurement (the vehicle's
hull as a primitive in an unbounded fluid) and the water's ρ, ν at a temperature."""

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
from api.core import theory as theory_common
from api.core import vehicle_files
from daq.store import ResultInfo, ResultNotFound


def _stored(result_ids: tuple[int, ...], db_url: str | None) -> list[ResultInfo]:
    """The stored estimation results (id, data) for ``--estimate``."""
    store = open_store(db_url)
    try:
        return sixdof_common.stored_estimates(store, result_ids)
    finally:
        store.close()


def _num(x: float | None, digits: int = 4) -> str:
    return "—" if x is None else f"{x:.{digits}g}"


@rig_command()
@request_options(theory_common.WaterQuery)
@json_option
def water(as_json, **options):
    """Water density and viscosity at a temperature (ITTC 7.5-02-01-03 formulas)."""
    query = request_from(theory_common.WaterQuery, options)
    try:
        out = theory_common.water(
            query.temp_c, query.salinity_g_kg, query.speed_m_s, query.length_m, query.g
        )
    except ValueError as err:
        fail(flag_names(click.get_current_context(), str(err)))
    if as_json:
        echo_json(out)
        return
    kind = "fresh water" if out["salinity_g_kg"] == 0 else f"{out['salinity_g_kg']:g} g/kg"
    click.echo(f"water at {out['temperature_c']:g} °C, {kind}:")
    click.echo(f"  ρ = {out['density_kg_m3']:.4f} kg/m³")
    click.echo(f"  μ = {out['dynamic_viscosity_pa_s']:.4e} Pa·s")
    click.echo(f"  ν = {out['kinematic_viscosity_m2_s']:.4e} m²/s")
    click.echo(f"  ({out['method']})")
    flow = out.get("flow")
    if flow is not None:
        click.echo(
            f"at {flow['speed_m_s']:g} m/s over {flow['length_m']:g} m: "
            f"Re = {flow['reynolds']:.4g}, Fr = {flow['froude']:.4g} (g = {flow['g']:g} m/s²)"
        )


@rig_command()
@click.argument("vehicle")
@request_options(theory_common.AddedMassQuery)
@estimate_option("Compare a stored surge/yaw/pendulum estimation result (repeatable).")
@db_option
@json_option
def predict_added_mass(vehicle, estimates, db_url, as_json, **options):
    """Predict VEHICLE's added mass per DOF from its [hull] (a name from fixtures/vehicles
    or $RIG_VEHICLES_DIR, or a .toml file), beside its file's values (or stored estimates),
    with the ratio."""
    query = request_from(theory_common.AddedMassQuery, options)
    try:
        veh = vehicle_files.find_vehicle(vehicle, allow_path=True)
        applied: list = []
        if estimates:
            veh, applied = sixdof_common.apply_results(veh, _stored(estimates, db_url))
        out = theory_common.predict(
            veh,
            query.water_temp_c,
            query.salinity_g_kg,
            query.tank_width_m,
            query.water_depth_m,
            applied=applied,
        )
    except (KeyError, ResultNotFound) as err:
        fail(str(err.args[0]) if err.args else str(err))
    except ValueError as err:
        fail(flag_names(click.get_current_context(), str(err)))
    if as_json:
        echo_json(out)
        return
    w = out["water"]
    pred = out["prediction"]
    causes: dict[str, list[str]] = {}
    hull = pred["hull"]
    click.echo(
        f"{out['vehicle']}: {hull['shape']} L {hull['length_m']:g} m × "
        f"{hull['width_m']:g} m × {hull['height_m']:g} m, ∇ {pred['displaced_volume_m3']:.4g} m³"
    )
    click.echo(
        f"water {w['temperature_c']:g} °C: ρ {w['density_kg_m3']:.2f} kg/m³, "
        f"ν {w['kinematic_viscosity_m2_s']:.4e} m²/s"
    )
    click.echo(f"theory: {pred['method']}")
    click.echo(f"{'dof':<6} {'predicted':>10} {'coef':>6} {'value':>9} {'ratio':>7}  unit")
    outside: dict[str, list[str]] = {}
    for row in out["dofs"]:
        verdict = row["verdict"]
        ratio = "—" if verdict is None else f"{verdict['ratio']:.3g}"
        flag = ""
        if verdict is not None and not verdict["plausible"]:
            flag = "  OUTSIDE"
            side = "above" if verdict["ratio"] > 1 else "below"
            outside.setdefault(side, []).append(row["dof"])
            causes[side] = verdict["causes"]
        coef = _num(row["coefficient_predicted"], 3)
        click.echo(
            f"{row['dof']:<6} {_num(row['predicted']):>10} {coef:>6}"
            f" {_num(row['value']):>9} {ratio:>7}  {row['unit']:<6} {row['source']}{flag}"
        )
    low, high = out["band"]
    click.echo(
        "ratio = value / predicted (the value from a stored result, or the vehicle file's: "
        f"measured or placeholder, as the file says); plausible within {low:g} … {high:g}"
    )
    for side, dofs in outside.items():
        click.echo(f"{side} the band ({', '.join(dofs)}); usual causes: " + "; ".join(causes[side]))
    for note in pred["notes"]:
        click.echo(f"note: {note}")
    dim = out["dimensionless"]
    area = "declared" if dim["reference_area_declared"] else "frontal area of the hull"
    click.echo(
        f"surge C_D = 2 K_Q/(ρ A) = {dim['surge_drag_coefficient']:.3g} "
        f"(A = {dim['reference_area_m2']:.4g} m², {area})"
    )
    if out["blockage"] is not None:
        click.echo(out["blockage"]["message"])
