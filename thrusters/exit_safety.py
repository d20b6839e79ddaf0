"""The thruster driver's last lines of defence: zero and disarm on SIGINT/SIGTERM, and
zero frames written synchronously at interpreter exit when the driver was never closed.

A collaborator of ``ThrusterDriver`` with its own state (the signal task, whether the exit
hook is registered); it uses only the driver's public face (:class:`Zeroable`).
"""

from __future__ import annotations

import asyncio
import atexit
import logging
import os
import signal
from collections.abc import Callable
from typing import Protocol

log = logging.getLogger("thrusters.driver")


class Zeroable(Protocol):
    """What exit safety needs of a driver."""

    #: Why commands are held at zero, or None.
    inhibited: str | None

    @property
    def is_open(self) -> bool: ...

    async def close(self) -> None:
        """Command zero, disarm, close the port (never raises)."""

    def write_zero_frames(self) -> None:
        """Write zero and DISARM frames synchronously, awaiting no reply."""


class ExitSafety:
    """Zero on signals and at exit (see the module docstring) for ``driver``."""

    def __init__(self, driver: Zeroable) -> None:
        self.driver = driver
        self._signal_task: asyncio.Task[None] | None = None

    def register_at_exit(self) -> None:
        """Write zero frames at interpreter exit unless :meth:`unregister_at_exit` first."""
        atexit.register(self.zero_at_exit)

    def unregister_at_exit(self) -> None:
        atexit.unregister(self.zero_at_exit)

    def zero_at_exit(self) -> None:
        """Last resort at interpreter exit: write zero and DISARM frames synchronously."""
        if not self.driver.is_open:
            return
        try:
            self.driver.write_zero_frames()
            log.warning("thrusters: zero frame written at exit (driver was not closed)")
        except Exception as err:
            log.error("thrusters: zero at exit failed: %s", err)

    def install_signal_handlers(
        self,
        loop: asyncio.AbstractEventLoop | None = None,
        *,
        then: Callable[[int], None] | None = None,
    ) -> None:
        """On SIGINT/SIGTERM: zero and disarm (``close()``), then call ``then(signum)`` —
        by default restore the default handler and re-raise the signal, so the process
        exits as the signal asked, thrusters already at zero."""
        loop = loop or asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, self._on_signal, loop, sig, then)

    def _on_signal(
        self, loop: asyncio.AbstractEventLoop, sig: int, then: Callable[[int], None] | None
    ) -> None:
        if self._signal_task is None:
            log.warning("thrusters: signal %d: zeroing before exit", sig)
            self.driver.inhibited = "shutting down"
            self._signal_task = loop.create_task(self._shutdown(loop, sig, then))

    async def _shutdown(
        self, loop: asyncio.AbstractEventLoop, sig: int, then: Callable[[int], None] | None
    ) -> None:
        await self.driver.close()
        if then is not None:
            then(sig)
            return
        for s in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(s)
        signal.signal(sig, signal.SIG_DFL)
        os.kill(os.getpid(), sig)
