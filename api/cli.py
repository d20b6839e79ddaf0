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
import os
import sys
from typing import Any

import click
from click.utils import make_default_short_help

#: name → (module, attribute, its short help as ``rig --help`` lists it without importing
#: the module: ``get_short_help_str(80)``, checked by tests/api/test_cli_edges.py).
COMMANDS: dict[str, tuple[str, str, str]] = {
    "tow": (
        "api.cli_procedures",
        "tow",
        "Tow test: a weight over the pulley (or the thrusters) pulls the vehicle along...",
    ),
    "spin": (
        "api.cli_procedures",
        "spin",
        "Spin test: constant torque about the vertical axis (weight on the drum, or...",
    ),
    "pendulum": (
        "api.cli_procedures",
        "pendulum",
        "Pendulum free decay: pull the vehicle out on the pendulum, release, record...",
    ),
    "calibrate-thrusters": (
        "api.cli_procedures",
        "calibrate_thrusters",
        "Thrust calibration: step the thrusters on the load cell and fit thrust vs...",
    ),
    "sequence": (
        "api.cli_procedures",
        "sequence",
        "Run a sequence file (tows, spins, calibrations; repeats and rest time).",
    ),
    "runs": ("api.cli_runs", "runs", "List stored runs, newest first."),
    "show": (
        "api.cli_runs",
        "show",
        "Show one run: configuration, how it ended, events and results (id or unique...",
    ),
    "export": (
        "api.cli_runs",
        "export",
        "Export a run's samples (CSV: one row per sample; JSON: metadata + samples).",
    ),
    "import": (
        "api.cli_runs",
        "import_",
        "Import a CSV (columns t [s] and position [m or rad]; more allowed); prints...",
    ),
    "estimate": (
        "api.cli_estimate",
        "estimate",
        "Fit (m + m_a) v̇ + K_L v + K_Q |v| v = τ to stored tow or spin runs (or α, β...",
    ),
    "crosscheck": (
        "api.cli_crosscheck",
        "crosscheck",
        "Estimate weight-driven and thruster-driven runs of one axis (or take two...",
    ),
    "sim": (
        "api.cli_sim",
        "sim",
        "Run the simulated rig (plant, Modbus PLC, thruster controller) until Ctrl-C.",
    ),
    "serve": (
        "api.cli_serve",
        "serve",
        "Serve the HTTP API and the browser UI (binds 127.0.0.1 by default).",
    ),
    "token": (
        "api.cli_serve",
        "token",
        "Print the API's bearer token (created on first use; or set RIG_API_TOKEN).",
    ),
    "sixdof": (
        "api.cli_sixdof",
        "sixdof",
        "Simulate VEHICLE (a name from fixtures/vehicles or $RIG_VEHICLES_DIR, or a...",
    ),
    "sensitivity": (
        "api.cli_analysis",
        "sensitivity",
        "Rank VEHICLE's coefficients (a name from fixtures/vehicles or...",
    ),
}

#: Set to see the traceback of an unexpected error (for bug reports).
DEBUG_ENV = "RIG_DEBUG"


def _user_error_types() -> tuple[type[BaseException], ...]:
    """Exceptions that mean bad input (exit 2), loaded with the modules that raise them."""
    found: list[type[BaseException]] = []
    for module, names in (
        ("daq.store.records", ("RunNotFound", "ResultNotFound", "AmbiguousRunId")),
        ("daq.config", ("RigConfigError",)),
        ("daq.procedures.params", ("ParameterError",)),
    ):
        loaded = sys.modules.get(module)
        found += [getattr(loaded, n) for n in names] if loaded is not None else []
    return tuple(found)


class RigGroup(click.Group):
    """Loads a command's module on first use; turns stray exceptions into one line."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return list(COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        entry = COMMANDS.get(cmd_name)
        if entry is None:
            return None
        module, attr, _ = entry
        return getattr(importlib.import_module(module), attr)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        limit = formatter.width - 6 - max(len(name) for name in COMMANDS)
        rows = [(name, make_default_short_help(h, limit)) for name, (_, _, h) in COMMANDS.items()]
        with formatter.section("Commands"):
            formatter.write_dl(rows)

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except (click.exceptions.Exit, click.ClickException, click.Abort, SystemExit):
            raise
        except KeyboardInterrupt:
            click.echo("error: interrupted", err=True)
            sys.exit(130)
        except _user_error_types() as err:
            from api.cli_common import fail, flag_names

            fail(flag_names(ctx, _one_line(err)))
        except Exception as err:  # a bug, or a fault outside the rig's control
            if os.environ.get(DEBUG_ENV):
                raise
            click.echo(
                f"error: {_one_line(err)} ({type(err).__name__}; set {DEBUG_ENV}=1 for details)",
                err=True,
            )
            sys.exit(1)


def _one_line(err: BaseException) -> str:
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
    main()
