"""The operator's acts: hanging a weight, returning the carriage, mounting the
thrust stand, pulling the pendulum out.

On a real rig a person does these, asked through the CLI prompt or the API state
``waiting_for_operator``; on the simulated rig the procedure plays the operator
by writing the simulator's documented simulation-only registers.
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Protocol


@dataclass(frozen=True)
class OperatorAct:
    """One thing the operator must do before the procedure goes on."""

    #: hang_tow_weight | hang_spin_weight | return_carriage | (un)mount_thrust_stand |
    #: mount_pendulum | pull_pendulum
    name: str
    instruction: str
    value: float | None = None
    #: A reverse test's rigging: the carriage pushed to the far end (``return_carriage``), the
    #: tow line over the far-end pulley, the spin cord wound the other way (the hang acts).
    reverse: bool = False


class Operator(Protocol):
    async def perform(self, act: OperatorAct) -> None:
        """Return once the act is done; raise to refuse (the procedure aborts)."""


class ChannelWriter(Protocol):
    async def write(self, name: str, value: float | bool) -> None: ...


class OperatorActUnavailable(RuntimeError):
    """The simulated operator cannot play an act: the rig file lacks its sim-only channel."""


#: The simulation-only channel each act of the simulated operator writes.
SIM_CHANNEL = {
    "hang_tow_weight": "sim_tow_weight",
    "hang_spin_weight": "sim_spin_weight",
    "return_carriage": "sim_reset",
    "mount_thrust_stand": "sim_thrust_stand",
    "unmount_thrust_stand": "sim_thrust_stand",
    "mount_pendulum": "sim_pendulum_angle",
    "pull_pendulum": "sim_pendulum_angle",
}


class SimulatedOperator:
    """Plays the operator on the simulated rig through its sim-only registers."""

    def __init__(self, plc: ChannelWriter, *, settle_s: float = 0.2) -> None:
        self._plc = plc
        self._settle_s = settle_s

    async def perform(self, act: OperatorAct) -> None:
        channel = SIM_CHANNEL.get(act.name)
        known = getattr(self._plc, "rig", None)
        if channel is not None and known is not None and not known.has(channel):
            raise OperatorActUnavailable(
                f"simulated operator: cannot {act.name.replace('_', ' ')}: the rig file has no "
                f"sim_only channel {channel!r} (docs/simulated-rig.md)"
            )
        if act.name == "hang_tow_weight":
            await self._plc.write("sim_tow_weight", act.value or 0.0)
            if act.reverse:  # over the far-end pulley (sim_reset leads it back)
                await self._plc.write("sim_tow_reversed", True)
        elif act.name == "hang_spin_weight":
            await self._plc.write("sim_spin_weight", act.value or 0.0)
            if act.reverse:  # the cord wound the other way (sim_reset winds it back)
                await self._plc.write("sim_spin_reversed", True)
        elif act.name == "return_carriage":  # to the start, or pushed to ``value`` m
            if act.value:
                await self._plc.write("sim_carriage_position", act.value)
            else:
                await self._plc.write("sim_reset", True)
        elif act.name == "mount_thrust_stand":
            await self._plc.write("sim_thrust_stand", True)
        elif act.name == "unmount_thrust_stand":
            await self._plc.write("sim_thrust_stand", False)
        elif act.name == "mount_pendulum":  # the vehicle hangs plumb at rest on the rod
            await self._plc.write("sim_pendulum_angle", 0.0)
        elif act.name == "pull_pendulum":  # pulled out to the angle and held there
            await self._plc.write("sim_pendulum_angle", act.value or 0.0)
        else:
            raise ValueError(f"unknown operator act {act.name!r}")
        await asyncio.sleep(self._settle_s)


class PromptOperator:
    """Asks a person and waits for confirmation (CLI prompt, API button).

    ``ask`` shows the instruction and returns once the person confirms; it is the
    only part that differs between the CLI and the HTTP API.
    """

    def __init__(self, ask: Callable[[OperatorAct], Awaitable[None]]) -> None:
        self._ask = ask

    async def perform(self, act: OperatorAct) -> None:
        await self._ask(act)


async def console_ask(act: OperatorAct) -> None:
    """CLI: print the instruction and wait for Enter (in a thread: the clock keeps ticking)."""
    await asyncio.to_thread(
        input, f"\n>>> {act.instruction}\n    Press Enter when done (Ctrl-C aborts) "
    )
