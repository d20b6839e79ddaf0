"""Which stored samples a fit leaves out, and whether what is left is enough.

A sample is left out when its value or its time cannot be trusted (``daq.sample_losses``:
a failed read, a stale channel, a late slot without a device clock, a NaN); consecutive
ones are one gap, said to the estimate as a ``estimation.data.left_out.LeftOut``. The
fit simulates through each hole and has no residual there; a run whose holes leave too
little is refused, naming the run (``left_out``).
"""

from __future__ import annotations

import math

import numpy as np

from daq.sample import Quality
from daq.sample_losses import LossTracker, hole_text, loss_reason
from daq.store import RunInfo, SampleTable
from daq.store.run_events import Gap
from daq.vocabulary import AXES
from estimation.data.left_out import LeftOut
from estimation.data.window import WindowReport


def trusted_samples(
    table: SampleTable, channel: str, device_clock: bool
) -> tuple[np.ndarray, tuple[Gap, ...]]:
    """Mask of the samples whose ``channel`` value and time can be fitted, and the gaps of
    the others (consecutive ones coalesced, skipped clock slots among them)."""
    values = table.channels[channel]
    flags = Quality.ERROR | Quality.STALE | (Quality.OK if device_clock else Quality.OVERRUN)
    nothing_lost = not np.any(table.quality & int(flags)) and np.all(np.isfinite(values))
    if nothing_lost and np.all(np.diff(table.seq) == 1):  # the common case, without a loop
        return np.ones(len(table), dtype=bool), ()
    tracker = LossTracker()
    good = np.zeros(len(table), dtype=bool)
    for i in range(len(table)):
        reasons = loss_reason(
            int(table.quality[i]), not math.isfinite(values[i]), device_clock=device_clock
        )
        tracker.feed(int(table.seq[i]), float(table.t_mono[i]), reasons)
        good[i] = not reasons
    tracker.finish()
    return good, tuple(tracker.gaps)


class TooMuchLeftOut(ValueError):
    """A run's lost samples leave too little to fit (the message names the run and why)."""


#: A fit refuses a run when more than this share of its free motion's samples is left out.
MAX_LEFT_OUT_SHARE = 0.2


def left_out(
    run: RunInfo,
    table: SampleTable,
    gaps: tuple[Gap, ...],
    offset: float,
    window: WindowReport,
    kept: int,
) -> tuple[LeftOut, ...]:
    """The samples the fit leaves out (``gaps``, host times; ``offset`` maps them onto the
    window's time base), from the run's first sample; raises ``TooMuchLeftOut``
    naming the run when its gaps leave too little: a hole in the free motion (release to
    end) longer than its kind tolerates, or more than ``MAX_LEFT_OUT_SHARE`` of it left out."""
    t0 = float(table.t_mono[0]) if len(table) else 0.0
    end = math.inf if window.t_end is None else window.t_end
    limit = AXES[run.kind].loss_tolerance_s
    found: list[LeftOut] = []
    lost = 0
    for g in gaps:
        inside = g.t_last + offset > window.t_release and g.t_first + offset < end
        out = LeftOut(g.t_first - t0, g.t_last - t0, g.count, g.reason, inside)
        found.append(out)
        if not inside:
            continue
        lost += g.count
        if limit is not None and g.hole_s > limit:
            raise TooMuchLeftOut(
                f"run {run.id}: {out.describe()}: a {hole_text(g.hole_s, limit)} hole in its "
                f"free motion, longer than a {run.kind} tolerates ({limit:g} s); repeat the run"
            )
    if lost > MAX_LEFT_OUT_SHARE * (lost + kept):
        raise TooMuchLeftOut(
            f"run {run.id}: {lost} of its {lost + kept} samples in free motion left out "
            f"(allowed: at most {MAX_LEFT_OUT_SHARE:.0%}); repeat the run"
        )
    return tuple(found)
