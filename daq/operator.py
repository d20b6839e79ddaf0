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


Writes = list[tuple[str, float | bool]]


@dataclass(frozen=True)
class SimulatedAct:
    """How the simulated operator plays one act: the sim-only channel the rig file must
    list for it (``channel``) and the registers it writes for an act (``writes``)."""

    channel: str
    writes: Callable[[OperatorAct], Writes]


def _hang(weight: str, reversed_: str) -> Callable[[OperatorAct], Writes]:
    """A hung weight (kg); a reverse test's rigging too (``sim_reset`` undoes it)."""
    return lambda act: [(weight, act.value or 0.0)] + ([(reversed_, True)] if act.reverse else [])


#: Every act the simulated operator plays, one entry each (the procedures name them; the
#: registry's entries list theirs, ``KindSpec.acts``).
SIMULATED_ACTS: dict[str, SimulatedAct] = {
    "hang_tow_weight": SimulatedAct("sim_tow_weight", _hang("sim_tow_weight", "sim_tow_reversed")),
    "hang_spin_weight": SimulatedAct(
        "sim_spin_weight", _hang("sim_spin_weight", "sim_spin_reversed")
    ),
    # to the start, or pushed to ``value`` m (a reverse tow's far end)
    "return_carriage": SimulatedAct(
        "sim_reset",
        lambda act: [("sim_carriage_position", act.value)] if act.value else [("sim_reset", True)],
    ),
    "mount_thrust_stand": SimulatedAct(
        "sim_thrust_stand", lambda act: [("sim_thrust_stand", True)]
    ),
    "unmount_thrust_stand": SimulatedAct(
        "sim_thrust_stand", lambda act: [("sim_thrust_stand", False)]
    ),
    # the vehicle hangs plumb at rest on the rod
    "mount_pendulum": SimulatedAct("sim_pendulum_angle", lambda act: [("sim_pendulum_angle", 0.0)]),
    # pulled out to the angle and held there
    "pull_pendulum": SimulatedAct(
        "sim_pendulum_angle", lambda act: [("sim_pendulum_angle", act.value or 0.0)]
    ),
}
#: The simulation-only channel each act of the simulated operator needs.
SIM_CHANNEL = {name: act.channel for name, act in SIMULATED_ACTS.items()}


class SimulatedOperator:
    """Plays the operator on the simulated rig through its sim-only registers."""

    def __init__(self, plc: ChannelWriter, *, settle_s: float = 0.2) -> None:
        self._plc = plc
        self._settle_s = settle_s

    async def perform(self, act: OperatorAct) -> None:
        played = SIMULATED_ACTS.get(act.name)
        if played is None:
            raise ValueError(f"unknown operator act {act.name!r}")
        known = getattr(self._plc, "rig", None)
        if known is not None and not known.has(played.channel):
            raise OperatorActUnavailable(
                f"simulated operator: cannot {act.name.replace('_', ' ')}: the rig file has no "
                f"sim_only channel {played.channel!r} (docs/simulated-rig.md)"
            )
        for channel, value in played.writes(act):
            await self._plc.write(channel, value)
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
