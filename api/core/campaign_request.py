"""What a campaign takes, declared once: ``POST /api/campaigns``' body and ``rig
campaign``'s options (``Flag``), with the target in percent of U/|θ| (docs/campaigns.md)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Literal

from pydantic import Field

from daq.procedures.flag import Flag
from daq.procedures.requests import StrictRequest
from daq.procedures.run_kinds import KINDS
from estimation.design.campaign_state import Target
from estimation.design.planning_envelope import RigEnvelope

#: The axes the planner plans: those of the kinds with an ``envelope`` (surge: tows, yaw: spins).
PLANNED = {str(s.axis.axis): str(k) for k, s in KINDS.items() if s.envelope and s.axis}
if TYPE_CHECKING:
    PlannedAxis = str  # a key of PLANNED: what the type checker can know of a computed Literal
else:
    PlannedAxis = Literal[tuple(PLANNED)]  # what pydantic checks and the OpenAPI schema lists


def parse_percent(text: str) -> float:
    """``1%`` or ``1`` → 1.0 (percent); ``ValueError`` for anything but a number."""
    return float(text.strip().removesuffix("%").strip())


class CampaignRequest(StrictRequest):
    """The target and the budget of a campaign; the axes default to every one the rig can
    test."""

    target_percent: Annotated[
        float,
        Field(gt=0, lt=100,
              description="Target U/|θ| on inertia, K_L and K_Q, in % (U: the expanded "
              "uncertainty of the GUM budget, 95 %, with the rig file's tolerances)."),
        Flag("--target", metavar="N%", parse=parse_percent),
    ] = 1.0  # fmt: skip
    axes: Annotated[
        list[PlannedAxis] | None,
        Field(min_length=1,
              description=" and/or ".join(f"{axis} ({kind}s)" for axis, kind in PLANNED.items())
              + "; default every one the rig can test."),
        Flag("--axis"),
    ] = None  # fmt: skip
    max_runs: Annotated[
        int, Field(ge=1, le=100, description="Budget: runs at most."), Flag("--max-runs")
    ] = 12
    max_minutes: Annotated[
        float,
        Field(gt=0, le=24 * 60,
              description="Budget: tank minutes at most (runs + a 30 s reset after each)."),
        Flag("--max-minutes"),
    ] = 60.0  # fmt: skip

    def target(self, envelope: RigEnvelope) -> Target:
        """The planner's target on ``envelope``'s rig (its axes when none are asked for)."""
        axes = self.axes or [str(a.axis) for a in envelope.axes]
        return Target(
            self.target_percent / 100, tuple(dict.fromkeys(axes)), self.max_runs, self.max_minutes
        )
