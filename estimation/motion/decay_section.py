"""A single-DOF record's section of the one result (``motion.estimation_result``): each
record's equilibrium, release and where its fitted free motion ends (docs/estimation.md,
*Free decay*)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from estimation.motion.decay_end import FreeWindow
from estimation.motion.estimation_result import EstimationResult
from estimation.report_numbers import finite_values


@dataclass(frozen=True)
class DecaySection:
    """Per record: its fitted equilibrium (m or rad), its release (s, on its clock) and where
    its fitted free motion ends and why (``decay_end.free_decay_end``)."""

    equilibrium: dict[str, float]
    release_time_s: dict[str, float]
    window: dict[str, FreeWindow] = field(default_factory=dict)

    def to_json(self, result: EstimationResult[Any]) -> dict[str, Any]:
        """The decay's keys: its kind and DOF, equilibria, releases and windows."""
        return {
            "kind": "decay",
            "dof": result.axis,
            "equilibrium": finite_values(self.equilibrium),
            "release_time_s": finite_values(self.release_time_s),
            "window": {
                run: {"release_time_s": self.release_time_s.get(run)} | w.to_json()
                for run, w in self.window.items()
            },
        }


#: A free decay's (or a driven single-DOF record's) result.
DecayResult = EstimationResult[DecaySection]
