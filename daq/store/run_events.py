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

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from daq.store.run_records import EventInfo


class RunAction(StrEnum):
    """What a run event records (its ``data["action"]``)."""

    RELEASE = "release"  # brake/latch let go, or thrust switched on
    BRAKE = "brake"  # a tow or spin stopped: brake engaged
    CATCH = "catch"  # a pendulum caught and held
    THRUST_STEPS = "thrust_steps"  # the outputs the thruster controller confirmed
    THRUSTER_FAULT = "thruster_fault"
    DISARM_FAILED = "disarm_failed"
    SAFE_STATE = "safe_state"  # every ending: brakes engaged, thrusters zero (or what failed)
    SAMPLES_LOST = "samples_lost"  # a gap: consecutive samples lost (``Gap``)


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
class Gap:
    """Consecutive lost samples (``daq.sample_losses``): clock slots ``seq_first``…``seq_last``
    at host times ``t_first``…``t_last`` (s; a missed slot's time is interpolated), ``count``
    of them, for ``reasons``; the good samples around it at ``t_before``/``t_after`` (None:
    the run began or ended in it); ``at_s`` its start from the run's first sample, s."""

    seq_first: int
    seq_last: int
    t_first: float
    t_last: float
    count: int
    reasons: tuple[str, ...]
    t_before: float | None = None
    t_after: float | None = None
    at_s: float = 0.0

    @property
    def hole_s(self) -> float:
        """How long the run went without a good sample here, s (good sample to good sample)."""
        start = self.t_first if self.t_before is None else self.t_before
        end = self.t_last if self.t_after is None else self.t_after
        return end - start

    @property
    def reason(self) -> str:
        return ", ".join(self.reasons)

    def describe(self) -> str:
        """ "7 samples lost in 0.9 s at 12.3 s (PLC read failed)"."""
        noun = "sample" if self.count == 1 else "samples"
        return (
            f"{self.count} {noun} lost in {self.hole_s:.1f} s at {self.at_s:.1f} s ({self.reason})"
        )

    def event_data(self) -> dict[str, Any]:
        """The event's ``data`` (read back by :meth:`RunEvents.of`)."""
        return {"action": str(RunAction.SAMPLES_LOST)} | {
            k: list(v) if isinstance(v, tuple) else v for k, v in self.__dict__.items()
        }

    @classmethod
    def of(cls, data: Mapping[str, Any]) -> Gap:
        """From an event's ``data``."""
        return cls(
            seq_first=int(data["seq_first"]),
            seq_last=int(data["seq_last"]),
            t_first=float(data["t_first"]),
            t_last=float(data["t_last"]),
            count=int(data["count"]),
            reasons=tuple(str(r) for r in data.get("reasons", ())),
            t_before=_number(data, "t_before"),
            t_after=_number(data, "t_after"),
            at_s=float(data.get("at_s", 0.0)),
        )


def losses_text(gaps: Sequence[Gap]) -> str | None:
    """ "7 samples lost in 0.9 s at 12.3 s" (one gap), "9 samples lost in 3 gaps, the
    longest 0.9 s at 12.3 s" (several); None when nothing was lost. Times from the run's
    first sample."""
    if not gaps:
        return None
    total = sum(g.count for g in gaps)
    longest = max(gaps, key=lambda g: (g.hole_s, g.count))
    noun = "sample" if total == 1 else "samples"
    if len(gaps) == 1:
        return f"{total} {noun} lost in {longest.hole_s:.1f} s at {longest.at_s:.1f} s"
    return (
        f"{total} {noun} lost in {len(gaps)} gaps, the longest {longest.hole_s:.1f} s "
        f"at {longest.at_s:.1f} s"
    )


@dataclass(frozen=True)
class RunEvents:
    """A run's typed events; each is the first of its action (None: not recorded, as for
    imported runs and for thrust steps of runs recorded before they were stored)."""

    release: Release | None = None
    brake: Halt | None = None
    catch: Halt | None = None
    thrust_steps: tuple[ThrustStep, ...] | None = None
    #: Every gap of lost samples, in time order (``daq.sample_losses``).
    losses: tuple[Gap, ...] = ()

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
        losses: list[Gap] = []
        for event in events:
            data = event.data or {}
            action = data.get("action")
            if action == RunAction.SAMPLES_LOST:
                losses.append(Gap.of(data))
                continue
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
            losses=tuple(sorted(losses, key=lambda g: g.t_first)),
        )


def _seq(value: Any) -> int | None:
    return None if value is None else int(value)
