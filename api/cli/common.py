"""What every ``rig`` command shares: options, error reporting, the session runner."""

from __future__ import annotations

import inspect
import json
import os
import re
import sys
from collections.abc import Awaitable, Callable
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, TypeVar

import click

if TYPE_CHECKING:  # imported where used: light commands start without numpy & co.
    from rich.progress import Progress as RichProgress
    from rich.progress import TaskID

    from daq.procedures.params import Progress
    from daq.procedures.recording import AbortSignal

T = TypeVar("T")

db_option = click.option(
    "--db",
    "db_url",
    metavar="URL",
    envvar="RIG_DATABASE_URL",
    default=None,
    help="Database URL (sqlite:///path or postgresql+psycopg://...). "
    "Default: $RIG_DATABASE_URL, else ~/.local/share/towrig/rig.db.",
)
json_option = click.option(
    "--json", "as_json", is_flag=True, help="Print one JSON document (for scripts)."
)
#: A lab sets its rig file once: every command's ``--rig`` defaults to it, and ``rig --help``
#: lists what that rig cannot do.
RIG_FILE_ENV = "RIG_FILE"
rig_option = click.option(
    "--rig",
    "rig_file",
    metavar="FILE",
    envvar=RIG_FILE_ENV,
    default=None,
    help=f"Rig file (default: ${RIG_FILE_ENV}, else fixtures/rigs/benbam.toml, simulated).",
)
scenario_option = click.option(
    "--scenario",
    "scenario_file",
    metavar="FILE",
    default=None,
    help="Simulation scenario (simulated rig only).",
)


def report_option(help: str) -> Callable[[Any], Any]:
    """``--report`` (into ``report_dir``): a folder to write the command's report to;
    ``help`` says what goes in it. Create it first with :func:`report_folder`."""
    return click.option(
        "--report", "report_dir", type=click.Path(file_okay=False), metavar="DIR", help=help
    )


def estimate_option(help: str) -> Callable[[Any], Any]:
    """``--estimate RESULT_ID`` (repeatable, into ``estimates``): stored estimation results
    to plug into a vehicle; ``help`` says which."""
    return click.option(
        "--estimate", "estimates", type=int, multiple=True, metavar="RESULT_ID", help=help
    )


#: Set to see the traceback behind any error (for bug reports).
DEBUG_ENV = "RIG_DEBUG"


def fail(message: str, code: int = 2) -> None:
    """Print ``error: message`` on stderr, on one line (several problems are joined by
    ``;``), and exit (2 = bad input, 1 = failure). With ``RIG_DEBUG=1`` the traceback of
    the exception being handled (or, without one, where ``fail`` was called) comes first."""
    if os.environ.get(DEBUG_ENV):
        import traceback

        if sys.exc_info()[1] is not None:
            traceback.print_exc()
        else:
            here = inspect.currentframe()
            traceback.print_stack(here.f_back if here is not None else None)
    parts = [line.strip() for line in str(message).splitlines() if line.strip()]
    click.echo(f"error: {'; '.join(parts)}", err=True)
    sys.exit(code)


def flag_names(ctx: click.Context | None, message: str) -> str:
    """``message`` with the command's parameter names (``force_n``) replaced by the
    option that sets them (``--force``) and a leading argument name by its metavar."""
    if ctx is None or ctx.command is None:
        return message
    for param in ctx.command.params:
        if not param.name:
            continue
        if isinstance(param, click.Option) and param.opts:
            flag = max(param.opts, key=len)
            message = re.sub(rf"(?<![\w.\[-]){re.escape(param.name)}\b", flag, message)
        elif isinstance(param, click.Argument) and message.startswith(f"{param.name}:"):
            message = param.make_metavar(ctx) + message[len(param.name) :]
    return message


@contextmanager
def user_errors():
    """Turn bad rig files, bad parameters and unknown or ambiguous ids into one clear
    message naming the CLI flag, and exit 2."""
    from daq.procedures.params import ParameterError
    from daq.store.run_records import AmbiguousRunId

    ctx = click.get_current_context(silent=True)
    try:
        yield
    except ParameterError as err:
        fail(flag_names(ctx, "; ".join(err.lines())))
    except AmbiguousRunId as err:
        fail(str(err))
    except ValueError as err:
        # A bad rig file; daq.config (pydantic) is loaded only if the block used it.
        config = sys.modules.get("daq.config")
        if config is None or not isinstance(err, config.RigConfigError):
            raise
        fail(str(err))
    except KeyError as err:  # RunNotFound and friends carry their own message
        fail(err.args[0] if err.args else str(err))


def check_database_folder(db_url: str | None) -> None:
    """Exit 2 when ``--db`` names a SQLite file whose folder does not exist (a typo would
    otherwise create folders and record there); only the default database's folder is
    made on first use."""
    if not db_url:
        return
    from daq.store.faults import sqlite_file_of

    file = sqlite_file_of(db_url)  # None for a URL the store cannot read: it says why
    if file is not None and not file.parent.is_dir():
        fail(
            f"--db: the folder {file.parent} of database {file.name} does not exist "
            "(allowed: a SQLite file in an existing folder; create the folder first)"
        )


def open_store(db_url: str | None):
    """Open the database; runs left ``running`` by a dead process become ``interrupted``."""
    from daq.collector import no_collections_while_loading

    with no_collections_while_loading():  # the store's modules and SQLAlchemy load here
        from daq.store import Store
        from daq.store.faults import StorageUnavailable, describe, opening_reason

        check_database_folder(db_url)
        with user_errors():
            try:
                store = Store(db_url)
            except Exception as err:  # a bad URL or unreachable server (DatabaseNotOpened)
                fail(f"--db: cannot open the database: {opening_reason(err)}")

    try:
        recovered = store.recover_interrupted()  # only runs whose owning process is gone
    except (StorageUnavailable, OSError) as err:  # storage failing: reads still work
        click.echo(
            f"warning: runs left running by a dead process not marked: storage failed: "
            f"{describe(err).message}",
            err=True,
        )
        recovered = []
    if recovered:
        click.echo(
            f"marked {len(recovered)} run(s) left running by a dead process as interrupted",
            err=True,
        )
    return store


def report_folder(path: str | None) -> str | None:
    """Create a ``--report`` folder before any work, so a bad path fails at once."""
    if path:
        from pathlib import Path

        Path(path).mkdir(parents=True, exist_ok=True)
    return path


def echo_json(data: Any) -> None:
    click.echo(json.dumps(data, indent=2, default=str))


class ProgressView:
    """A rich progress bar on a terminal, nothing under ``--json``."""

    def __init__(self, enabled: bool, title: str) -> None:
        self.enabled = enabled and sys.stderr.isatty()
        self._bar: RichProgress | None = None
        self._task: TaskID | None = None
        self.title = title
        self.last: Progress | None = None

    def __enter__(self) -> ProgressView:
        if self.enabled:
            from rich.progress import BarColumn, TextColumn, TimeElapsedColumn
            from rich.progress import Progress as Bar

            self._bar = bar = Bar(
                TextColumn("[bold]{task.description}"),
                BarColumn(),
                TextColumn("{task.percentage:>3.0f}%"),
                TimeElapsedColumn(),
                TextColumn("{task.fields[message]}"),
                transient=False,
            )
            bar.__enter__()
            self._task = bar.add_task(self.title, total=1.0, message="")
        return self

    def __call__(self, p: Progress) -> None:
        self.last = p
        if self._bar is not None and self._task is not None:
            self._bar.update(self._task, completed=p.fraction, message=p.message)

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.__exit__(None, None, None)


def run_with_signals(main: Callable[[AbortSignal], Awaitable[T]]) -> T:
    """Run ``main(abort)`` on a fresh event loop; SIGINT/SIGTERM set ``abort``.

    The procedure then ends the run as ``aborted`` and the session leaves the rig
    safe (thrusters zero, brakes on) before the process exits.
    """

    import asyncio
    import signal

    from daq.procedures.recording import AbortSignal

    async def runner() -> T:
        loop = asyncio.get_running_loop()
        abort = AbortSignal()
        for sig, name in ((signal.SIGINT, "SIGINT"), (signal.SIGTERM, "SIGTERM")):
            loop.add_signal_handler(sig, abort.set, f"operator abort ({name})")
        try:
            return await main(abort)
        finally:
            for sig in (signal.SIGINT, signal.SIGTERM):
                loop.remove_signal_handler(sig)

    return asyncio.run(runner())


def plus_minus(estimate: dict) -> str:
    """``value ± std`` of a result's {value, std} (``—`` when there is no value)."""
    if estimate.get("value") is None:
        return "—"
    std = estimate.get("std")
    return f"{estimate['value']:.5g} ± {std:.2g}" if std is not None else f"{estimate['value']:.5g}"


def number(x: float | None) -> str:
    """Three significant digits, ``—`` for a missing number."""
    return "—" if x is None else f"{x:.3g}"
