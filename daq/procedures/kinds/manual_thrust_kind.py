"""Manual thrust: one thruster held at a command for a bounded time on the thrust stand."""

from __future__ import annotations

from typing import TYPE_CHECKING

from daq.procedures import requests
from daq.procedures.kind_spec import KindOutcome, KindSpec
from daq.rig_capabilities import Needs
from daq.vocabulary import RunKind

if TYPE_CHECKING:
    from daq.session import RigSession

#: Why a manual thrust run is refused over the API while the thrusters are disarmed.
NOT_ARMED = (
    "thrusters not armed: arm them first (the Arm thrusters button, or POST /api/rig/arm), "
    "then start the manual thrust"
)


async def _run_manual(session, params, *, abort, progress) -> KindOutcome:
    from daq.procedures.manual_thrust import run_manual_thrust

    return KindOutcome(await run_manual_thrust(session, params, abort=abort, progress=progress))


def _not_now(session: RigSession) -> str | None:
    """A remote start of thrust is two deliberate acts, arm then start, and happens now or
    not at all: never queued behind another job to start later, unattended."""
    if session.lock_holder is not None:
        return (
            f"rig is busy: {session.lock_holder} holds the rig lock; a manual thrust run "
            "starts now or not at all (never queued)"
        )
    return None if session.armed else NOT_ARMED


SPEC = KindSpec(
    kind=RunKind.MANUAL_THRUST,
    rank=45,
    label="manual thrust",
    help="Manual thrust: hold one thruster at a command for a bounded time on the thrust "
    "stand, then back to zero.",
    request=requests.ManualThrustRequest,
    run=_run_manual,
    describe=lambda p: (
        f"manual thrust: thruster {p.thruster} at {p.command:+.3g} for {p.duration_s:g} s"
    ),
    command="manual-thrust",
    route="manual-thrust",
    needs=Needs(channels=("load_cell",), thrusters=True),
    acts=("mount_thrust_stand",),
    live=("load_cell", "thrusters"),
    shown=("command", "fraction"),
    refusal=_not_now,
)
