"""``rig import-calibration`` (a thrust-stand table), ``rig calibrations`` (measured and
imported, newest first) and ``rig thrust`` (the thrust law: force at a command and voltage,
or the command for a force)."""

from __future__ import annotations

from pathlib import Path

import click

from api.cli.command_table import rig_command
from api.cli.common import db_option, echo_json, fail, flag_names, json_option, open_store
from api.cli.options import request_from, request_options
from api.core.calibration_queries import CalibrationChoice, StandTableQuery, ThrustQuery


@rig_command()
@click.argument("file", type=click.Path(exists=True, dir_okay=False))
@request_options(StandTableQuery)
@db_option
@json_option
def import_calibration(file, db_url, as_json, **options):
    """Import a thrust-stand calibration table (CSV: command, thrust, optional supply
    voltage; `,` or `;` separated, decimal commas and Excel's BOM read); prints its id and
    the thrust law identified from it. Current, RPM and power columns are kept when named or
    when their header says what they are (`Current (A)`, `RPM`, `Power (W)`), with the
    efficiency (N/W) derived from them. No run is needed: thruster-driven tests and `rig
    thrust` use the newest calibration, imported or measured."""
    from daq.calibration_law import import_calibration as store_table

    ctx = click.get_current_context()
    # the query POST /api/calibrations/import takes (api.core.calibration_queries)
    query = request_from(StandTableQuery, options)
    try:
        spec = query.spec()
        data = Path(file).read_bytes()
    except ValueError as err:
        fail(flag_names(ctx, str(err)))
    store = open_store(db_url)
    try:
        try:
            summary = store_table(store, data, spec, query.name or Path(file).name)
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


@rig_command()
@request_options(ThrustQuery)
@request_options(CalibrationChoice)
@db_option
@json_option
def thrust(db_url, as_json, **options):
    """Thrust law of the stored calibration: the force ± σ at --command and --voltage, or the
    command ± σ for --force at --voltage (refused beyond what full command delivers)."""
    from daq.calibration_catalog import voltage_for
    from daq.calibration_law import NoCalibration, law_of

    ctx = click.get_current_context()
    # the query GET /api/thrust takes (api.core.calibration_queries)
    query = request_from(ThrustQuery, options)
    choice = request_from(CalibrationChoice, options)
    try:
        query.check()
    except ValueError as err:
        _fail_naming_flags(ctx, err)
    store = open_store(db_url)
    try:
        try:
            law, info = law_of(store, choice.source, choice.calibration_id)
        except NoCalibration as err:
            fail(f"--calibration: {err}" if choice.calibration else str(err))
        except ValueError as err:
            fail(f"calibration {choice.label()}: {err}")
        v, voltage_source = voltage_for(store, law.reference_voltage, query.voltage_v)
    finally:
        store.close()
    try:
        answer = query.answer(law, v)
    except ValueError as err:  # beyond what full command delivers at that voltage
        _fail_naming_flags(ctx, err)
    given, found = ("command", "force_n") if query.command is not None else ("force_n", "command")
    out = answer[found]
    text = (
        f"{out['value']:.4g} ± {out['std']:.2g} N at command {query.command:g}, {v:g} V"
        if given == "command"
        else f"command {out['value']:.4g} ± {out['std']:.2g} for {query.force_n:g} N at {v:g} V"
    )
    answer |= {"voltage_v": v, "voltage_source": voltage_source, "calibration": info}
    if as_json:
        echo_json(answer)
    else:
        click.echo(text)
        click.echo(f"supply: {voltage_source}")
        click.echo(f"calibration: {info['label']}; {answer['voltage_law']}")


def _fail_naming_flags(ctx: click.Context, err: ValueError) -> None:
    """Exit 2 with ``err``, its leading field names spelled as options (the rest is prose
    that may use the same words: "command 0.125")."""
    fields, _, rest = str(err).partition(": ")
    fail(f"{flag_names(ctx, fields)}: {rest}")


@rig_command()
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
