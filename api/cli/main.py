"""The ``rig`` command: one entry point, one module per command group.

Every command takes ``--db URL`` (default: ``RIG_DATABASE_URL`` or the SQLite file
documented in the README) where it touches storage, and ``--json`` where a script
may want to read its output.

Command modules are imported only when their command runs (``rig --help`` and light
commands such as ``rig token`` never import numpy, scipy or the web stack), and any
error a user's input can cause ends as one ``error: …`` line, never a traceback.
"""

from __future__ import annotations

import importlib
import logging
import os
import sys
import warnings
from collections.abc import Sequence
from typing import Any, NoReturn

import click

from api.cli.command_table import COMMANDS, records_runs, short_helps
from api.cli.common import DEBUG_ENV, RIG_FILE_ENV
from daq.collector import no_collections_while_loading


def _loaded(pairs: tuple[tuple[str, tuple[str, ...]], ...]) -> tuple[type[BaseException], ...]:
    """Exception classes of modules already imported (a command that never imported one
    cannot raise it), so catching them costs no import."""
    found: list[type[BaseException]] = []
    for module, names in pairs:
        loaded = sys.modules.get(module)
        found += [getattr(loaded, n) for n in names] if loaded is not None else []
    return tuple(found)


#: Bad input (exit 2): unknown or ambiguous ids, bad rig files, bad parameters.
USER_ERRORS = (
    ("daq.store.run_records", ("RunNotFound", "ResultNotFound", "AmbiguousRunId")),
    ("daq.config", ("RigConfigError",)),
    ("daq.procedures.params", ("ParameterError",)),
)
#: The rig or a device failed (exit 1: the run, if any, did not complete).
FAULTS = (
    ("daq.plc", ("DeviceError",)),
    ("thrusters.driver", ("ThrusterError",)),
    ("daq.session", ("RigBusy",)),
    ("daq.procedures.motion", ("PreconditionFailed",)),
    ("daq.operator", ("OperatorActUnavailable",)),
    ("daq.store.faults", ("StorageFault",)),
    ("api.core.estimation_failure", ("EstimationFailure",)),
)


class RigGroup(click.Group):
    """Loads a command's module on first use; every error ends as one ``error: …`` line."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return list(COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        entry = COMMANDS.get(cmd_name)
        if entry is None:
            return None
        module, attr = entry
        with no_collections_while_loading():
            command = getattr(importlib.import_module(module), attr)
        if records_runs(cmd_name, module):
            from api.cli.metadata import with_run_metadata

            command = with_run_metadata(command)
        return command

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        limit = formatter.width - 6 - max(len(name) for name in COMMANDS)
        rows = [
            (name, click.Command(name, help=text).get_short_help_str(limit))
            for name, text in short_helps().items()
        ]
        with formatter.section("Commands"):
            formatter.write_dl(rows)
        missing = _not_on_this_rig()
        if missing:
            with formatter.section(f"Not on the rig of ${RIG_FILE_ENV}"):
                formatter.write_dl(missing)

    def main(
        self,
        args: Sequence[str] | None = None,
        prog_name: str | None = None,
        complete_var: str | None = None,
        standalone_mode: bool = True,
        **extra: Any,
    ) -> NoReturn:
        """Click's usage errors as one line (with where to find help), not three."""
        # pymodbus logs each failed connect/bind itself; the command reports it once.
        logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
        if not os.environ.get(DEBUG_ENV):  # numerics' warnings are ours: the error line says it
            warnings.filterwarnings(
                "ignore", category=RuntimeWarning, module=r"(numpy|scipy|estimation)(\.|$)"
            )
        try:
            # errors are reported here, one line each: click's standalone mode is off
            rv = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except click.ClickException as err:
            if os.environ.get(DEBUG_ENV):
                import traceback

                traceback.print_exc()
            hint = ""
            if isinstance(err, click.UsageError) and err.ctx is not None:
                hint = f" (see '{err.ctx.command_path} --help')"
            click.echo(f"error: {_one_line(err.format_message())}{hint}", err=True)
            sys.exit(err.exit_code)
        except click.Abort:
            click.echo("error: aborted", err=True)
            sys.exit(1)
        sys.exit(rv if isinstance(rv, int) else 0)

    def resolve_command(
        self, ctx: click.Context, args: list[str]
    ) -> tuple[str | None, click.Command | None, list[str]]:
        name, cmd, rest = super().resolve_command(ctx, args)
        ctx.meta["rig.command"] = (name, cmd, list(rest))  # to name flags in errors
        return name, cmd, rest

    def invoke(self, ctx: click.Context) -> Any:
        from api.cli.common import fail, flag_names

        try:
            return super().invoke(ctx)
        except (click.exceptions.Exit, click.ClickException, click.Abort, SystemExit):
            raise
        except KeyboardInterrupt:
            fail("interrupted", code=130)
        except _loaded(USER_ERRORS) as err:
            fail(flag_names(_command_context(ctx), _one_line(err)))
        except _loaded(FAULTS) as err:
            fail(_one_line(err), code=1)
        except OSError as err:
            if err.filename is None:
                fail(_one_line(err), code=1)
            where = _option_given(_command_context(ctx), str(err.filename))
            fail(f"{where}cannot use {err.filename}: {err.strerror or err}")
        except Exception as err:  # a bug: say what, and how to see more
            hint = "" if os.environ.get(DEBUG_ENV) else f"; set {DEBUG_ENV}=1 for details"
            fail(f"{_one_line(err)} ({type(err).__name__}{hint})", 1)


def _not_on_this_rig() -> list[tuple[str, str]]:
    """With ``$RIG_FILE`` set: each test its rig cannot do, with why (the rig file is read
    only then, so a plain ``rig --help`` stays light)."""
    path = os.environ.get(RIG_FILE_ENV)
    if not path:
        return []
    from daq.config import RigConfigError, load_rig
    from daq.procedures.run_kinds import RIG_KINDS

    try:
        rig = load_rig(path)
    except RigConfigError as err:
        return [(RIG_FILE_ENV, _one_line(err))]
    rows = []
    for spec in RIG_KINDS.values():
        can = spec.capability(rig)  # with any of its drives
        if not can.available:
            rows.append((str(spec.command), str(can.reason)))
            continue
        for drive in spec.drives:
            can = spec.capability(rig, drive)
            if not can.available:
                rows.append((f"{spec.command} --{drive}", str(can.reason)))
    return rows


def _command_context(ctx: click.Context) -> click.Context | None:
    """The subcommand's context, parsed again from its arguments (the real one is gone
    by the time an error reaches the group)."""
    name, cmd, args = ctx.meta.get("rig.command", (None, None, []))
    if cmd is None:
        return None
    try:
        return cmd.make_context(name, list(args), parent=ctx, resilient_parsing=True)
    except click.ClickException:
        return None


def _option_given(ctx: click.Context | None, path: str) -> str:
    """``--output: `` when the user gave ``path`` (or a folder holding it) to an option."""
    if ctx is None:
        return ""
    for param in ctx.command.params:
        value = ctx.params.get(param.name or "")
        values = value if isinstance(value, tuple | list) else [value]
        for v in values:
            given = str(v).rstrip("/") if v is not None else ""
            if given and (path == given or path.startswith(given + "/")):
                return f"{max(param.opts, key=len)}: " if isinstance(param, click.Option) else ""
    return ""


def _one_line(err: BaseException | str) -> str:
    lines = getattr(err, "lines", None)
    text = "; ".join(lines()) if callable(lines) else str(err)
    return " ".join(text.split()) or type(err).__name__


@click.group(
    cls=RigGroup,
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
)
@click.version_option(package_name="towrig", prog_name="rig")
def main() -> None:
    """Run the underwater-vehicle test rig: tow, spin and pendulum tests, thrust calibration,
    sequences, stored runs, estimation, the simulated rig and the HTTP service."""


if __name__ == "__main__":
    main(prog_name="rig")
