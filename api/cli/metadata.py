"""Run metadata on the command line: the options of
``api.core.run_metadata_query.RunMetadataQuery`` (``--operator --water-temp --notes --tag
--meta``, the query parameters of ``POST /api/runs/import``), added once to every command
that records or imports runs (see ``records_runs`` in api.cli.command_table) and read by the
procedure runner; ``rig annotate`` changes it afterwards."""

from __future__ import annotations

import functools
from typing import Any

import click

from api.cli.common import fail, flag_names
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
