"""``rig import-calibration`` (a thrust-stand table), ``rig calibrations`` (measured and
imported, newest first) and ``rig thrust`` (the thrust law: force at a command and voltage,
or the command for a force)."""

from __future__ import annotations

import click

from api.cli.common import db_option, echo_json, fail, flag_names, json_option, open_store
from estimation.thrust.calibration_import import COMMAND_UNITS, THRUST_UNITS, stand_columns


@click.command("import-calibration")
@click.argument("file", type=click.Path(exists=True, dir_okay=False))
@click.option(
    "--command-column",
    "command_column",
    default="1",
    show_default=True,
    help="Header (or 1-based number) of the command column.",
)
@click.option(
    "--command-unit",
    "command_unit",
    type=click.Choice(COMMAND_UNITS),
    default="fraction",
    show_default=True,
    help="pwm_us (with --pwm-neutral/--pwm-span), permille, fraction (−1 … 1) or volts "
    "(with --full-scale).",
)
@click.option("--pwm-neutral", "pwm_neutral_us", type=float, default=1500.0, show_default=True)
@click.option(
    "--pwm-span",
    "pwm_span_us",
    type=float,
    default=400.0,
    show_default=True,
    help="µs from neutral to full command.",
)
@click.option(
    "--full-scale", "full_scale_v", type=float, help="Command voltage of full command (volts)."
)
@click.option(
    "--thrust-column",
    "thrust_column",
    default="2",
    show_default=True,
    help="Header (or 1-based number) of the thrust column.",
)
@click.option(
    "--thrust-unit",
    "thrust_unit",
    type=click.Choice(list(THRUST_UNITS)),
    default="N",
    show_default=True,
)
@click.option(
    "--voltage-column", "voltage_column", help="Header (or number) of the supply-voltage column."
)
@click.option(
    "--voltage",
    "voltage_v",
    type=float,
    help="Supply voltage of the whole table, V (when it has no voltage column).",
)
@click.option(
    "--current-column", "current_column", help="Header (or number) of a current column (A)."
)
@click.option("--rpm-column", "rpm_column", help="Header (or number) of an RPM column (rev/min).")
@click.option(
    "--power-column", "power_column", help="Header (or number) of an electrical power column (W)."
)
@click.option("--name", help="Name to store it under (default: the file name).")
@db_option
@json_option
def import_calibration(
    file,
    command_column,
    command_unit,
    pwm_neutral_us,
    pwm_span_us,
    full_scale_v,
    thrust_column,
    thrust_unit,
    voltage_column,
    voltage_v,
    current_column,
    rpm_column,
    power_column,
    name,
    db_url,
    as_json,
):
    """Import a thrust-stand calibration table (CSV: command, thrust, optional supply
    voltage; `,` or `;` separated, decimal commas and Excel's BOM read); prints its id and
    the thrust law identified from it. Current, RPM and power columns are kept when named or
    when their header says what they are (`Current (A)`, `RPM`, `Power (W)`), with the
    efficiency (N/W) derived from them. No run is needed: thruster-driven tests and `rig
    thrust` use the newest calibration, imported or measured."""
    from pathlib import Path

    from daq.calibration_law import import_calibration as store_table
    from estimation.thrust.calibration_import import CommandUnit, ImportSpec

    ctx = click.get_current_context()
    try:
        spec = ImportSpec(
            command_column=command_column,
            thrust_column=thrust_column,
            thrust_unit=thrust_unit,
            command=CommandUnit(command_unit, pwm_neutral_us, pwm_span_us, full_scale_v),
            voltage_column=voltage_column,
            voltage_v=voltage_v,
            extra_columns=stand_columns(
                current_a=current_column, rpm=rpm_column, power_w=power_column
            ),
        )
        data = Path(file).read_bytes()
    except ValueError as err:
        fail(flag_names(ctx, str(err)))
    store = open_store(db_url)
    try:
        try:
            summary = store_table(store, data, spec, name or Path(file).name)
        except ValueError as err:
            fail(f"{Path(file).name}: {flag_names(ctx, str(err))}")
    finally:
        store.close()
    if as_json:
        echo_json(summary)
        return
    law = summary["law"]
    kept = ", ".join(summary["channels"]) or "none"
    click.echo(
        f"calibration {summary['id']} ({summary['name']}): {summary['rows']} rows; "
        f"stand channels kept: {kept}"
    )
    volts = ", ".join(f"{v:g}" for v in law["voltages_v"])
    if law["identified"]:
        held = (
            ", ".join(f"{v} V {100 * e:.2g} %" for v, e in law["held_out"].items())
            or "not measured (fewer than 3 voltages)"
        )
        click.echo(f"voltage law: identified from {volts} V ({law['interpolation']})")
        click.echo(f"held-out voltages predicted within (RMS, % of full thrust): {held}")
    else:
        q = law["assumed_exponent"]
        click.echo(
            f"voltage law: assumed F ∝ V^{q['value']:g} ± {q['std']:g} (one voltage, {volts} V)"
        )


@click.command("thrust")
@click.option("--command", "command", type=float, help="Command (fraction −1 … 1): give the force.")
@click.option("--force", "force_n", type=float, help="Force per thruster, N: give the command.")
@click.option(
    "--voltage",
    "volts",
    type=click.FloatRange(0, 1000, min_open=True),
    help="Supply voltage, V (default: the supply the rig recorded last, else the "
    "calibration's reference voltage; the output says which).",
)
@click.option(
    "--calibration",
    "calibration_id",
    help="Imported calibration id, or run:ID for a calibration run's result "
    "(default: the newest of both).",
)
@db_option
@json_option
def thrust(command, force_n, volts, calibration_id, db_url, as_json):
    """Thrust law of the stored calibration: the force ± σ at --command and --voltage, or the
    command ± σ for --force at --voltage (refused beyond what full command delivers)."""
    import math

    from daq.calibration_catalog import voltage_for
    from daq.calibration_law import NoCalibration, law_of

    if (command is None) == (force_n is None):
        fail("--command or --force: give exactly one")
    if command is not None and not (math.isfinite(command) and -1 <= command <= 1):
        fail(f"--command: got {command:g}, allowed: −1 … 1 (fraction of full command)")
    if force_n is not None and not math.isfinite(force_n):
        fail(f"--force: got {force_n}, allowed: a finite force in N")
    source, key = None, None
    if calibration_id is not None:
        source, _, key = calibration_id.rpartition(":")
        source = {"": "imported", "run": "run", "imported": "imported"}.get(source)
        if source is None or not key.isdigit():
            fail(f"--calibration: got {calibration_id!r}, allowed: ID or run:ID")
    store = open_store(db_url)
    try:
        try:
            law, info = law_of(store, source, key)
        except NoCalibration as err:
            fail(f"--calibration: {err}" if calibration_id else str(err))
        except ValueError as err:
            fail(f"calibration {info_name(source, key)}: {err}")
        v, voltage_source = voltage_for(store, law.reference_voltage, volts)
    finally:
        store.close()
    try:
        if command is not None:
            out = law.estimate(command, v)
            answer = {"command": command, "force_n": out.to_json()}
            text = f"{out.value:.4g} ± {out.std:.2g} N at command {command:g}, {v:g} V"
        else:
            out = law.command_for_force(force_n, v)
            answer = {"force_n": force_n, "command": out.to_json()}
            text = f"command {out.value:.4g} ± {out.std:.2g} for {force_n:g} N at {v:g} V"
    except ValueError as err:  # beyond what full command delivers at that voltage
        fail(f"--force: {str(err).removeprefix('force: ')}")
    answer |= {
        "voltage_v": v,
        "voltage_source": voltage_source,
        "calibration": info,
        "voltage_law": out.voltage_law,
    }
    if as_json:
        echo_json(answer)
    else:
        click.echo(text)
        click.echo(f"supply: {voltage_source}")
        click.echo(f"calibration: {info['label']}; {out.voltage_law}")


@click.command("calibrations")
@db_option
@json_option
def calibrations(db_url, as_json):
    """List thrust calibrations, measured (calibration runs) and imported tables, newest
    first: which one, its voltages, commands and the stand channels it carries."""
    from daq.calibration_catalog import calibrations as listed

    store = open_store(db_url)
    try:
        found = listed(store)
    finally:
        store.close()
    if as_json:
        echo_json(found)
        return
    if not found:
        click.echo(
            "no thrust calibration stored: rig calibrate-thrusters or rig import-calibration"
        )
        return
    for c in found:
        volts = ", ".join(f"{v:g}" for v in c["voltages_v"]) or "?"
        lo, hi = c["command_range"] or (0.0, 0.0)
        extra = f"; {', '.join(c['channels'])}" if c["channels"] else ""
        click.echo(
            f"{c['created_at'][:19]}  {c['label']}: {c['rows']} rows at {volts} V, "
            f"commands {lo:g} … {hi:g}{extra}"
        )


def info_name(source: str | None, key: str | None) -> str:
    return "newest" if key is None else f"{source} {key}"
