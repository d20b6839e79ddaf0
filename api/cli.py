"""The ``rig`` command: one entry point, one module per command group.

Every command takes ``--db URL`` (default: ``RIG_DATABASE_URL`` or the SQLite file
documented in the README) where it touches storage, and ``--json`` where a script
may want to read its output.
"""

from __future__ import annotations

import click

from api import (
    cli_analysis,
    cli_crosscheck,
    cli_estimate,
    cli_procedures,
    cli_runs,
    cli_serve,
    cli_sim,
    cli_sixdof,
)


@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(package_name="towrig", prog_name="rig")
def main() -> None:
    """Run the underwater-vehicle test rig: tow, spin and pendulum tests, thrust calibration,
    sequences, stored runs, estimation, the simulated rig and the HTTP service."""


for command in (
    cli_procedures.tow,
    cli_procedures.spin,
    cli_procedures.pendulum,
    cli_procedures.calibrate_thrusters,
    cli_procedures.sequence,
    cli_runs.runs,
    cli_runs.show,
    cli_runs.export,
    cli_runs.import_,
    cli_estimate.estimate,
    cli_crosscheck.crosscheck,
    cli_sim.sim,
    cli_serve.serve,
    cli_serve.token,
    cli_sixdof.sixdof,
    cli_analysis.sensitivity,
):
    main.add_command(command)


if __name__ == "__main__":
    main()
