"""``rig capabilities``: what the rig file's rig can do, and why not the rest."""

from __future__ import annotations

import click

from api.cli.command_table import rig_command
from api.cli.common import echo_json, json_option, rig_option, user_errors


@rig_command()
@rig_option
@json_option
def capabilities(rig_file: str | None, as_json: bool) -> None:
    """What the rig can do: each test (and drive), or why not; the safety channels it uses."""
    from daq.config import load_rig
    from daq.procedures.run_kinds import RIG_KINDS, capabilities
    from daq.rig_capabilities import safety

    with user_errors():
        rig = load_rig(rig_file)
    if as_json:
        echo_json(
            {
                "rig": rig.rig.name,
                "capabilities": capabilities(rig),
                "safety": {name: c.to_json() for name, c in safety(rig).items()},
            }
        )
        return
    click.echo(f"rig {rig.rig.name!r}")
    for spec in RIG_KINDS.values():
        drives: list[str | None] = [*spec.drives] or [None]  # None: the kind's one way
        for drive in drives:
            can = spec.capability(rig, drive)
            flag = f" --{drive}" if drive == "thrusters" else ""
            what = f"rig {spec.command}{flag}"
            click.echo(f"  {what:<28} " + ("yes" if can.available else f"no: {can.reason}"))
    for name, c in safety(rig).items():
        click.echo(f"  {name:<28} " + ("used" if c.available else c.reason or ""))
