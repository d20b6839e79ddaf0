"""A run's stored events read back as typed records (daq.store.run_events)."""

from __future__ import annotations

from datetime import UTC, datetime

import pytest

from daq.store.run_events import Halt, Release, RunAction, RunEvents, ThrustStep
from daq.store.run_records import EventInfo
from tests.store.helpers import new_run


def _event(n: int, data: dict | None, kind: str = "operator") -> EventInfo:
    return EventInfo(n, "run", datetime.fromtimestamp(1.7e9 + n, tz=UTC), kind, "m", data)


def test_each_action_is_read_into_its_type_first_one_wins():
    events = RunEvents.of(
        [
            _event(0, None),
            _event(1, {"hung_mass_kg": 2.5}),
            _event(2, {"action": "release"}),  # no instant: tells nothing
            _event(3, {"action": "release", "t_mono": 10.5, "t_half_width": 0.002, "seq": 4}),
            _event(4, {"action": "release", "t_mono": 99.0}),
            _event(
                5,
                {
                    "action": "thrust_steps",
                    "steps": [[10.4, 10.6, [0.1, -0.1]], [11, 11.2, [0, 0]]],
                },
            ),
            _event(6, {"action": "brake", "seq": 40, "t_mono": 14.0, "t_last_free": 13.9}),
        ]
    )
    assert events.release == Release(10.5, 0.002, 4)
    assert events.release_time == 10.5
    assert events.brake == Halt(14.0, 13.9, 40)
    assert events.halt(RunAction.BRAKE) is events.brake
    assert events.catch is None and events.halt(RunAction.CATCH) is None
    assert events.thrust_steps == (
        ThrustStep(10.4, 10.6, (0.1, -0.1)),
        ThrustStep(11.0, 11.2, (0.0, 0.0)),
    )
    assert events.thrust_steps[0].t_mono == pytest.approx(10.5)


def test_a_run_without_events_has_none_of_them():
    events = RunEvents.of([])
    assert events == RunEvents()
    assert events.release_time is None and events.thrust_steps is None


def test_the_action_is_stored_as_its_plain_name(store):
    """Writers pass the enum; the database keeps the plain string the readers match."""
    run_id = new_run(store, kind="pendulum")
    store.add_event(run_id, "limit", "caught", {"action": RunAction.CATCH, "seq": 7})
    (stored,) = store.events(run_id)
    assert stored.data == {"action": "catch", "seq": 7}
    assert RunEvents.of([stored]).catch == Halt(None, None, 7)
