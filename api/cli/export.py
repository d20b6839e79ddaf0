"""``rig export``: one stored run written to a file (or stdout) in a format of
``daq.export_formats``; its options are ``api.core.export_request.ExportQuery``'s, the query
of ``GET /api/runs/{id}/export``."""

from __future__ import annotations

import sys

import click

from api.cli.command_table import rig_command
from api.cli.common import db_option, fail, open_store, user_errors
from api.cli.options import request_from, request_options
from api.core.export_request import ExportQuery
from daq.export_formats import FORMATS, export_file_name, write_export


@rig_command()
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
