"""Losing the lease on the rig's devices, as a fault of the session that held it.

The lease's renewal thread (``daq.rig_lock``) reports a loss; on the session's event loop
this then, once: sets the thrust target to zero (the thruster supervisor sends it at the
next tick), calls every fault listener with the reason (a recorded run's, a job's or the
CLI's abort signal: the procedure stops wherever it waits and its run ends ``aborted``
naming the lost lock), and closes the session — its ``close`` puts the thrusters at zero
and the brakes on first, then closes every device and gives the lease back — after which
``released`` is set. The same ending as a lost PLC, and within one renewal interval
(0.2 s) plus the time to command zero and write the brake coils.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable

from daq.rig_lock import RigLease

log = logging.getLogger(__name__)


class LeaseFault:
    """Watches one session's lease; ``reason`` is why it was lost (None while held)."""

    def __init__(self) -> None:
        self.reason: str | None = None
        #: Set once the session closed its devices and gave the lease back after the loss.
        self.released = asyncio.Event()
        self._listeners: list[Callable[[str], object]] = []
        self._closing: asyncio.Future | None = None  # a strong reference to the close

    def arm(
        self, lease: RigLease, zero_thrust: Callable[[], None], close: Callable[[], Awaitable]
    ) -> None:
        """Before the lease is taken, on the session's loop: report its loss there."""
        loop = asyncio.get_running_loop()
        self.reason = None
        self.released.clear()

        def lost(reason: str) -> None:
            if self.reason is not None:
                return
            self.reason = reason
            log.error("%s: thrusters to zero, brakes on, devices released", reason)
            zero_thrust()
            for listener in list(self._listeners):
                try:
                    listener(reason)
                except Exception:
                    log.exception("fault listener failed")
            self._closing = asyncio.ensure_future(close())
            self._closing.add_done_callback(lambda _: self.released.set())

        lease.on_lost = lambda reason: loop.call_soon_threadsafe(lost, reason)

    def add_listener(self, listener: Callable[[str], object]) -> Callable[[], None]:
        """Call ``listener(reason)`` on a loss (at once if it already happened); returns
        the function that removes it."""
        self._listeners.append(listener)
        if self.reason is not None:
            listener(self.reason)
        return lambda: self._listeners.remove(listener)
