"""Supervision of the thruster link: frames without a valid reply counted, a lost link or
a watchdog trip turned into one ``ThrusterFault`` that a run can wait for.

A collaborator of ``ThrusterDriver`` with its own state (the count of misses, the fault
and its event): the driver tells it what each frame got and what the controller last
confirmed, and holds its commands at zero when it says the link is lost.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable

from thrusters import protocol as p
from thrusters.link import LinkStats
from thrusters.status import LINE_NAKS, LINK_LOST_AFTER, ThrusterFault, miss_cause

log = logging.getLogger("thrusters.driver")


class LinkSupervisor:
    """Lost-link and watchdog detection (see the module docstring); ``clock`` is the
    driver's monotonic clock, s."""

    def __init__(self, clock: Callable[[], float]) -> None:
        self.clock = clock
        #: Frames in a row without a valid reply.
        self.missed_replies = 0
        #: The first fault since the last ``clear()`` (link lost, watchdog trip), or None.
        self.fault: ThrusterFault | None = None
        self._fault_event: asyncio.Event | None = None

    @property
    def link_lost(self) -> bool:
        return self.fault is not None and self.fault.kind == "link_lost"

    async def wait_fault(self) -> ThrusterFault:
        """Wait until the link is lost or the controller's watchdog trips (since the last
        ``clear()``) and return that fault."""
        if self._fault_event is None:
            self._fault_event = asyncio.Event()
        await self._fault_event.wait()
        assert self.fault is not None
        return self.fault

    def clear(self) -> None:
        """Forget the fault and the misses (the driver opened or armed again)."""
        self.fault = None
        self.missed_replies = 0
        if self._fault_event is not None:
            self._fault_event.clear()

    def report(
        self, kind: str, reason: str, t_confirmed: float, confirmed: tuple[float, ...]
    ) -> None:
        """Record a fault (``link_lost`` | ``watchdog``) unless one is recorded already;
        ``t_confirmed`` (s, driver clock) and ``confirmed`` (fractions of full scale) are
        the outputs the controller last confirmed."""
        if self.fault is not None:
            return
        self.fault = ThrusterFault(kind, reason, self.clock(), t_confirmed, confirmed)
        log.error("thrusters: %s", reason)
        if self._fault_event is None:
            self._fault_event = asyncio.Event()
        self._fault_event.set()

    def observe(
        self,
        reply: p.Reply | None,
        before: LinkStats,
        after: LinkStats,
        *,
        armed: bool,
        t_confirmed: float,
        confirmed: tuple[float, ...],
    ) -> bool:
        """Count a frame's reply (``before``/``after``: the link's counters around it);
        True when this frame lost the link: ``LINK_LOST_AFTER`` in a row without a valid
        reply while ``armed`` (the driver then holds commands at zero until it arms again).
        """
        if reply is not None and reply.reason not in LINE_NAKS:
            self.missed_replies = 0
            return False
        self.missed_replies += 1
        if self.missed_replies < LINK_LOST_AFTER or self.fault is not None:
            return False
        if not armed:  # nothing to supervise: outputs already zero
            return False
        cause = miss_cause(reply, before, after)
        age = self.clock() - t_confirmed
        outputs = ", ".join(f"{x:+.3f}" for x in confirmed)
        self.report(
            "link_lost",
            f"thruster link lost: {self.missed_replies} consecutive replies missing "
            f"({cause}); thrust last confirmed {age:.2f} s before "
            f"(outputs {outputs}); commanding zero",
            t_confirmed,
            confirmed,
        )
        return True
