"""What a run lost: every late, missed or bad sample, coalesced into gaps.

A sample is *lost* when its value or its time cannot be trusted (:func:`loss_reason`): the
read failed (ERROR, or a NaN value), a channel was stale (STALE), or its slot came after
skipped ones (OVERRUN) and no device clock corrects its late host time stamp. A clock slot
with no sample at all (``seq`` jumps) is lost as "slot missed". Consecutive lost samples
are one :class:`daq.store.run_events.Gap`; :class:`LossTracker` builds them one sample at
a time, the same way for the recorder (events of the run, ``daq.procedures.recording``)
and for the loader (what a fit leaves out, ``daq.run_data``).

How long a hole a run tolerates is declared per kind (``daq.vocabulary.AxisTerms.
loss_tolerance_s``); a longer one of the devices' making aborts the run (:data:`SAMPLES_LOST`;
a busy host's skipped slots are named and left out, ``HOST_SIDE``).
"""

from __future__ import annotations

from dataclasses import replace

from daq.sample import Quality
from daq.store.run_events import Gap

#: A sample stamped late by the host, with no device clock to correct it (OVERRUN).
LATE_SLOT = "late slot, no device clock"
#: The reason each quality flag gives (in this order when several are set).
FLAG_REASONS: tuple[tuple[Quality, str], ...] = (
    (Quality.ERROR, "PLC read failed"),
    (Quality.STALE, "stale channel"),
    (Quality.OVERRUN, LATE_SLOT),
)
#: A slot the clock skipped (no sample at all), and a value the read left unset.
MISSED_SLOT = "slot missed"
NAN_VALUE = "NaN value"
#: How the reason of a run aborted for a hole beyond its kind's tolerance begins.
SAMPLES_LOST = "samples lost"
#: Reasons that are the host's, not the rig's: the PC was late (a slot skipped, a late host
#: stamp). Named, counted and left out of the fit like any loss, but they do not abort a
#: run: the devices answered and the rig is safe; a hole they leave that is too long for the
#: fit makes the loader refuse the run instead (``daq.fit_exclusions``).
HOST_SIDE = frozenset({MISSED_SLOT, LATE_SLOT})


def hole_text(hole_s: float, limit_s: float) -> str:
    """``hole_s`` (s) written with the fewest decimals (1-3) that show it longer than
    ``limit_s``: "0.53 s", never "0.5 s hole, longer than 0.5 s"."""
    for decimals in (1, 2):
        if round(hole_s, decimals) > limit_s:
            return f"{hole_s:.{decimals}f} s"
    return f"{hole_s:.3f} s"


def device_side(gap: Gap) -> bool:
    """Whether ``gap`` holds a loss the rig's devices caused (a failed read, a stale channel,
    a NaN value), which aborts a run past its kind's tolerance."""
    return any(reason not in HOST_SIDE for reason in gap.reasons)


def loss_reason(
    quality: int, value_nan: bool = False, *, device_clock: bool = False
) -> tuple[str, ...]:
    """Why a sample of quality ``quality`` cannot be fitted, each reason once, in
    ``FLAG_REASONS``' order and then ``NAN_VALUE`` (empty: it can). ``value_nan``: the
    channel used is NaN; ``device_clock``: the PLC's clock stamps the sample, so a late
    host time stamp (OVERRUN) does not matter."""
    reasons = tuple(
        text
        for flag, text in FLAG_REASONS
        if quality & flag and not (flag is Quality.OVERRUN and device_clock)
    )
    return (*reasons, NAN_VALUE) if value_nan and not quality & Quality.ERROR else reasons


class LossTracker:
    """Coalesces lost samples into gaps, fed one sample at a time (slots the clock skipped
    are found from ``seq`` and dated evenly between their neighbours). :meth:`feed` returns
    the gap a good sample closes; :meth:`finish` the one still open at the end.
    """

    def __init__(self) -> None:
        self.t0: float | None = None  # the first sample's time, s
        self.last_good: float | None = None
        self._seq: int | None = None
        self._t: float | None = None
        self._open: Gap | None = None
        self.gaps: list[Gap] = []

    @property
    def open_gap(self) -> Gap | None:
        """The gap still going on (no good sample since it began)."""
        return self._open

    def feed(self, seq: int, t: float, reasons: tuple[str, ...]) -> Gap | None:
        """Take sample ``seq`` at ``t`` (s), lost for ``reasons`` (``loss_reason``; empty:
        good). Returns the gap it closes (a good sample after lost ones), else None."""
        if self.t0 is None:
            self.t0 = t
        if self._seq is not None and self._t is not None and seq > self._seq + 1:
            missed = seq - self._seq - 1
            step = (t - self._t) / (missed + 1)
            self._lose(
                self._seq + 1, self._t + step, self._seq + missed, t - step, missed, (MISSED_SLOT,)
            )
        self._seq, self._t = seq, t
        if reasons:
            self._lose(seq, t, seq, t, 1, reasons)
            return None
        self.last_good = t
        closed = self._open
        if closed is not None:
            self._open = None
            closed = replace(closed, t_after=t)
            self.gaps.append(closed)
        return closed

    def finish(self) -> Gap | None:
        """Close the gap still open at the run's end (its ``t_after`` stays None)."""
        closed, self._open = self._open, None
        if closed is not None:
            self.gaps.append(closed)
        return closed

    def _lose(
        self,
        seq_first: int,
        t_first: float,
        seq_last: int,
        t_last: float,
        count: int,
        named: tuple[str, ...],
    ) -> None:
        gap = self._open
        if gap is None:
            self._open = Gap(
                seq_first=seq_first,
                seq_last=seq_last,
                t_first=t_first,
                t_last=t_last,
                count=count,
                reasons=named,
                t_before=self.last_good,
                at_s=t_first - (self.t0 if self.t0 is not None else t_first),
            )
            return
        # each reason once: not "PLC read failed, PLC read failed, stale channel" for a
        # failed read that then went stale
        reasons = (*gap.reasons, *(r for r in named if r not in gap.reasons))
        self._open = replace(
            gap, seq_last=seq_last, t_last=t_last, count=gap.count + count, reasons=reasons
        )

    def hole_s(self, now: float) -> float:
        """How long the open gap has gone without a good sample at ``now`` (0: none open)."""
        gap = self._open
        if gap is None:
            return 0.0
        start = gap.t_before if gap.t_before is not None else gap.t_first
        return now - start
