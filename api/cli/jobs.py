"""``rig jobs`` and ``rig queue``: jobs and queues as stored in the database (read-only;
a running ``rig serve`` changes its queue over HTTP, see docs/api.md)."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import click

from api.cli.command_table import rig_command
from api.cli.common import db_option, echo_json, json_option, open_store
from api.cli.options import request_from, request_options
from api.core.job_filter import JobFilter
from api.core.paging import JobsPage

if TYPE_CHECKING:  # imported where used: `rig --help` stays light
    from daq.store.job_repository import JobRepository


def _when(unix_s: float | None) -> str:
    from daq.store.run_records import to_datetime

    moment = to_datetime(unix_s)
    return moment.astimezone().strftime("%Y-%m-%d %H:%M:%S") if moment else "—"


def _as_json(row: dict[str, Any]) -> dict[str, Any]:
    from api.core.job_model import Job

    return Job.from_row(row).to_json() | {"rig_name": row["rig_name"]}


def _table(rows: list[dict[str, Any]], first: str) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(first, "job", "rig", "label", "state", "user", "created", "runs", box=None)
    for row in rows:
        state = row["state"] + (f" ({row['error']})" if row["error"] else "")
        table.add_row(
            str(row["position"] or "") if first == "#" else row["kind"],
            row["id"],
            row["rig_name"],
            row["label"],
            state,
            row.get("user_name") or "—",
            _when(row["created_at"]),
            " ".join(r[:8] for r in row["run_ids"] or []),
        )
    Console().print(table)


def _show_jobs(
    db_url: str | None,
    read: Callable[[JobRepository], list[dict[str, Any]]],
    first: str,
    empty: str,
    as_json: bool,
) -> None:
    """Print the job rows ``read`` takes from the database: JSON, or a table whose first
    column is ``first`` (``empty`` on stderr when there are none)."""
    from daq.store.job_repository import JobRepository

    store = open_store(db_url)
    try:
        rows = read(JobRepository(store))
        if as_json:
            echo_json([_as_json(r) for r in rows])
            return
        _table(rows, first)
        if not rows:
            click.echo(empty, err=True)
    finally:
        store.close()


@rig_command()
@request_options(JobFilter)
@request_options(JobsPage)
@db_option
@json_option
def jobs(db_url, as_json, **chosen):
    """List jobs stored in the database (every service's, across restarts), newest first."""
    state = request_from(JobFilter, chosen).state  # as GET /api/jobs takes it
    page = request_from(JobsPage, chosen)
    _show_jobs(
        db_url,
        lambda repo: repo.list_jobs(None, state=state, limit=page.limit, offset=page.offset),
        "kind",
        "no jobs stored yet: start one with `rig serve` and the API",
        as_json,
    )


@rig_command()
@db_option
@json_option
def queue(db_url, as_json):
    """Show the rigs' queues: procedure jobs waiting for the rig, in the order they run.

    Reorder, remove, pause and resume through the running service's API (/api/queue)."""
    _show_jobs(db_url, lambda repo: repo.queued(None), "#", "the queue is empty", as_json)
