"""Supervision of the thruster link: frames without a valid reply counted, a lost link or
a watchdog trip turned into one ``ThrusterFault`` that a run can wait for.

A mixin of ``ThrusterDriver``: it reads the driver's state (controller state, confirmed
outputs, clock, link counters) and owns the fault, its event and the count of misses.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from typing import TYPE_CHECKING

from thrusters import protocol as p
from thrusters.link import LinkStats
from thrusters.status import LINE_NAKS, LINK_LOST_AFTER, ThrusterFault, miss_cause

if TYPE_CHECKING:
    from thrusters.link import SerialLink

log = logging.getLogger("thrusters.driver")


class LinkSupervision:
    """Lost-link and watchdog detection (see the module docstring)."""

    _link: SerialLink
    clock: Callable[[], float]
    state: str
    inhibited: str | None
    _confirmed: tuple[float, ...]
    _t_confirmed: float
    #: Frames in a row without a valid reply.
    missed_replies: int
    #: The first fault since the last ``arm()`` (link lost, watchdog trip), or None.
    fault: ThrusterFault | None
    _fault_event: asyncio.Event | None

    @property
    def link_lost(self) -> bool:
        return self.fault is not None and self.fault.kind == "link_lost"

    async def wait_fault(self) -> ThrusterFault:
        """Wait until the link is lost or the controller's watchdog trips (since the last
        ``arm()``) and return that fault."""
        if self._fault_event is None:
            self._fault_event = asyncio.Event()
        await self._fault_event.wait()
        assert self.fault is not None
        return self.fault

    def _clear_fault(self) -> None:
        self.fault = None
        self.missed_replies = 0
        if self._fault_event is not None:
            self._fault_event.clear()
        if self.inhibited == "thruster link lost":
            self.inhibited = None

    def _set_fault(self, kind: str, reason: str) -> None:
        if self.fault is not None:
            return
        self.fault = ThrusterFault(kind, reason, self.clock(), self._t_confirmed, self._confirmed)
        log.error("thrusters: %s", reason)
        if self._fault_event is None:
            self._fault_event = asyncio.Event()
        self._fault_event.set()

    def _supervise(self, reply: p.Reply | None, before: LinkStats) -> None:
        """Count frames without a valid reply; ``LINK_LOST_AFTER`` in a row is a lost link:
        commands are then held at zero (``inhibited``) until the next ``arm()``."""
        if reply is not None and reply.reason not in LINE_NAKS:
            self.missed_replies = 0
            return
        self.missed_replies += 1
        if self.missed_replies < LINK_LOST_AFTER or self.fault is not None:
            return
        if self.state != "ARMED":  # nothing to supervise: outputs already zero
            return
        self.inhibited = "thruster link lost"
        cause = miss_cause(reply, before, self._link.stats)
        age = self.clock() - self._t_confirmed
        confirmed = ", ".join(f"{x:+.3f}" for x in self._confirmed)
        self._set_fault(
            "link_lost",
            f"thruster link lost: {self.missed_replies} consecutive replies missing "
            f"({cause}); thrust last confirmed {age:.2f} s before "
            f"(outputs {confirmed}); commanding zero",
        )
