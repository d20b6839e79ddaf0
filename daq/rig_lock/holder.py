"""Who holds a rig's lease, and the refusal a second driver gets."""

from __future__ import annotations

import os
import socket
import sys
import time
from dataclasses import dataclass
from pathlib import Path

#: PostgreSQL keeps ``application_name`` to 63 bytes.
PG_NAME_BYTES = 63

#: How the reason of a run (and the session's fault) begins when the lease was lost.
LOCK_LOST = "rig lock lost"


@dataclass(frozen=True)
class LockHolder:
    """Who holds a rig: the program, its process and host, since when, doing what."""

    program: str
    pid: int
    host: str
    since: float  # Unix time, s
    activity: str | None = None

    def describe(self) -> str:
        """```rig serve` pid 1234 on host lab-pc since 2026-11-23 16:02:11 (tow 24.5 N)``"""
        when = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(self.since))
        text = f"`{self.program}` pid {self.pid} on host {self.host} since {when}"
        return text + (f" ({self.activity})" if self.activity else "")

    # -- compact form for PostgreSQL's application_name (63 bytes) -------------------------
    def to_pg_name(self) -> str:
        fields = [str(self.pid), str(int(self.since)), self.program, self.host[:24]]
        text = "|".join(f.replace("|", "/") for f in fields)
        if self.activity:
            text += "|" + self.activity.replace("|", "/")
        return text.encode()[:PG_NAME_BYTES].decode(errors="ignore")

    @classmethod
    def from_pg_name(cls, text: str, fallback_pid: int) -> LockHolder:
        parts = text.split("|", 4)
        if len(parts) < 4 or not parts[0].isdigit() or not parts[1].isdigit():
            return cls(text or "unknown program", fallback_pid, "unknown", time.time())
        activity = parts[4] if len(parts) > 4 and parts[4] else None
        return cls(parts[2], int(parts[0]), parts[3], float(parts[1]), activity)


def this_process(program: str | None = None) -> LockHolder:
    """A holder description of this process (``program`` defaults to ``rig <command>``)."""
    return LockHolder(program or program_name(), os.getpid(), socket.gethostname(), time.time())


def program_name() -> str:
    """``rig tow`` for the CLI, else the script's name."""
    script = Path(sys.argv[0]) if sys.argv and sys.argv[0] else Path("python")
    name = script.parent.name if script.name == "__main__.py" else script.name
    if name == "rig" and len(sys.argv) > 1:
        return f"rig {sys.argv[1]}"
    return name


class RigInUse(RuntimeError):
    """Another process (or session) holds one of the rig's devices."""

    def __init__(self, rig_name: str, holder: LockHolder | None, device: str = "") -> None:
        self.rig_name = rig_name
        self.holder = holder
        self.device = device
        who = holder.describe() if holder else "another process (it is just starting)"
        what = f" ({device})" if device else ""
        super().__init__(f"rig '{rig_name}'{what} is in use by {who}")


class RigLockError(RuntimeError):
    """The lease cannot be taken at all (its lock folder unusable, say): one line."""
