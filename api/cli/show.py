"""``rig show``: one stored run in full (by id or unique prefix), and how a run's start and
input read in ``rig runs``'s list too. Its own module: showing a run builds no filter
options, so it loads no pydantic (~0.1 s of CPU, issue 33).
"""

from __future__ import annotations

from datetime import datetime
from typing import Any

import click

from api.cli.command_table import rig_command
from api.cli.common import db_option, echo_json, json_option, open_store, user_errors
from daq.parameter_labels import labelled
from daq.vocabulary import AXES


def local_time(value: datetime | None) -> str:
    """``value`` in this computer's zone, to the second ("—" for none)."""
    return value.astimezone().strftime("%Y-%m-%d %H:%M:%S") if value else "—"


def input_summary(params: dict[str, Any]) -> str:
    """What drove the run, from its parameters: "24.5 N", "12 steps", "" for nothing."""
    for key, unit in ((a.drive_key, a.drive_unit) for a in AXES.values() if a.drive_key):
        if params.get(key) is not None:
            return f"{params[key]:.4g} {unit}"
    if params.get("sweep"):
        return f"{len(params['sweep'])} steps"
    return ""


@rig_command()
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
        drive = run.drive or "—"
        click.echo(f"kind       {run.kind}   {input_summary(run.parameters)}   drive {drive}")
        click.echo(f"status     {run.summary}")  # how it ended, and what it lost
        click.echo(f"vehicle    {run.vehicle} on {run.rig_name}")
        if run.source == "imported":
            click.echo(f"imported   {local_time(run.imported_at)} from {run.source_file}")
        started, stopped = local_time(run.started_at), local_time(run.stopped_at)
        click.echo(f"recorded   {started}   stopped {stopped}")
        click.echo(f"samples    {run.sample_count}   channels {', '.join(run.channel_names)}")
        for i, p in enumerate(labelled(run.parameters)):
            click.echo(f"{'parameters' if i == 0 else '':<10} {p.text}")
        for key, value in run.metadata.items():
            shown = ", ".join(value) if key == "tags" else value
            click.echo(f"{key:<10} {shown}" if len(key) <= 10 else f"{key} {shown}")
        click.echo(f"software   {run.software_version}")
        for e in events:
            click.echo(f"  {local_time(e.time)}  {e.kind:<8} {e.message}")
        for r in results:
            click.echo(f"  result #{r.id} {r.kind} ({local_time(r.created_at)})")
    finally:
        store.close()
