"""``rig runs``: the stored runs, listed (``rig show`` is in ``api.cli.show``, ``rig annotate``
in ``api.cli.metadata``, ``rig export`` in ``api.cli.export``, ``rig import`` in
``api.cli.imports``: each builds its options from its model when its module is imported, which
a listing does not need).
"""

from __future__ import annotations

from datetime import datetime

import click

from api.cli.command_table import rig_command
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
from api.cli.show import input_summary, local_time
from api.core.paging import RunsPage
from api.core.run_filter import RunFilter


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


@rig_command()
@request_options(RunFilter)
@request_options(RunsPage)
@db_option
@json_option
def runs(db_url, as_json, **chosen):
    """List stored runs, newest first."""
    ctx = click.get_current_context()
    # the filters and the page as GET /api/runs takes them, days local here
    run_filter = request_from(RunFilter, chosen)
    page = request_from(RunsPage, chosen)
    limit, offset = page.limit, page.offset
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
                input_summary(r.parameters),
                r.status + (f" ({r.reason})" if r.reason else ""),
                local_time(r.started_at),
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
