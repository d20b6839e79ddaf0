"""Sequences: a TOML file lists test steps, run one after another.

```toml
name = "seed 000 campaign"
rest_s = 30          # between runs, to let the water settle
repeats = 1          # the whole list this many times

[[steps]]
kind = "tow"         # any run kind: tow | spin | pendulum | thrust_calibration
force_n = 4.9        # the same parameters as the CLI / API

[[steps]]
kind = "tow"
force_n = -24.5      # negative: a reverse tow (from the far end, over the far-end pulley)
```
Every step is validated against the rig's limits (and a thruster drive against the stored
thrust calibration) before the first one starts, so a typo in step 7 never aborts a
half-finished campaign. Between steps the sequence
can be paused, resumed or aborted.
"""

from __future__ import annotations

import asyncio
import contextlib
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from daq.config import RigConfig
from daq.procedures.axis_steps import RunOutcome
from daq.procedures.params import MAX_SEQUENCE_STEPS, ParameterError, Progress, check_rest
from daq.procedures.procedure_request import ProcedureRequest
from daq.procedures.recording import AbortSignal, ProgressCallback
from daq.procedures.run_kinds import RIG_KINDS
from daq.session import Aborted, RigSession
from daq.vocabulary import RunStatus, quoted_kinds


@dataclass(frozen=True)
class Sequence:
    name: str
    steps: tuple[ProcedureRequest, ...]
    rest_s: float = 0.0
    repeats: int = 1

    def to_json(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "rest_s": self.rest_s,
            "repeats": self.repeats,
            "steps": [s.to_json() for s in self.steps],
        }


def parse_sequence(data: dict[str, Any], rig: RigConfig, source: str = "sequence") -> Sequence:
    """Validate a sequence dictionary; ``ParameterError`` names ``steps[i].field``."""
    problems: list[tuple[str, Any, str]] = []
    rest = data.get("rest_s", 0.0)
    try:
        rest = check_rest(rest)
    except ParameterError as err:
        problems += err.problems
    repeats = data.get("repeats", 1)
    if isinstance(repeats, bool) or not isinstance(repeats, int) or not 1 <= repeats <= 100:
        problems.append(("repeats", repeats, "allowed whole number 1 ≤ repeats ≤ 100"))
    unknown = sorted(set(data) - {"name", "rest_s", "repeats", "steps"})
    if unknown:
        problems.append(
            (unknown[0], data[unknown[0]], "allowed keys: name, rest_s, repeats, steps")
        )
    raw_steps = data.get("steps")
    steps: list[ProcedureRequest] = []
    if not isinstance(raw_steps, list) or not raw_steps:
        problems.append(("steps", raw_steps, "a non-empty list of [[steps]] tables"))
        raw_steps = []
    elif len(raw_steps) > MAX_SEQUENCE_STEPS:
        problems.append(
            (
                "steps",
                f"a list of {len(raw_steps)}",
                f"at most {MAX_SEQUENCE_STEPS} steps per sequence",
            )
        )
        raw_steps = []
    for i, raw in enumerate(raw_steps):
        kind = raw.get("kind") if isinstance(raw, dict) else None
        if not isinstance(kind, str) or kind not in RIG_KINDS:
            problems.append((f"steps[{i}].kind", kind, f"allowed {quoted_kinds(tuple(RIG_KINDS))}"))
            continue
        spec = RIG_KINDS[kind]  # type: ignore[index]  # a RunKind key matches its string
        given = {k: v for k, v in raw.items() if k != "kind"}
        assert spec.request is not None  # a kind the rig runs
        unknown = sorted(set(given) - set(spec.request.model_fields))
        if unknown:
            allowed = f"a {kind} step takes kind, " + ", ".join(spec.request.model_fields)
            problems.append((f"steps[{i}].{unknown[0]}", given[unknown[0]], allowed))
            continue
        try:
            steps.append(spec.check(given, rig))
        except ParameterError as err:
            problems += [
                (f"steps[{i}].{name}", value, allowed) for name, value, allowed in err.problems
            ]
    if problems:
        raise ParameterError(problems)
    return Sequence(
        name=str(data.get("name") or source),
        steps=tuple(steps),
        rest_s=float(rest),
        repeats=int(repeats),
    )


def load_sequence(path: str | Path, rig: RigConfig) -> Sequence:
    """Read and validate a sequence TOML file."""
    p = Path(path)
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except OSError as err:
        raise ParameterError(
            [("file", str(p), f"a readable sequence file ({err.strerror})")]
        ) from None
    except tomllib.TOMLDecodeError as err:
        raise ParameterError([("file", str(p), f"valid TOML ({err})")]) from None
    return parse_sequence(data, rig, source=p.stem)


@dataclass
class SequenceControl:
    """Pause/resume/abort a running sequence from another task (CLI, API)."""

    abort: AbortSignal = field(default_factory=AbortSignal)
    _resume: asyncio.Event = field(default_factory=asyncio.Event)

    def __post_init__(self) -> None:
        self._resume.set()

    @property
    def paused(self) -> bool:
        return not self._resume.is_set()

    def pause(self) -> None:
        """Finish the current step, then wait."""
        self._resume.clear()

    def resume(self) -> None:
        self._resume.set()

    async def wait_if_paused(self, report: ProgressCallback, fraction: float) -> None:
        if self.paused:
            report(Progress(fraction, "paused between steps", state="paused"))
        while self.paused:
            self.abort.check()
            try:
                await asyncio.wait_for(self._resume.wait(), timeout=0.2)
            except TimeoutError:
                continue


@dataclass(frozen=True)
class SequenceOutcome:
    """How a sequence ended and the runs it made (also when aborted)."""

    status: str  # completed | aborted
    reason: str | None
    runs: tuple[RunOutcome, ...]

    def to_json(self) -> dict[str, Any]:
        return {
            "status": self.status,
            "reason": self.reason,
            "runs": [r.to_json() for r in self.runs],
        }


async def run_sequence(
    session: RigSession,
    seq: Sequence,
    *,
    control: SequenceControl | None = None,
    progress: ProgressCallback | None = None,
) -> SequenceOutcome:
    """Run every step ``repeats`` times, resting ``rest_s`` between runs. Every step's
    thruster drive is checked against the newest stored calibration first (it may have
    changed since the sequence was queued): ``ParameterError`` before anything moves."""
    from daq.procedures.drive_check import check_steps

    await asyncio.to_thread(check_steps, seq.steps, session.rig, session.store)
    control = control or SequenceControl()
    report = progress or (lambda p: None)
    plan = [step for _ in range(seq.repeats) for step in seq.steps]
    outcomes: list[RunOutcome] = []
    base_metadata = dict(session.run_metadata or {})
    try:
        for i, step in enumerate(plan):
            base = i / len(plan)
            await control.wait_if_paused(report, base)
            control.abort.check()

            def sub(p: Progress, i: int = i, base: float = base) -> None:
                report(
                    Progress(
                        base + p.fraction / len(plan),
                        f"step {i + 1}/{len(plan)}: {p.message}",
                        extra=p.extra,
                    )
                )

            # each run says which sequence and step made it (daq.store.run_metadata)
            origin = {"sequence": seq.name[:200], "sequence_step": i + 1}
            session.run_metadata = base_metadata | origin
            ran = await RIG_KINDS[step.kind].run(session, step, abort=control.abort, progress=sub)
            outcome = ran.run
            outcomes.append(outcome)
            if outcome.status != RunStatus.COMPLETED:
                raise Aborted(f"step {i + 1}: {outcome.reason or outcome.status}")
            if i + 1 < len(plan) and seq.rest_s > 0:
                report(
                    Progress(
                        (i + 1) / len(plan), f"resting {seq.rest_s:g} s to let the water settle"
                    )
                )
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(control.abort.wait(), timeout=seq.rest_s)
                control.abort.check()
    except Aborted as err:
        report(
            Progress(len(outcomes) / len(plan), f"sequence aborted: {err.reason}", state="aborted")
        )
        return SequenceOutcome("aborted", err.reason, tuple(outcomes))
    finally:
        session.run_metadata = base_metadata or None
    report(Progress(1.0, f"sequence done: {len(outcomes)} runs", state="completed"))
    return SequenceOutcome("completed", None, tuple(outcomes))
