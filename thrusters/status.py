"""What the thruster driver reports: its errors, faults, controller status and the output
steps the controller confirmed, and how a missing reply is described (pure, no I/O)."""

from __future__ import annotations

from dataclasses import dataclass

from thrusters import protocol as p
from thrusters.link import LinkStats

#: Consecutive frames without a valid reply (timeout, bad CRC, garbage, I/O error, or a
#: ``NAK crc``/``NAK malformed`` saying our frame arrived spoiled) after which the link
#: counts as lost: one lost reply is ridden out, two are not. The fault is seen at most
#: one heartbeat + 2 × ``ack_timeout_s`` after it began (0.3 s at 10 Hz and 0.1 s; see
#: docs/thruster-protocol.md, "Link supervision").
LINK_LOST_AFTER = 2

#: NAK reasons that mean the controller got our frame spoiled: the line, not the request.
LINE_NAKS = frozenset({"crc", "malformed"})


class ThrusterError(RuntimeError):
    """The controller refused or did not answer an operator-level request."""


class NoReply(ThrusterError):
    """The controller did not answer within ``ack_timeout_s``."""


@dataclass(frozen=True, slots=True)
class ThrusterFault:
    """Why thrust can no longer be trusted: the link was lost or the controller's watchdog
    tripped. ``t_confirmed`` is the host monotonic time the controller last confirmed its
    outputs, ``outputs`` what it confirmed then (fractions of full scale)."""

    kind: str  # "link_lost" | "watchdog"
    reason: str
    t_detected: float
    t_confirmed: float
    outputs: tuple[float, ...]

    def to_json(self) -> dict:
        return {
            "fault": self.kind,
            "t_detected": self.t_detected,
            "t_thrust_confirmed": self.t_confirmed,
            "confirmed_outputs": list(self.outputs),
        }


@dataclass(frozen=True, slots=True)
class ThrusterStatus:
    """Answer to a query: controller state, measured RPM and motor current (A) per thruster."""

    state: str
    rpm: tuple[float, ...]
    current_a: tuple[float, ...]
    t_mono: float


@dataclass(frozen=True, slots=True)
class OutputStep:
    """One change of the controller's outputs: host monotonic times just before the frame
    went out and when its reply came back (the change happened in between), and the
    outputs after it as fractions of full scale."""

    t_sent: float
    t_acked: float
    fractions: tuple[float, ...]

    def to_json(self) -> list:
        return [self.t_sent, self.t_acked, list(self.fractions)]


def miss_cause(reply: p.Reply | None, before: LinkStats, after: LinkStats) -> str:
    """What kept one frame from getting a valid reply, from the link counters."""
    if reply is not None:
        return f"controller got our frame spoiled: NAK {reply.reason}"
    if after.io_errors > before.io_errors:
        return "I/O error on the port"
    causes = []
    if after.corrupt_lines > before.corrupt_lines:
        causes.append("bad CRC")
    if after.garbage_lines > before.garbage_lines:
        causes.append("garbage")
    if after.unexpected_replies > before.unexpected_replies:
        causes.append("reply to another frame")
    return ", ".join(causes) or "no reply within ack_timeout_s"


def describe_reply(reply: p.Reply | None) -> str:
    if reply is None:
        return "no reply (timeout or line error)"
    if reply.kind == "NAK":
        return f"NAK {reply.reason}"
    return f"{reply.kind} {reply.state}"
