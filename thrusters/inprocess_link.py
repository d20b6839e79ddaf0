"""A thruster link to a simulated controller in the same process (simulated time).

``InProcessLink`` hands each frame to ``ThrusterControllerEmulator.exchange`` and reads
the reply it gives back, classified exactly as ``SerialLink`` classifies a line read off
the port (CRC, garbage, replies to other sequence numbers, NAKs). The driver calls it on
the event loop (``blocking = False``), so the controller's watchdog and the driver run on
one clock. A controller that does not answer (``silent``) costs the reply timeout, as a
read on the link's thread would, waited on the event loop (``wait_on_loop``): the
acquisition, the controller's watchdog and the rest of the loop run on meanwhile.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable

import serial

from thrusters import protocol as p
from thrusters.emulator import ThrusterControllerEmulator
from thrusters.link import SerialLink


class InProcessLink(SerialLink):
    """The thruster line to ``controller``, as function calls; ``clock`` stamps replies."""

    blocking = False

    def __init__(
        self,
        controller: ThrusterControllerEmulator,
        reply_timeout_s: float,
        *,
        clock: Callable[[], float],
        url: str = "inprocess://thrusters",
    ) -> None:
        super().__init__(url, 0, reply_timeout_s, clock=clock)
        self.controller = controller
        #: Time the last ``transact`` owes its caller (s): the reply timeout when unanswered.
        self.owed_s = 0.0

    def open(self) -> None:
        self._wanted = True

    def close(self) -> None:
        self._wanted = False

    def write_raw(self, raw: bytes) -> None:
        if self._wanted:
            self.controller.exchange(raw)

    def transact(self, raw: bytes, seq: int) -> p.Reply | None:
        if not self._wanted:
            raise serial.SerialException(f"thruster link {self.url} is not open")
        t_sent = self._clock()
        self.stats.sent += 1
        self.last_bracket = None
        for line in self.controller.exchange(raw).split(b"\n"):
            if not line.strip():
                continue
            reply = self._classify(line.rstrip(b"\r"), seq)
            if reply is not None:
                self.last_bracket = (t_sent, self._clock())
                return reply
        self.owed_s = self.reply_timeout_s
        self.stats.timeouts += 1
        return None

    async def wait_on_loop(self) -> None:
        owed, self.owed_s = self.owed_s, 0.0
        if owed:
            await asyncio.sleep(owed)
