"""Run metadata on the command line: the options of
``api.core.run_metadata_query.RunMetadataQuery`` (the known keys of
``daq.store.run_metadata.KNOWN``, ``--tag`` and ``--meta``; the query parameters of ``POST
/api/runs/import``), added once to every command
that records or imports runs (see ``records_runs`` in api.cli.command_table) and read by the
procedure runner; ``rig annotate`` (here) changes it afterwards."""

from __future__ import annotations

import functools
from typing import Any

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
from api.cli.options import model_options, request_from
from api.core.run_metadata_query import RunMetadataQuery

#: Where the checked metadata waits in ``click.Context.meta`` for the run to start.
CONTEXT_KEY = "rig.run_metadata"
#: The options' parameter names (the model's fields).
NAMES = tuple(RunMetadataQuery.model_fields)


def metadata_options() -> list[click.Option]:
    """Fresh click options, one per field of :class:`RunMetadataQuery`."""
    return model_options(RunMetadataQuery)


def metadata_from_options(ctx: click.Context | None, given: dict[str, Any]) -> dict[str, Any]:
    """The checked metadata of the options given (unset options left out); a bad value
    ends the command with one line naming the flag."""
    query = request_from(RunMetadataQuery, {k: v for k, v in given.items() if k in NAMES})
    try:
        checked = query.metadata()
    except ValueError as err:
        fail(flag_names(ctx, str(err)))
    return checked


def with_run_metadata(command: click.Command) -> click.Command:
    """``command`` with the metadata options; their checked values go to
    :func:`run_metadata` before the command body runs (nothing starts on bad input)."""
    if any(param.name in NAMES for param in command.params):
        return command  # it has them already
    command.params.extend(metadata_options())
    body = command.callback
    assert body is not None

    @functools.wraps(body)
    def checked_first(*args: Any, **kwargs: Any) -> Any:
        ctx = click.get_current_context()
        given = {name: kwargs.pop(name, None) for name in NAMES}
        ctx.meta[CONTEXT_KEY] = metadata_from_options(ctx, given) or None
        return body(*args, **kwargs)

    command.callback = checked_first
    return command


def run_metadata() -> dict[str, Any] | None:
    """The metadata the running command was given (None when none)."""
    ctx = click.get_current_context(silent=True)
    return None if ctx is None else ctx.meta.get(CONTEXT_KEY)


def _annotate_options(command):
    command.params[1:1] = [
        *metadata_options(),
        click.Option(["--untag"], multiple=True, metavar="TAG", help="Remove a tag."),
        click.Option(
            ["--unset"], multiple=True, metavar="KEY", help="Remove a key (e.g. notes, ballast)."
        ),
    ]
    return command


@_annotate_options
@rig_command()
@click.argument("run_id")
@db_option
@json_option
def annotate(run_id, untag, unset, db_url, as_json, **given):
    """Set a run's metadata: operator, water (°C, g/kg), notes, tags, free keys.

    Options given replace the stored values; --tag adds, --untag and --unset remove. Works
    on any run, recorded or imported; prints the metadata as stored."""
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
            flags = [p.opts[0] for p in ctx.command.params if isinstance(p, click.Option)]
            ways = [f for f in flags if f not in ("--db", "--json")]
            fail(f"nothing to change: give {', '.join(ways[:-1])} or {ways[-1]}")
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
