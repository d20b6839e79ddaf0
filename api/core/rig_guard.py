"""Who may move the rig now: the emergency-stop latch and the hold (a lock with a key).

After an emergency stop the rig refuses motion until a named operator acknowledges it, as
lab practice expects (the stop itself may come from anyone, even without a token: it only
makes the rig safer). A person at the tank can *hold* the rig for local work, with a
reason: while held, starts by anyone else are refused (423) naming the holder and why;
the holder releases it, or another operator overrides, which the log names.

The state lives in the database's safety log (``rig_events``), read at each check, so a
hold or an acknowledgement made with the ``rig`` command reaches a running ``rig serve``,
and an unacknowledged stop outlives a restart. A change made through the service is also
published on its live stream (a ``guard`` event), so every open page shows it at once; one
made with the ``rig`` command reaches the pages at their next poll of ``GET /api/rig``.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Iterator
from typing import Any

from api.core.job_model import JobConflict, iso_time
from api.core.service import RigService, RigUnavailable
from daq.procedures.params import ParameterError
from daq.store.people_and_safety_log import ESTOP, ESTOP_ACK, HOLD, RELEASE, RigEventLog, User

log = logging.getLogger(__name__)

#: Longest hold reason, characters.
MAX_REASON = 200
#: Rigs (by name) stopped in this process whose stop the safety log does not hold yet (being
#: written, or the write failed): motion is refused from memory meanwhile.
_STOPPING: set[str] = set()


class MotionRefused(JobConflict):
    """An emergency stop not yet acknowledged (HTTP 409)."""


class RigHeld(JobConflict):
    """The rig is held by someone else (HTTP 423)."""


def _when(event: dict[str, Any]) -> str:
    return str(iso_time(event["t_wall"]))[:19].replace("T", " ") + " UTC"


def check_reason(reason: Any) -> str:
    """A hold's reason: 1 to ``MAX_REASON`` characters; ``ParameterError`` naming ``reason``."""
    if not isinstance(reason, str) or not reason.strip() or len(reason) > MAX_REASON:
        allowed = f"allowed 1-{MAX_REASON} characters saying why the rig is held, e.g. "
        raise ParameterError([("reason", reason, allowed + "'rigging the vehicle'")])
    return reason.strip()


class RigGuard:
    """The emergency-stop latch and the hold of one rig, kept in its safety log."""

    def __init__(self, log: RigEventLog) -> None:
        self.log = log

    @classmethod
    def of(cls, service: RigService) -> RigGuard:
        if service.store is None:
            raise RigUnavailable("the rig service is not running")
        return cls(RigEventLog(service.store, service.source.rig.rig.name))

    # -- state --------------------------------------------------------------------------
    def estop(self) -> dict[str, Any] | None:
        """The emergency stop not yet acknowledged, or None."""
        return self.log.active(ESTOP, ESTOP_ACK)

    def hold(self) -> dict[str, Any] | None:
        """The hold in force, or None."""
        return self.log.active(HOLD, RELEASE)

    def state(self) -> dict[str, Any]:
        """``{"estop": …, "hold": …}``: each ``{by, at, message}`` or None."""

        def shown(event: dict[str, Any] | None) -> dict[str, Any] | None:
            if event is None:
                return None
            return {
                "by": event["user_name"],
                "at": iso_time(event["t_wall"]),
                "message": event["message"],
            }

        return {"estop": shown(self.estop()), "hold": shown(self.hold())}

    def refusal(self, user_name: str | None) -> JobConflict | None:
        """Why ``user_name`` may not move the rig now (None: it may)."""
        if self.log.rig_name in _STOPPING:
            return MotionRefused(
                "rig refuses motion: an emergency stop is being recorded or could not be; an "
                "operator acknowledges it with POST /api/estop/ack",
                holder="emergency stop",
            )
        stop = self.estop()
        if stop is not None:
            return MotionRefused(
                f"rig refuses motion: emergency stop at {_when(stop)} ({stop['message']}) not "
                "acknowledged; an operator acknowledges it with POST /api/estop/ack, "
                "`rig ack-estop --user NAME` or the button on the Rig page",
                holder="emergency stop",
            )
        held = self.hold()
        if held is not None and held["user_name"] != user_name:
            return RigHeld(
                f"rig is held by {held['user_name']} since {_when(held)}: {held['message']} "
                f"(released by {held['user_name']}, or an operator with override)",
                holder=held["user_name"],
            )
        return None

    def check_start(self, user_name: str | None) -> None:
        """Raise the refusal of :meth:`refusal`, if any."""
        refused = self.refusal(user_name)
        if refused is not None:
            raise refused

    # -- changes ----------------------------------------------------------------------------
    def record_stop(self, user_name: str | None, message: str) -> dict[str, Any]:
        """Latch an emergency stop (whoever pressed it; None: no token given)."""
        return self.log.add(ESTOP, user_name, message)

    def acknowledge(self, user: User, note: str = "") -> dict[str, Any]:
        """A named operator acknowledges the emergency stop; 409 when none is latched."""
        stop = self.estop()
        if stop is None and self.log.rig_name not in _STOPPING:
            raise JobConflict("no emergency stop to acknowledge")
        when = _when(stop) if stop is not None else "now (not recorded)"
        text = f"acknowledged the emergency stop of {when}" + (f": {note}" if note else "")
        event = self.log.add(ESTOP_ACK, user.name, text)
        _STOPPING.discard(self.log.rig_name)
        return event

    def take_hold(self, user: User, reason: Any) -> dict[str, Any]:
        """Hold the rig for ``user``; 423 when someone else holds it."""
        reason = check_reason(reason)
        held = self.hold()
        if held is not None and held["user_name"] != user.name:
            raise self.refusal(user.name) or JobConflict("rig is held")
        return self.log.add(HOLD, user.name, reason)

    def release(self, user: User, override: bool = False) -> dict[str, Any]:
        """Release the hold: its holder, or any operator with ``override`` (logged as
        such); 409 when the rig is not held, 423 for someone else without override."""
        held = self.hold()
        if held is None:
            raise JobConflict("the rig is not held")
        if held["user_name"] == user.name:
            return self.log.add(RELEASE, user.name, "released by the holder")
        if not override:
            raise RigHeld(
                f"rig is held by {held['user_name']}: {held['message']}; only the holder "
                "releases it (an operator may pass override)",
                holder=held["user_name"],
            )
        return self.log.add(
            RELEASE, user.name, f"override: released the hold of {held['user_name']}"
        )


def published_state(service: RigService, guard: RigGuard) -> dict[str, Any]:
    """The guard's :meth:`~RigGuard.state` after a change made through ``service``, sent to
    every client of its live stream (a ``guard`` event): one read answers the request and
    every open page."""
    state = guard.state()
    service.broadcaster.publish_guard(state)
    return state


@contextlib.contextmanager
def latching_stop(service: RigService, user_name: str | None) -> Iterator[None]:
    """Around an emergency stop: motion is refused from the moment it is pressed (in
    memory), and afterwards the stop is recorded in the safety log naming ``user_name``.
    The stop never waits for the database first; if recording fails, motion stays refused
    until an operator acknowledges (fail safe). Once recorded it is published on the live
    stream (:func:`published_state`)."""
    name = service.source.rig.rig.name
    _STOPPING.add(name)
    try:
        yield
    finally:
        who = f" by {user_name}" if user_name else " (no token)"
        try:
            guard = RigGuard.of(service)
            guard.record_stop(user_name, f"emergency stop (API){who}")
        except Exception as err:  # the stop stands; motion stays refused
            log.error("emergency stop not recorded in the safety log: %s", err)
        else:
            _STOPPING.discard(name)
            try:  # the pages see it at their next poll of the rig's status otherwise
                published_state(service, guard)
            except Exception as err:
                log.warning("emergency stop recorded but not sent to the stream: %s", err)
