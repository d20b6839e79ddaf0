"""The unit of acquisition: one tick of the clock, every channel in SI units."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntFlag


class Quality(IntFlag):
    """Quality flags of a sample or a channel reading (combine with ``|``)."""

    OK = 0
    STALE = 1  # a channel is older than its freshness limit
    ERROR = 2  # the read failed this tick (timeout, exception response, disconnect)
    OVERRUN = 4  # the previous tick overran its slot and slots were skipped


@dataclass(frozen=True, slots=True)
class Sample:
    """One tick.

    ``seq`` counts clock slots from 0 (skipped slots leave gaps); ``t_mono`` is the
    host's monotonic time (s) when the read completed, ``t_wall`` the matching
    Unix time; ``channels`` maps channel name to SI value (NaN when unread);
    ``quality`` is the OR of all flags; ``stale`` names the stale channels.
    """

    seq: int
    t_mono: float
    t_wall: float
    channels: dict[str, float]
    quality: Quality = Quality.OK
    stale: tuple[str, ...] = field(default_factory=tuple)
