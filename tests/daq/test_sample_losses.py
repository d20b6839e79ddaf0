"""Lost samples coalesced into gaps (daq.sample_losses), and each quality flag's reason."""

from __future__ import annotations

import pytest

from daq.sample import Quality
from daq.sample_losses import LossTracker, hole_text, loss_reason
from daq.store.run_events import RunEvents, losses_text
from daq.store.run_records import EventInfo


def _feed(rows: list[tuple[int, str | tuple[str, ...] | None]], period: float = 0.1) -> LossTracker:
    """Samples (seq, reason or reasons; None: good) at seq·period s from t = 10 s."""
    tracker = LossTracker()
    for seq, why in rows:
        reasons = () if why is None else (why,) if isinstance(why, str) else why
        tracker.feed(seq, 10.0 + seq * period, reasons)
    tracker.finish()
    return tracker


def test_consecutive_lost_samples_are_one_gap_with_its_span_count_and_reasons():
    rows = [(i, None) for i in range(5)]
    rows += [(5, "PLC read failed"), (6, "PLC read failed"), (7, "stale channel")]
    rows += [(i, None) for i in range(8, 12)] + [(12, "NaN value")] + [(13, None)]
    gaps = _feed(rows).gaps
    assert len(gaps) == 2
    first, second = gaps
    assert (first.seq_first, first.seq_last, first.count) == (5, 7, 3)
    assert first.reasons == ("PLC read failed", "stale channel")
    assert first.t_first == pytest.approx(10.5) and first.t_last == pytest.approx(10.7)
    # good sample to good sample: 10.4 s to 10.8 s
    assert first.hole_s == pytest.approx(0.4) and first.at_s == pytest.approx(0.5)
    assert (second.count, second.reasons, second.hole_s) == (1, ("NaN value",), pytest.approx(0.2))
    assert first.describe() == "3 samples lost in 0.4 s at 0.5 s (PLC read failed, stale channel)"


def test_a_sample_lost_for_several_reasons_names_each_once_in_its_gap():
    failed, failed_stale = loss_reason(Quality.ERROR), loss_reason(Quality.ERROR | Quality.STALE)
    assert failed_stale == ("PLC read failed", "stale channel")
    (gap,) = _feed([(0, None), (1, failed), (2, failed_stale), (3, failed_stale), (4, None)]).gaps
    assert gap.reasons == ("PLC read failed", "stale channel")
    assert gap.describe() == "3 samples lost in 0.4 s at 0.1 s (PLC read failed, stale channel)"
    late = loss_reason(Quality.OVERRUN | Quality.STALE)  # a reason with a comma of its own
    (gap,) = _feed([(0, None), (1, late), (2, None)]).gaps
    assert gap.reasons == ("stale channel", "late slot, no device clock")


def test_skipped_slots_are_lost_samples_dated_between_their_neighbours():
    gaps = _feed([(0, None), (1, None), (4, "late slot, no device clock"), (5, None)]).gaps
    (gap,) = gaps
    assert (gap.seq_first, gap.seq_last, gap.count) == (2, 4, 3)
    assert gap.reasons == ("slot missed", "late slot, no device clock")
    assert gap.t_first == pytest.approx(10.2) and gap.hole_s == pytest.approx(0.4)


def test_a_run_that_ends_in_a_gap_keeps_it_open_ended():
    tracker = LossTracker()
    for seq in range(3):
        tracker.feed(seq, seq * 0.1, ())
    tracker.feed(3, 0.3, ("PLC read failed",))
    assert tracker.hole_s(0.9) == pytest.approx(0.7)  # still going: from the last good
    gap = tracker.finish()
    assert gap is not None and gap.t_after is None and gap.hole_s == pytest.approx(0.1)


def test_gaps_round_trip_through_the_run_events_in_time_order():
    gaps = _feed([(0, None), (1, "stale channel"), (2, None), (3, "PLC read failed")]).gaps
    events = [
        EventInfo(i, "r", None, "samples_lost", g.describe(), g.event_data())  # type: ignore[arg-type]
        for i, g in enumerate(reversed(gaps))
    ]
    assert RunEvents.of(events).losses == tuple(gaps)
    assert losses_text(gaps) == "2 samples lost in 2 gaps, the longest 0.2 s at 0.1 s"
    assert losses_text([]) is None


@pytest.mark.parametrize(
    ("quality", "nan", "clock", "reason"),
    [
        (Quality.OK, False, False, ()),
        (Quality.ERROR, True, False, ("PLC read failed",)),
        (Quality.STALE, False, False, ("stale channel",)),
        (Quality.OVERRUN, False, False, ("late slot, no device clock",)),
        (Quality.OVERRUN, False, True, ()),  # the PLC's clock stamps it
        (Quality.OK, True, False, ("NaN value",)),
        (
            Quality.STALE | Quality.OVERRUN,
            False,
            False,
            ("stale channel", "late slot, no device clock"),
        ),
    ],
)
def test_each_quality_flag_names_its_reason(quality, nan, clock, reason):
    assert loss_reason(quality, nan, device_clock=clock) == reason


def test_a_hole_just_over_its_limit_is_written_longer_than_the_limit():
    """Not "a 0.5 s hole, longer than a tow tolerates (0.5 s)" (the rehearsal of 6a050e9)."""
    assert hole_text(0.503, 0.5) == "0.503 s"
    assert hole_text(0.53, 0.5) == "0.53 s"
    assert hole_text(0.9, 0.5) == "0.9 s"
    assert hole_text(1.35, 1.0) == "1.4 s"
