"""``rig runs``, ``rig show``, ``rig annotate``, ``rig export``: the stored runs (``rig import`` is
in ``api.cli.imports``).

One module because the commands on stored runs share the run-id resolution, the one-line
errors and the table output.
"""

from __future__ import annotations

import sys
from datetime import datetime
from typing import Any

import click

from api.cli.common import (
    db_option,
    echo_json,
    fail,
    flag_names,
    json_option,
    open_store,
    user_errors,
)
from api.cli.options import request_from, request_options
from api.core.export_request import ExportQuery
from api.core.run_filter import RunFilter
from daq.export_formats import FORMATS, export_file_name, write_export
from daq.parameter_labels import labelled
from daq.vocabulary import AXES


def _when(value: datetime | None) -> str:
    return value.astimezone().strftime("%Y-%m-%d %H:%M:%S") if value else "—"


def _summary(params: dict[str, Any]) -> str:
    for key, unit in ((a.drive_key, a.drive_unit) for a in AXES.values() if a.drive_key):
        if params.get(key) is not None:
            return f"{params[key]:.4g} {unit}"
    if params.get("sweep"):
        return f"{len(params['sweep'])} steps"
    return ""


def _source(run) -> str:
    return f"imported {run.source_file or ''}".strip() if run.source == "imported" else "recorded"


def aligned(header: tuple[str, ...], rows: list[tuple[str, ...]]) -> str:
    """A plain table: each column as wide as its widest cell, two spaces apart, trailing
    blanks cut (rich's table cost ~0.25 s of CPU to import and lay out 50 rows)."""
    widths = [max(len(cell) for cell in column) for column in zip(header, *rows, strict=True)]
    return "\n".join(
        "  ".join(cell.ljust(w) for cell, w in zip(line, widths, strict=True)).rstrip()
        for line in (header, *rows)
    )


@click.command("runs")
@request_options(RunFilter)
@click.option("--limit", type=click.IntRange(1, 10_000), default=50, show_default=True)
@click.option(
    "--offset", type=click.IntRange(0), default=0, show_default=True, help="Skip this many."
)
@db_option
@json_option
def runs(limit, offset, db_url, as_json, **chosen):
    """List stored runs, newest first."""
    ctx = click.get_current_context()
    # the filters as GET /api/runs takes them (api.core.run_filter), days local here
    run_filter = request_from(RunFilter, chosen)
    try:
        filters = run_filter.store_filters(datetime.now().astimezone().tzinfo)
    except ValueError as err:  # a day, a date-time or a zone that is none of the forms
        fail(flag_names(ctx, str(err)))
    store = open_store(db_url)
    try:
        with user_errors():
            try:
                found = store.list_runs(**filters, limit=limit, offset=offset)
                total = store.count_runs(**filters)
            except ValueError as err:
                fail(flag_names(ctx, str(err)))
        if as_json:
            echo_json([r.to_json() for r in found])
            return
        rows = [
            (
                r.id[:8],
                r.kind,
                r.drive or "—",
                _summary(r.parameters),
                r.status + (f" ({r.reason})" if r.reason else ""),
                _when(r.started_at),
                str(r.sample_count),
                r.vehicle,
                _source(r),
                ", ".join(r.metadata.get("tags", [])),
            )
            for r in found
        ]
        header = ("run", "kind", "drive", "input", "status", "recorded", "samples", "vehicle",
                  "source", "tags")  # fmt: skip
        if found:
            click.echo(aligned(header, rows))
        if not found and not total:
            click.echo("no runs found (none stored yet? try `rig tow --force 24.5`)", err=True)
        elif offset + len(found) < total or offset:
            more = (
                f"; --offset {offset + len(found)} for more" if offset + len(found) < total else ""
            )
            shown = f"{offset + 1}-{offset + len(found)}" if found else "none"
            click.echo(f"runs {shown} of {total}{more}", err=True)
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
        click.echo(f"kind       {run.kind}   {_summary(run.parameters)}   drive {run.drive or '—'}")
        click.echo(f"status     {run.summary}")  # how it ended, and what it lost
        click.echo(f"vehicle    {run.vehicle} on {run.rig_name}")
        if run.source == "imported":
            click.echo(f"imported   {_when(run.imported_at)} from {run.source_file}")
        click.echo(f"recorded   {_when(run.started_at)}   stopped {_when(run.stopped_at)}")
        click.echo(f"samples    {run.sample_count}   channels {', '.join(run.channel_names)}")
        for i, p in enumerate(labelled(run.parameters)):
            click.echo(f"{'parameters' if i == 0 else '':<10} {p.text}")
        for key, value in run.metadata.items():
            shown = ", ".join(value) if key == "tags" else value
            click.echo(f"{key:<10} {shown}" if len(key) <= 10 else f"{key} {shown}")
        click.echo(f"software   {run.software_version}")
        for e in events:
            click.echo(f"  {_when(e.time)}  {e.kind:<8} {e.message}")
        for r in results:
            click.echo(f"  result #{r.id} {r.kind} ({_when(r.created_at)})")
    finally:
        store.close()


def _annotate_options(command):
    from api.cli.metadata import metadata_options

    command.params[1:1] = [
        *metadata_options(),
        click.Option(["--untag"], multiple=True, metavar="TAG", help="Remove a tag."),
        click.Option(
            ["--unset"], multiple=True, metavar="KEY", help="Remove a key (e.g. notes, ballast)."
        ),
    ]
    return command


@_annotate_options
@click.command("annotate")
@click.argument("run_id")
@db_option
@json_option
def annotate(run_id, untag, unset, db_url, as_json, **given):
    """Set a run's metadata: operator, water temperature, notes, tags, free keys.

    Options given replace the stored values; --tag adds, --untag and --unset remove. Works
    on any run, recorded or imported; prints the metadata as stored."""
    from api.cli.metadata import metadata_from_options

    ctx = click.get_current_context()
    changes = metadata_from_options(ctx, given)
    store = open_store(db_url)
    try:
        with user_errors():
            run = store.get_run(run_id)
        for key in unset:
            changes[key] = None
        if "tags" in changes or untag:
            tags = [t for t in run.metadata.get("tags", []) if t not in untag]
            changes["tags"] = list(dict.fromkeys([*tags, *changes.get("tags", [])])) or None
        if not changes:
            fail("nothing to change: give --operator, --water-temp, --notes, --tag, --untag, "
                 "--meta or --unset")  # fmt: skip
        try:
            run = store.set_run_metadata(run.id, changes)
        except ValueError as err:
            fail(flag_names(ctx, str(err)).replace("metadata.", "--unset ", 1))
        if as_json:
            echo_json(run.metadata)
        else:
            for key, value in run.metadata.items():
                click.echo(f"{key}: {', '.join(value) if key == 'tags' else value}")
    finally:
        store.close()


@click.command("export")
@click.argument("run_id")
@request_options(ExportQuery)
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, writable=True),
    help="File to write (default: stdout; "
    + ", ".join(f.name for f in FORMATS.values() if f.binary)
    + " need it on a terminal).",
)
@db_option
def export(run_id, output, db_url, **options):
    """Export a run with its units and metadata, in a format of --format."""
    # the query GET /api/runs/{id}/export takes (api.core.export_request)
    fmt = request_from(ExportQuery, options).format
    store = open_store(db_url)
    try:
        with user_errors():
            run = store.get_run(run_id)
        binary = FORMATS[fmt].binary
        if output:
            write_export(store, run.id, fmt, output)
            click.echo(f"wrote {output}", err=True)
        elif binary and sys.stdout.isatty():
            fail(
                f"--output: a file is needed for --format {fmt} (binary), e.g. -o "
                + export_file_name(run.id, fmt)
            )
        else:
            _to_stdout(store, run.id, fmt)
    finally:
        store.close()


def _to_stdout(store, run_id: str, fmt: str) -> None:
    """Write the export to a temporary file (HDF5 needs to seek), then to stdout."""
    import shutil
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory(prefix="rig-export-") as folder:
        path = write_export(store, run_id, fmt, Path(folder) / export_file_name(run_id, fmt))
        with open(path, "rb") as f:
            shutil.copyfileobj(f, sys.stdout.buffer)
        sys.stdout.buffer.flush()
