"""Samples a fit leaves out of a run because their value or time cannot be trusted.

The loader that reads a stored run (``daq.run_data``) decides which (a failed read, a stale
channel, a late slot without a device clock, a NaN) and says so with one :class:`LeftOut`
per stretch of consecutive samples; the fit simulates through each hole and simply has no
residual there. The list rides with the run's window report into the result.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class LeftOut:
    """``count`` consecutive samples left out from ``start_s`` to ``end_s`` (s from the run's
    first sample), for ``reason`` ("PLC read failed", "stale channel", …); ``in_motion``:
    within the fitted free motion (release to end), not the baseline or the hold."""

    start_s: float
    end_s: float
    count: int
    reason: str
    in_motion: bool = False

    def describe(self) -> str:
        """ "4 samples left out at 12.3–12.7 s (PLC read failed)"."""
        noun = "sample" if self.count == 1 else "samples"
        at = (
            f"{self.start_s:.1f} s"
            if round(self.end_s, 1) == round(self.start_s, 1)
            else f"{self.start_s:.1f}–{self.end_s:.1f} s"
        )
        return f"{self.count} {noun} left out at {at} ({self.reason})"

    def to_json(self) -> dict[str, Any]:
        return {
            "start_s": float(self.start_s),
            "end_s": float(self.end_s),
            "count": int(self.count),
            "reason": self.reason,
            "in_motion": bool(self.in_motion),
        }
