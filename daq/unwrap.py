"""Host-side unwrapping of counters that wrap on the PLC (heartbeat, millisecond clock)."""

from __future__ import annotations


class CounterUnwrapper:
    """Turn a wrapping raw counter into one that keeps growing.

    Each new raw value is taken to be the nearest of its aliases to the previous
    one: a step of more than half the wrap period backwards is read as a wrap
    forwards, and vice versa. So the counter must be read at least once per half
    period (a uint16 heartbeat at 100 counts/s: every 327 s; a uint32 ms clock:
    every 24 days), which any acquisition clock does.
    """

    def __init__(self, period: int) -> None:
        if period < 2:
            raise ValueError(f"period must be at least 2 counts, got {period}")
        self.period = period
        self._last_raw: int | None = None
        self._total: int = 0

    def update(self, raw: int) -> int:
        """Feed the next raw reading; returns the unwrapped count."""
        raw = int(raw)
        if self._last_raw is None:
            self._total = raw
        else:
            step = (raw - self._last_raw) % self.period
            if step > self.period // 2:
                step -= self.period
            self._total += step
        self._last_raw = raw
        return self._total

    def reset(self) -> None:
        """Forget history: the next reading starts the count afresh."""
        self._last_raw = None
        self._total = 0
