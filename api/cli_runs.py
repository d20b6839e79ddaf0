"""``rig runs``, ``rig show``, ``rig export``, ``rig import``: the stored runs."""

from __future__ import annotations

import sys
from datetime import datetime
from typing import Any

import click

from api.cli_common import db_option, echo_json, fail, json_option, open_store, user_errors
from daq.vocabulary import AXES, RunKind, RunStatus


def _when(value: datetime | None) -> str:
    return value.astimezone().strftime("%Y-%m-%d %H:%M:%S") if value else "—"


def _summary(params: dict[str, Any]) -> str:
    for key, unit in ((a.drive_key, a.drive_unit) for a in AXES.values() if a.drive_key):
        if params.get(key) is not None:
            return f"{params[key]:.4g} {unit}"
    if params.get("sweep"):
        return f"{len(params['sweep'])} steps"
    return ""


@click.command("runs")
@click.option(
    "--kind",
    type=click.Choice([k.value for k in RunKind]),
    help="Only runs of this kind.",
)
@click.option(
    "--status",
    type=click.Choice([s.value for s in RunStatus]),
    help="Only this status.",
)
@click.option("--vehicle", help="Only runs of this vehicle.")
@click.option("--since", type=click.DateTime(), help="Started at or after (local time).")
@click.option("--limit", type=click.IntRange(1, 10_000), default=50, show_default=True)
@db_option
@json_option
def runs(kind, status, vehicle, since, limit, db_url, as_json):
    """List stored runs, newest first."""
    store = open_store(db_url)
    try:
        found = store.list_runs(
            kind=kind,
            status=status,
            vehicle=vehicle,
            since=since.astimezone() if since else None,
            limit=limit,
        )
        if as_json:
            echo_json([r.to_json() for r in found])
            return
        from rich.console import Console
        from rich.table import Table

        table = Table("run", "kind", "input", "status", "started", "samples", "vehicle", box=None)
        for r in found:
            status_text = r.status + (f" ({r.reason})" if r.reason else "")
            table.add_row(
                r.id[:8],
                r.kind,
                _summary(r.parameters),
                status_text,
                _when(r.started_at),
                str(r.sample_count),
                r.vehicle,
            )
        Console().print(table)
        if not found:
            click.echo("no runs stored yet: try `rig tow --force 24.5`", err=True)
    finally:
        store.close()


@click.command("show")
@click.argument("run_id")
@db_option
@json_option
def show(run_id, db_url, as_json):
    """Show one run: configuration, how it ended, events and results (id or unique prefix)."""
    store = open_store(db_url)
    try:
        with user_errors():
            run = store.get_run(run_id)
        events = store.events(run.id)
        results = store.results(run.id)
        if as_json:
            data = run.to_json()
            data["events"] = [e.to_json() for e in events]
            data["results"] = [r.to_json() for r in results]
            echo_json(data)
            return
        click.echo(f"run        {run.id}")
        click.echo(f"kind       {run.kind}   {_summary(run.parameters)}")
        click.echo(f"status     {run.status}" + (f" ({run.reason})" if run.reason else ""))
        click.echo(f"vehicle    {run.vehicle} on {run.rig_name}")
        click.echo(f"started    {_when(run.started_at)}   stopped {_when(run.stopped_at)}")
        click.echo(f"samples    {run.sample_count}   channels {', '.join(run.channel_names)}")
        click.echo(f"parameters {run.parameters}")
        click.echo(f"software   {run.software_version}")
        for e in events:
            click.echo(f"  {_when(e.time)}  {e.kind:<8} {e.message}")
        for r in results:
            click.echo(f"  result #{r.id} {r.kind} ({_when(r.created_at)})")
    finally:
        store.close()


@click.command("export")
@click.argument("run_id")
@click.option(
    "--format", "fmt", type=click.Choice(["csv", "json"]), default="csv", show_default=True
)
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, writable=True),
    help="File to write (default: stdout).",
)
@db_option
def export(run_id, fmt, output, db_url):
    """Export a run's samples (CSV: one row per sample; JSON: metadata + samples)."""
    from daq.store import export_run_csv, export_run_json

    store = open_store(db_url)
    try:
        with user_errors():
            run = store.get_run(run_id)
        writer = export_run_csv if fmt == "csv" else export_run_json
        if output:
            with open(output, "w", encoding="utf-8", newline="") as f:
                writer(store, run.id, f)
            click.echo(f"wrote {output}", err=True)
        else:
            writer(store, run.id, sys.stdout)
    finally:
        store.close()


@click.command("import")
@click.argument("file", type=click.Path(exists=True, dir_okay=False))
@click.option(
    "--kind",
    type=click.Choice(["tow", "spin"]),
    required=True,
    help="Tow (position in m) or spin (angle in rad).",
)
@click.option("--force", "force_n", type=float, help="Tow force in N.")
@click.option("--torque", "torque_nm", type=float, help="Spin torque in N·m.")
@click.option(
    "--weight",
    "weight_kg",
    type=float,
    help="Hung weight in kg, if known (lets estimation account for its inertia).",
)
@click.option(
    "--vehicle", default=None, help="Vehicle name (default: the rig file's, else 'unknown')."
)
@click.option(
    "--rig",
    "rig_file",
    metavar="FILE",
    default=None,
    help="Rig file the data was recorded on (gives pulley/drum inertia to estimation).",
)
@click.option(
    "--time-unit",
    type=click.Choice(["s", "ms", "us"]),
    default="s",
    show_default=True,
    help="Unit of the t column (a median step over 1 s is refused as not seconds).",
)
@click.option(
    "--release-time",
    "release_time_s",
    type=float,
    help="Brake release, s on the t axis (default: found from the release coil or the motion).",
)
@click.option(
    "--end-time",
    "end_time_s",
    type=float,
    help="End of free motion, s on the t axis (default: end_of_travel/brake/carriage at rest).",
)
@db_option
@json_option
def import_(
    file,
    kind,
    force_n,
    torque_nm,
    weight_kg,
    vehicle,
    rig_file,
    time_unit,
    release_time_s,
    end_time_s,
    db_url,
    as_json,
):
    """Import a CSV (columns t [s] and position [m or rad]; more allowed); prints the new run id.

    Estimation finds the free-motion window itself (tow_release/spin_release and
    end_of_travel columns when present, else the motion); --release-time/--end-time
    override it."""
    from daq.procedures.params import ParameterError
    from daq.store import import_csv

    problems = []
    drive_name, drive = ("force_n", force_n) if kind == "tow" else ("torque_nm", torque_nm)
    other = torque_nm if kind == "tow" else force_n
    if drive is None:
        problems.append(
            (
                drive_name,
                None,
                f"--{'force' if kind == 'tow' else 'torque'} is required for a {kind}",
            )
        )
    elif not (drive > 0 and drive < float("inf")):
        problems.append((drive_name, drive, f"allowed 0 < {drive_name} < ∞"))
    if other is not None:
        problems.append(
            ("torque_nm" if kind == "tow" else "force_n", other, f"not used by a {kind}")
        )
    if weight_kg is not None and not (weight_kg > 0 and weight_kg < float("inf")):
        problems.append(("weight_kg", weight_kg, "allowed 0 < weight_kg < ∞"))
    with user_errors():
        if problems:
            raise ParameterError(problems)
    params: dict[str, Any] = {"source": "import", "file": str(file), drive_name: drive}
    if weight_kg is not None:
        params["hung_mass_kg"] = weight_kg
    origin: dict[str, str] = {"vehicle": vehicle or "unknown"}
    if rig_file:
        from daq.session import RigSource

        with user_errors():
            source = RigSource.load(rig_file)
        origin = {
            "rig_name": source.rig.rig.name,
            "vehicle": vehicle or source.rig.vehicle.name,
            "rig_toml": source.rig_toml,
        }
    store = open_store(db_url)
    try:
        try:
            run_id = import_csv(
                store,
                file,
                kind=kind,
                parameters=params,
                time_unit=time_unit,
                release_time_s=release_time_s,
                end_time_s=end_time_s,
                **origin,
            )
        except ValueError as err:
            fail(str(err))
        if as_json:
            echo_json({"run_id": run_id})
        else:
            click.echo(run_id)
    finally:
        store.close()
