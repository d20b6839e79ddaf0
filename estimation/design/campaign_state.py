"""A campaign's state and trail: measure, re-estimate, choose, until certain or out of budget.

``Campaign`` holds what was recorded per axis, the latest fit, the tank time used and the
trail (each choice, why, the target ratios before and after the run it chose). A driver —
the rig service's campaign job (``api.core.campaign``) or ``bench/campaign_efficiency.py`` —
loops::

    while (d := campaign.next()).stop is None:
        run_id, seconds = record(d.choice.test)               # on the rig
        result, budget = estimate(campaign.run_ids(axis) + [run_id])  # and its GUM budget
        state = state_from_result(result, campaign.tests_after(d.choice), budget)
        campaign.recorded(d.choice, run_id, seconds, state)   # U, not 2σ
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from estimation.design.planner import AxisState, Choice, Decision, decide
from estimation.design.planning_envelope import Candidate, RigEnvelope
from estimation.report_numbers import finite_or_none

#: How many times in a row a campaign repeats a test whose runs are damaged.
MAX_REPEATS = 2


@dataclass(frozen=True)
class Target:
    """U/|θ| ≤ ``relative`` on M, K_L, K_Q of every axis in ``axes`` (a released axis: those
    its fit carries; U: the expanded uncertainty of the GUM budget, 95 %), ambiguities resolved;
    within ``max_runs`` runs and ``max_minutes`` tank minutes (runs + resets)."""

    relative: float = 0.01
    axes: tuple[str, ...] = ("surge", "yaw")
    max_runs: int = 12
    max_minutes: float = 60.0

    def __post_init__(self) -> None:
        if not 0 < self.relative < 1:
            raise ValueError(f"target: got {self.relative:g}, allowed: 0 < target < 1 (0.01 = 1 %)")
        if self.max_runs < 1:
            raise ValueError(f"max_runs: got {self.max_runs}, allowed: ≥ 1")
        if not self.max_minutes > 0:
            raise ValueError(f"max_minutes: got {self.max_minutes:g}, allowed: > 0")
        if not self.axes:  # which axes a rig can test: ``Campaign`` checks its envelope
            raise ValueError("axes: got none, allowed: at least one the rig can test")


@dataclass
class Campaign:
    """Per-axis runs, fits and the trail of one campaign."""

    target: Target
    envelope: RigEnvelope
    runs: dict[str, list[tuple[Candidate, str]]] = field(default_factory=dict)
    states: dict[str, AxisState | None] = field(default_factory=dict)
    minutes_used: float = 0.0
    trail: list[dict[str, Any]] = field(default_factory=list)
    outcome: str | None = None
    #: The test queued and not yet booked (its description, why, the operator's acts, job).
    pending: dict[str, Any] | None = None
    #: A test whose run was damaged (samples lost), to run again before planning on.
    again: Choice | None = None
    repeats: int = 0

    def __post_init__(self) -> None:
        missing = [a for a in self.target.axes if self.envelope.axis(a) is None]
        if missing:
            raise ValueError(f"axes: the rig cannot test {', '.join(missing)}")
        for axis in self.target.axes:
            self.runs.setdefault(axis, [])
            self.states.setdefault(axis, None)

    @property
    def runs_used(self) -> int:
        return sum(len(r) for r in self.runs.values())

    def run_ids(self, axis: str) -> list[str]:
        return [rid for _, rid in self.runs[axis]]

    def next(self) -> Decision:
        """The next test (a damaged run's again first), or the reason to stop (recorded as
        ``outcome``)."""
        if self.again is not None:
            return Decision(stop=None, choice=self.again)
        decision = decide(
            self.states,
            self.envelope,
            self.target.relative,
            runs_used=self.runs_used,
            minutes_used=self.minutes_used,
            max_runs=self.target.max_runs,
            max_minutes=self.target.max_minutes,
            done={a: [c for c, _ in r] for a, r in self.runs.items()},
        )
        if decision.stop is not None:
            self.outcome = decision.stop
        return decision

    def repeat(self, choice: Choice, run_id: str, seconds: float, damage: str) -> dict | None:
        """A run of ``choice`` was damaged (``damage`` says how): it is not fitted, its tank
        time counts and the test runs again (the trail entry says why, returned); None when
        the test was already repeated ``MAX_REPEATS`` times (``outcome`` says so)."""
        if self.repeats >= MAX_REPEATS:
            self.again = None
            self.outcome = (
                f"{choice.test.describe()}: damaged {MAX_REPEATS + 1} times in a row "
                f"(last: run {run_id}: {damage})"
            )
            return None
        self.repeats += 1
        self.again = choice
        self.minutes_used += (seconds + self.envelope.reset_s) / 60
        now = self.status(choice.test.axis)
        return self._book(
            choice, run_id, seconds, f"repeated, not fitted: run {run_id}: {damage}", now,
            repeated=True,
        )  # fmt: skip

    def _book(
        self, choice: Choice, run_id: str, seconds: float, why: str, before: dict, **extra: Any
    ) -> dict:
        """Append the trail entry of a run of ``choice`` and return it."""
        entry = {
            "n": len(self.trail) + 1,
            "axis": choice.test.axis,
            "test": choice.test.describe(),
            "command": choice.test.command,
            "request": choice.test.request(),
            "why": why,
            "run_id": run_id,
            **extra,
            "run_s": round(seconds, 2),
            "tank_minutes": round(self.minutes_used, 2),
            "before": before,
            "after": self.status(choice.test.axis),
        }
        self.trail.append(entry)
        return entry

    def tests_after(self, choice: Choice) -> tuple[Candidate, ...]:
        """The tests behind the axis's fit once ``choice``'s run is booked, in order."""
        return (*(c for c, _ in self.runs[choice.test.axis]), choice.test)

    def recorded(self, choice: Choice, run_id: str, seconds: float, state: AxisState) -> dict:
        """Book a finished run (``seconds`` on the rig) and the axis's new fit as the
        planner sees it (``state_from_result`` of the fit with ``tests_after(choice)`` and
        its uncertainty budget); returns the trail entry."""
        self.again, self.repeats = None, 0
        axis = choice.test.axis
        before = self.status(axis)
        self.runs[axis].append((choice.test, run_id))
        self.minutes_used += (seconds + self.envelope.reset_s) / 60
        self.states[axis] = state
        return self._book(
            choice,
            run_id,
            seconds,
            choice.why,
            before,
            predicted_after=_finite(choice.predicted_after),
        )

    def status(self, axis: str) -> dict[str, Any]:
        """U/|θ| in % per target coefficient and what is unresolved, for the trail."""
        state = self.states.get(axis)
        if state is None:
            return {"expanded_percent": {}, "unresolved": ["no fit yet"]}
        ratios = state.ratios(self.target.relative)
        percent = {n: _finite(r * self.target.relative * 100) for n, r in ratios.items()}
        floor = state.floor(self.target.relative)
        return {  # each coefficient by the result's name for it (``AxisState.name``)
            "expanded_percent": {state.name(n): p for n, p in percent.items()},
            "unresolved": state.unresolved(),
            "correlated": state.correlated(),
            "type_b_above_target": {
                state.name(n): _finite(f * self.target.relative * 100)
                for n, f in floor.items()
                if f > 1.0
            },
        }

    def to_json(self) -> dict[str, Any]:
        return {
            "target_percent": self.target.relative * 100,
            "axes": list(self.target.axes),
            "max_runs": self.target.max_runs,
            "max_minutes": self.target.max_minutes,
            "runs_used": self.runs_used,
            "tank_minutes": round(self.minutes_used, 2),
            "outcome": self.outcome,
            "pending": self.pending,
            "status": {a: self.status(a) for a in self.target.axes},
            "trail": list(self.trail),
        }


def _finite(x: float) -> float | None:
    """``x`` to 4 decimals for the trail; None when not finite."""
    value = finite_or_none(x)
    return None if value is None else round(value, 4)
