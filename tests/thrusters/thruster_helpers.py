"""Helpers for the thruster tests: a scripted serial peer on a real pty, rig settings."""

from __future__ import annotations

import os
import select
import threading
import time
import tty

from daq.config import Limits, load_rig
from thrusters.config import ThrusterPort

RIG = load_rig()


def thruster_port(port: str, **overrides: object) -> ThrusterPort:
    """The BENBAM rig's [thrusters] section pointed at ``port``."""
    return RIG.thrusters.model_copy(update={"port": port, **overrides})


def limits(**overrides: object) -> Limits:
    """The BENBAM rig's [limits] (max command 0.8, slew 2.0 /s) with overrides."""
    return RIG.limits.model_copy(update=overrides)


class ScriptedPeer:
    """A fake controller on a real pty that expects exact bytes and replies with given
    bytes: ``[(expected_write, reply_or_None), ...]`` (None = stay silent)."""

    def __init__(self, conversation: list[tuple[bytes, bytes | None]]) -> None:
        self.conversation = conversation
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.path = os.ttyname(self._slave)
        self.received: list[bytes] = []
        self.error: str | None = None
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _read_exact(self, n: int, timeout_s: float) -> bytes:
        data = b""
        deadline = time.monotonic() + timeout_s
        while len(data) < n:
            ready, _, _ = select.select([self.master], [], [], max(0, deadline - time.monotonic()))
            if not ready:
                break
            data += os.read(self.master, n - len(data))
        return data

    def _serve(self) -> None:
        for i, (expected, reply) in enumerate(self.conversation):
            got = self._read_exact(len(expected), 3.0)
            self.received.append(got)
            if got != expected:
                self.error = f"step {i}: expected {expected!r}, got {got!r}"
                return
            if reply:
                os.write(self.master, reply)

    def assert_done(self) -> None:
        """Every step happened byte-exact and the host wrote nothing more."""
        self._thread.join(5)
        assert self.error is None, self.error
        assert len(self.received) == len(self.conversation)
        extra = self._read_exact(1, 0.05)
        assert extra == b"", f"host wrote unexpected bytes {extra!r}"
        os.close(self.master)
        os.close(self._slave)


class FakeClock:
    """A monotonic clock the test advances by hand."""

    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t
