"""``rig sim``: run the simulated rig standalone until SIGINT/SIGTERM.

When ready it prints exactly one JSON line on stdout (schema in
``docs/simulated-rig.md``) that other lab tools parse for the endpoints.
"""

from __future__ import annotations

import asyncio
import json
import os
import signal
import sys
from pathlib import Path
from typing import Any

import click

from api.cli.command_table import rig_command
from daq.config import RigConfig, RigConfigError, load_rig
from daq.priority import SIMULATOR_PRIORITY, set_realtime
from daq.sim.scenario import load_scenario
from daq.sim.simulated_rig import SimEndpoints, SimulatedRig


def ready_line(rig: RigConfig, ep: SimEndpoints) -> dict[str, Any]:
    """The JSON document ``rig sim`` prints when it is ready."""
    if ep.modbus_transport == "tcp":
        modbus: dict[str, Any] = {"transport": "tcp", "host": ep.host, "port": ep.port}
    else:
        mb = rig.modbus
        modbus = {
            "transport": "rtu",
            "serial_port": ep.serial_port,
            "baudrate": mb.baudrate,
            "parity": mb.parity,
            "stopbits": mb.stopbits,
            "bytesize": mb.bytesize,
        }
    modbus["unit_id"] = ep.unit_id
    registers = {
        ch.name: {
            "kind": ch.kind,
            "address": ch.address,
            "type": ch.type,
            "word_order": ch.word_order,
            "scale": ch.scale,
            "offset": ch.offset,
            "unit": ch.unit,
            "wraps": ch.wraps,
            "sim_only": ch.sim_only,
        }
        for ch in rig.channels
    }
    return {
        "modbus": modbus,
        "thrusters": {
            "serial_port": ep.thruster_serial_port,
            "baudrate": ep.thruster_baudrate,
            "count": ep.thruster_count,
        },
        "registers": registers,
        "pid": os.getpid(),
    }


async def _serve(sim: SimulatedRig) -> None:
    # It stands in for devices with their own CPU: real-time where the OS allows (as the
    # session raises its in-process simulator), so a busy host does not make it answer late.
    set_realtime(SIMULATOR_PRIORITY, warn=False)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    try:
        endpoints = await sim.start()
    except (OSError, RuntimeError) as err:
        raise click.ClickException(_listen_error(sim, err)) from None
    try:
        sys.stdout.write(json.dumps(ready_line(sim.rig, endpoints)) + "\n")
        sys.stdout.flush()
        await stop.wait()
    finally:
        await sim.stop()


def _listen_error(sim: SimulatedRig, err: BaseException) -> str:
    if sim.rtu_mode:
        return f"cannot serve Modbus RTU on a pty: {err}"
    return (
        f"--modbus-port: cannot listen on {sim.host}:{sim.modbus_port} "
        f"(in use or not allowed; use another port, or 0 for any free port)"
    )


@rig_command()
@click.option(
    "--rig",
    "rig_file",
    type=click.Path(path_type=Path, dir_okay=False),
    default=None,
    help="Rig file (default: fixtures/rigs/benbam.toml).",
)
@click.option(
    "--scenario",
    "scenario_file",
    type=click.Path(path_type=Path, dir_okay=False),
    default=None,
    help="Scenario file: coefficients, effects, sensor realism (default: clean).",
)
@click.option(
    "--modbus-port",
    type=click.IntRange(0, 65535),
    default=5020,
    show_default=True,
    help="Modbus TCP port; 0 picks any free port.",
)
@click.option("--host", default="127.0.0.1", show_default=True, help="Address to listen on.")
@click.option("--rtu", is_flag=True, help="Serve Modbus RTU on a pty instead of Modbus TCP.")
def sim(
    rig_file: Path | None, scenario_file: Path | None, modbus_port: int, host: str, rtu: bool
) -> None:
    """Run the simulated rig (plant, Modbus PLC, thruster controller) until Ctrl-C.

    Prints one JSON line with the endpoints and the register map when ready.
    """
    try:
        rig = load_rig(rig_file)
        scenario = load_scenario(scenario_file)
    except RigConfigError as err:
        click.echo(f"error: {err}", err=True)
        sys.exit(2)
    simulated = SimulatedRig(rig, scenario, modbus_port=modbus_port, host=host, rtu=rtu)
    try:
        asyncio.run(_serve(simulated))
    except click.ClickException as err:
        click.echo(f"error: {err.message}", err=True)
        sys.exit(2)
