"""The rig's safe state: brakes engaged (release coils cleared) and thrusters at zero, and
what putting the rig in it did, as every run's ending records it."""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Protocol

from daq.clock import Clock

log = logging.getLogger(__name__)

#: Brakes the safe state engages (those the rig file lists).
RELEASE_CHANNELS = ("tow_release", "spin_release")
#: How long the safe state keeps writing a brake that fails (a late reply, a PLC that
#: reconnects) before it gives up and the run's ending says so, s.
BRAKE_RETRY_S = 2.0
#: Pause between two tries of a failed brake write (each try is itself a write that keeps
#: trying for what is left of ``BRAKE_RETRY_S``), s.
BRAKE_RETRY_PAUSE_S = 0.05


class BrakeCoils(Protocol):
    """What engaging a brake needs of the PLC client (``daq.plc.PlcClient``)."""

    @property
    def connected(self) -> bool: ...

    async def write(self, name: str, value: float | bool, *, within_s: float) -> None: ...


async def engage_brake(
    plc: BrakeCoils, name: str, clock: Clock, *, within_s: float = BRAKE_RETRY_S
) -> str | None:
    """Clear the release coil ``name`` (the brake engages), trying again while it fails for
    up to ``within_s`` s (waiting out a reconnect too; each write keeps trying for what is
    left of that window, no longer). ``None`` once written, else the last failure in one
    line (logged as a warning, never with a traceback): the safety path escalates by saying
    so in the run's ending, not by raising."""
    give_up_at = clock.now() + within_s
    tries = 0
    while True:
        tries += 1
        try:
            if plc.connected:
                await plc.write(name, False, within_s=max(0.0, give_up_at - clock.now()))
                if tries > 1:
                    log.warning("brake %s engaged at try %d", name, tries)
                return None
            error = "PLC not connected"
        except Exception as err:  # a DeviceError, or anything odd from the transport
            error = str(err).splitlines()[0] if str(err) else type(err).__name__
        if clock.now() + BRAKE_RETRY_PAUSE_S > give_up_at:
            line = f"{error} (brake not engaged after {tries} tries in {within_s:g} s)"
            log.warning("brake %s: %s", name, line)
            return line
        await clock.sleep(BRAKE_RETRY_PAUSE_S)


@dataclass(frozen=True)
class SafeState:
    """What putting the rig in its safe state did: the release coils cleared (brakes
    engaged), whether the thrusters were confirmed at zero, and what failed."""

    brakes_engaged: tuple[str, ...]
    thrusters_zero: bool | None  # None: the rig has no thrusters
    errors: tuple[str, ...] = ()

    def describe(self) -> str:
        """``safe state: brake engaged (tow_release cleared); thrusters at zero``."""
        parts = []
        if self.brakes_engaged:
            parts.append(f"brake engaged ({', '.join(self.brakes_engaged)} cleared)")
        if self.thrusters_zero is not None:
            parts.append(
                "thrusters at zero" if self.thrusters_zero else "thrusters NOT confirmed at zero"
            )
        text = "safe state: " + ("; ".join(parts) or "nothing to engage")
        return text + (f"; failed: {'; '.join(self.errors)}" if self.errors else "")
