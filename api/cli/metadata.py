"""Run metadata on the command line: ``--operator --water-temp --notes --tag --meta``,
added once to every command that records or imports runs (see ``records_runs`` in
api.cli.main) and read by the procedure runner; ``rig annotate`` changes it afterwards."""

from __future__ import annotations

import functools
import re
from typing import Any

import click

from api.cli.common import fail, flag_names
from daq.store.run_metadata import check_run_metadata, parse_meta_pair

#: Where the checked metadata waits in ``click.Context.meta`` for the run to start.
CONTEXT_KEY = "rig.run_metadata"


def metadata_options(*, tag_help: str = "Tag the run (repeat for more tags).") -> list:
    """Fresh click options for the four known keys and free ``--meta KEY=VALUE``."""
    return [
        click.Option(["--operator"], metavar="NAME", help="Who runs the test."),
        click.Option(
            ["--water-temp", "water_temperature_c"],
            type=float,
            metavar="°C",
            help="Water temperature, °C (-2 to 50).",
        ),
        click.Option(["--notes"], metavar="TEXT", help="Free notes on the run."),
        click.Option(["--tag", "tags"], multiple=True, metavar="TAG", help=tag_help),
        click.Option(
            ["--meta", "meta"],
            multiple=True,
            metavar="KEY=VALUE",
            help="Any other key, e.g. --meta ballast=B3 (numbers stay numbers).",
        ),
    ]


NAMES = ("operator", "water_temperature_c", "notes", "tags", "meta")


def metadata_from_options(
    ctx: click.Context | None, given: dict[str, Any], *, allow_null: bool = False
) -> dict[str, Any]:
    """The checked metadata of the options given (unset options left out); a bad value
    ends the command with one line naming the flag."""
    known = {k: v for k, v in given.items() if k in NAMES[:3] and v is not None}
    if given.get("tags"):
        known["tags"] = list(given["tags"])
    free: dict[str, Any] = {}
    try:
        for pair in given.get("meta") or ():
            key, value = parse_meta_pair(pair)
            free[key] = value
    except ValueError as err:
        fail(f"--meta {err}")
    try:
        checked = check_run_metadata(known, prefix="")
    except ValueError as err:
        fail(re.sub(r"--tag\[\d+\]", "--tag", flag_names(ctx, str(err))))
    try:
        checked |= check_run_metadata(free, prefix="--meta ", allow_null=allow_null)
    except ValueError as err:
        fail(str(err))
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
