"""A job as the API shows it, its errors, and its row in the jobs table."""

from __future__ import annotations

import asyncio
import threading
import time
from dataclasses import dataclass, field
from typing import Any

from daq.procedures.recording import AbortSignal
from daq.procedures.sequence import SequenceControl
from daq.store.run_records import to_datetime
from daq.store.schema import JOB_FINAL, JobState


class JobNotFound(KeyError):
    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "job not found"


class JobConflict(RuntimeError):
    """The request does not fit the job's state (or the rig is held by another job)."""

    def __init__(self, message: str, holder: str | None = None) -> None:
        super().__init__(message)
        self.holder = holder


def iso_time(unix_s: float | None) -> str | None:
    """ISO 8601 UTC text of a Unix time, like a run's times (None stays None)."""
    moment = to_datetime(unix_s)
    return None if moment is None else moment.isoformat()


def labelled_parameters(parameters: dict[str, Any]) -> list[dict[str, Any]]:
    """The job's parameters as people read them (``daq.parameter_labels``); a sequence's
    steps one entry each (``step 1``: ``tow: force 4.9 N``)."""
    from daq.parameter_labels import Parameter, labelled

    steps = parameters.get("steps")
    if not isinstance(steps, list):
        return [p.to_json() for p in labelled(parameters)]
    out = [p.to_json() for p in labelled({k: v for k, v in parameters.items() if k != "steps"})]
    for i, step in enumerate(steps, start=1):
        if isinstance(step, dict):
            words = "; ".join(p.text for p in labelled(step))
            text = f"{step.get('kind', 'step')}: {words}" if words else str(step.get("kind"))
            out.append(Parameter(f"steps[{i - 1}]", f"step {i}", text, "").to_json())
    return out


@dataclass(eq=False)
class Job:
    """One job; mutated on the thread that runs it, under ``lock``. Times are Unix s
    inside, ISO 8601 UTC in ``to_json``."""

    id: str
    kind: str
    label: str
    parameters: dict[str, Any]
    state: JobState = JobState.QUEUED
    fraction: float = 0.0
    message: str = "queued"
    run_ids: list[str] = field(default_factory=list)
    outcome: dict[str, Any] | None = None
    error: str | None = None
    result_id: int | None = None
    operator_act: dict[str, Any] | None = None
    pause_requested: bool = False
    created_at: float = field(default_factory=time.time)
    started_at: float | None = None
    finished_at: float | None = None
    #: What the operator should know about the request, e.g. a load rounded to the gram.
    notes: list[str] = field(default_factory=list)
    #: 1, 2, … while waiting in the rig's queue.
    position: int | None = None
    #: The request body a queued procedure is rebuilt from after a restart.
    request: dict[str, Any] | None = None
    #: The named user who asked for it (None: older jobs, estimations of no one).
    user_name: str | None = None
    #: The validated parameters object (None for a job loaded back from the database).
    params: Any = None
    # rig-loop objects (procedures) — touched only through RigService.call_soon
    abort: AbortSignal | None = None
    control: SequenceControl | None = None
    confirm: asyncio.Event | None = None
    lock: threading.Lock = field(default_factory=threading.Lock)
    #: Set as the job reaches a final state (``JobRegistry.update``): what a thread waits on.
    ended: threading.Event = field(default_factory=threading.Event)

    def __post_init__(self) -> None:
        if self.state in JOB_FINAL:  # read back ended
            self.ended.set()

    def to_json(self) -> dict[str, Any]:
        with self.lock:
            return {
                "id": self.id,
                "kind": self.kind,
                "label": self.label,
                "state": str(self.state),
                "position": self.position,
                "progress": {"fraction": self.fraction, "message": self.message},
                "parameters": self.parameters,
                "parameters_labelled": labelled_parameters(self.parameters),
                "request": self.request,
                "run_ids": list(self.run_ids),
                "outcome": self.outcome,
                "error": self.error,
                "result_id": self.result_id,
                "operator_act": self.operator_act,
                "created_at": iso_time(self.created_at),
                "started_at": iso_time(self.started_at),
                "finished_at": iso_time(self.finished_at),
                "notes": list(self.notes),
                "user": self.user_name,
            }

    def row(self, rig_name: str) -> dict[str, Any]:
        """The job's columns in the jobs table."""
        with self.lock:
            return {
                "rig_name": rig_name,
                "kind": self.kind,
                "label": self.label,
                "state": str(self.state),
                "position": self.position,
                "request": self.request,
                "parameters": self.parameters,
                "fraction": self.fraction,
                "message": self.message,
                "run_ids": list(self.run_ids),
                "outcome": self.outcome,
                "error": self.error,
                "result_id": self.result_id,
                "notes": list(self.notes),
                "created_at": self.created_at,
                "started_at": self.started_at,
                "finished_at": self.finished_at,
                "user_name": self.user_name,
            }

    @classmethod
    def from_row(cls, row: dict[str, Any]) -> Job:
        """A job read back from the jobs table (no rig-loop objects, no parameters object)."""
        return cls(
            id=row["id"],
            kind=row["kind"],
            label=row["label"],
            parameters=dict(row["parameters"] or {}),
            state=JobState(row["state"]),
            fraction=float(row["fraction"]),
            message=row["message"],
            run_ids=list(row["run_ids"] or []),
            outcome=row["outcome"],
            error=row["error"],
            result_id=row["result_id"],
            created_at=row["created_at"],
            started_at=row["started_at"],
            finished_at=row["finished_at"],
            notes=list(row["notes"] or []),
            position=row["position"],
            request=row["request"],
            user_name=row.get("user_name"),
        )


def without_report_files(data: Any) -> Any:
    """``data`` without its ``report_files`` (absolute paths in a scratch folder that is gone
    once the job ends, kept in results stored before issue 19): API answers hold no path of
    this machine; ``/api/results/{id}/report/{name}.png`` serves the figures."""
    if isinstance(data, dict):
        return {k: without_report_files(v) for k, v in data.items() if k != "report_files"}
    if isinstance(data, list):
        return [without_report_files(v) for v in data]
    return data
