"""What a run's stored events say, as types: the release, the brake or the catch, and
the thruster outputs the controller confirmed.

Procedures write these as events whose ``data`` carries an ``action`` (a
:class:`RunAction`) and its fields (``RecordedRun.event(..., action=RunAction.RELEASE,
t_mono=…)``); the loaders read them back here, once, instead of looking keys up::

    events = RunEvents.of(store.events(run_id))
    events.release_time          # host monotonic s of the release, or None
    events.brake.t_last_free     # last sample still moving freely (if braked)

Times are the host's monotonic clock (``time.monotonic()``), s.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from daq.store.records import EventInfo


class RunAction(StrEnum):
    """What a run event records (its ``data["action"]``)."""

    RELEASE = "release"  # brake/latch let go, or thrust switched on
    BRAKE = "brake"  # a tow or spin stopped: brake engaged
    CATCH = "catch"  # a pendulum caught and held
    THRUST_STEPS = "thrust_steps"  # the outputs the thruster controller confirmed
    THRUSTER_FAULT = "thruster_fault"
    DISARM_FAILED = "disarm_failed"
    SAFE_STATE = "safe_state"  # every ending: brakes engaged, thrusters zero (or what failed)


def _number(data: Mapping[str, Any], key: str) -> float | None:
    value = data.get(key)
    return None if value is None else float(value)


@dataclass(frozen=True)
class Release:
    """The release: between the write (``t_mono − t_half_width``) and its acknowledgement
    (``t_mono + t_half_width``); ``seq`` the latest sample when it was written."""

    t_mono: float
    t_half_width: float = 0.0
    seq: int | None = None


@dataclass(frozen=True)
class Halt:
    """A brake (tow, spin) or a catch (pendulum): when it was written (``t_mono``), the
    host time of the last sample still free (``t_last_free``) and its ``seq``."""

    t_mono: float | None = None
    t_last_free: float | None = None
    seq: int | None = None


@dataclass(frozen=True)
class ThrustStep:
    """One change of the thruster outputs: the command's send and reply instants and the
    output fraction per thruster (−1…1) the controller confirmed."""

    sent: float
    acked: float
    fractions: tuple[float, ...]

    @property
    def t_mono(self) -> float:
        """When the change took effect: mid-way between sending and the reply."""
        return (self.sent + self.acked) / 2


@dataclass(frozen=True)
class RunEvents:
    """A run's typed events; each is the first of its action (None: not recorded, as for
    imported runs and for thrust steps of runs recorded before they were stored)."""

    release: Release | None = None
    brake: Halt | None = None
    catch: Halt | None = None
    thrust_steps: tuple[ThrustStep, ...] | None = None

    @property
    def release_time(self) -> float | None:
        """Host monotonic time of the release, s (None: not recorded)."""
        return None if self.release is None else self.release.t_mono

    def halt(self, action: RunAction) -> Halt | None:
        """The brake or the catch."""
        if action is RunAction.BRAKE:
            return self.brake
        if action is RunAction.CATCH:
            return self.catch
        raise ValueError(f"action: got {action!r}, allowed: brake, catch")

    @classmethod
    def of(cls, events: Iterable[EventInfo]) -> RunEvents:
        """Read a run's stored events (in time order); other events are left out."""
        found: dict[str, Any] = {}
        for event in events:
            data = event.data or {}
            action = data.get("action")
            if action in found:
                continue
            if action == RunAction.RELEASE:
                t_mono = _number(data, "t_mono")
                if t_mono is None:
                    continue  # a release without its instant tells nothing
                found[action] = Release(
                    t_mono, _number(data, "t_half_width") or 0.0, _seq(data.get("seq"))
                )
            elif action in (RunAction.BRAKE, RunAction.CATCH):
                found[action] = Halt(
                    _number(data, "t_mono"), _number(data, "t_last_free"), _seq(data.get("seq"))
                )
            elif action == RunAction.THRUST_STEPS:
                found[action] = tuple(
                    ThrustStep(float(sent), float(acked), tuple(float(f) for f in fractions))
                    for sent, acked, fractions in data.get("steps", [])
                )
        return cls(
            release=found.get(RunAction.RELEASE),
            brake=found.get(RunAction.BRAKE),
            catch=found.get(RunAction.CATCH),
            thrust_steps=found.get(RunAction.THRUST_STEPS),
        )


def _seq(value: Any) -> int | None:
    return None if value is None else int(value)
