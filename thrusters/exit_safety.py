"""The thruster driver's last lines of defence: zero and disarm on SIGINT/SIGTERM, and
zero frames written synchronously at interpreter exit when the driver was never closed.

A mixin of ``ThrusterDriver``: it uses the driver's link, sequence number, ``close()`` and
``inhibited`` flag, and adds nothing else to its state but the signal task.
"""

from __future__ import annotations

import asyncio
import logging
import os
import signal
from collections.abc import Awaitable, Callable
from typing import TYPE_CHECKING

from thrusters import protocol as p

if TYPE_CHECKING:
    from thrusters.link import SerialLink

log = logging.getLogger("thrusters.driver")


class ExitSafety:
    """Zero on signals and at exit (see the module docstring)."""

    _link: SerialLink
    _seq: int
    count: int
    inhibited: str | None
    _signal_task: asyncio.Task[None] | None
    #: The driver's own: command zero, disarm, close the port (never raises).
    close: Callable[[], Awaitable[None]]

    @property
    def is_open(self) -> bool:
        return self._link.is_open

    def _zero_at_exit(self) -> None:
        """Last resort at interpreter exit: write zero and DISARM frames synchronously."""
        if not self.is_open:
            return
        try:
            self._seq = p.next_seq(self._seq)
            self._link.write_raw(p.thr_frame(self._seq, [0] * self.count))
            self._seq = p.next_seq(self._seq)
            self._link.write_raw(p.disarm_frame(self._seq))
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
            self.inhibited = "shutting down"
            self._signal_task = loop.create_task(self._shutdown(loop, sig, then))

    async def _shutdown(
        self, loop: asyncio.AbstractEventLoop, sig: int, then: Callable[[int], None] | None
    ) -> None:
        await self.close()
        if then is not None:
            then(sig)
            return
        for s in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(s)
        signal.signal(sig, signal.SIG_DFL)
        os.kill(os.getpid(), sig)
