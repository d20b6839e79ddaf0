"""Queue routes: the rig's queue of procedure jobs — view, reorder, replace a job's
parameters, remove, run one now, stop after the current job, resume (like
bluesky-queueserver's queue)."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import Body, Depends
from fastapi.exceptions import RequestValidationError
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from api.core.job_model import JobConflict
from api.core.sequence_request import SequenceRequest
from api.http.app_codes import app_router
from api.http.deps import OperatorDep, RunnerDep, require_read, require_write
from api.http.schemas import JobOut, QueueMoveRequest, QueueOut, error_responses
from daq.procedures.run_kinds import RIG_KINDS

router = app_router("/api/queue", "queue")
_CHANGE = error_responses(401, 404, 409, 503)
#: Job kinds whose request a queued job can have replaced.
_EDITABLE = (*RIG_KINDS, "sequence")


@router.get(
    "",
    response_model=QueueOut,
    dependencies=[Depends(require_read)],
    responses=error_responses(401),
)
def get_queue(runner: RunnerDep) -> dict:
    """The job on the rig and the queued jobs in the order they will run; paused or not."""
    return runner.queue_json()


@router.post(
    "/{job_id}/move",
    response_model=QueueOut,
    dependencies=[Depends(require_write)],
    responses=error_responses(401, 404, 409, 422),
)
def move_job(job_id: str, body: QueueMoveRequest, runner: RunnerDep) -> dict:
    """Put a queued job at ``position`` (1 = next to run); 422 outside 1..queue length."""
    return runner.move(job_id, body.position)


def _request_model(kind: str) -> type[BaseModel]:
    """The body a new ``kind`` job is submitted with."""
    return SequenceRequest if kind == "sequence" else RIG_KINDS[kind].request  # type: ignore[index, return-value]


@router.put(
    "/{job_id}",
    response_model=JobOut,
    dependencies=[Depends(require_write)],
    responses=error_responses(401, 404, 409, 422, 503),
)
def replace_job(
    job_id: str,
    body: Annotated[
        dict[str, Any],
        Body(
            description="The job's new request: the body its kind's ``POST /api/jobs/…`` "
            "takes (a tow's ``{force_n, drive, …}``, a sequence's ``{steps, …}``)."
        ),
    ],
    runner: RunnerDep,
) -> dict:
    """Replace a queued job's parameters, validated exactly like a new submission (422
    naming the field); it keeps its place in the queue (409 once it started)."""
    job = runner.get(job_id)
    if job.position is None:
        raise JobConflict(f"job {job.id} is not in the queue (state {job.state})")
    try:
        parsed = _request_model(job.kind).model_validate(body) if job.kind in _EDITABLE else None
    except ValidationError as err:
        raise RequestValidationError(
            [e | {"loc": ("body", *e["loc"])} for e in err.errors(include_context=False)]
        ) from None
    request = parsed.model_dump(mode="json", exclude_none=True) if parsed is not None else body
    return runner.replace(job_id, request).to_json()


@router.post(
    "/{job_id}/run-now",
    response_model=QueueOut,
    dependencies=[Depends(require_write)],
    responses=_CHANGE,
)
def run_job_now(job_id: str, runner: RunnerDep) -> dict:
    """Put a queued job first and resume the queue: it starts now if the rig is free, else
    as soon as the job on the rig ends (409 for a job not queued)."""
    return runner.run_now(job_id)


@router.delete(
    "/{job_id}",
    response_model=QueueOut,
    dependencies=[Depends(require_write)],
    responses=_CHANGE,
)
def remove_job(job_id: str, runner: RunnerDep) -> dict:
    """Take a job out of the queue; it never ran, so it is deleted (409 once it started)."""
    return runner.remove(job_id)


@router.post(
    "/pause", response_model=QueueOut, dependencies=[Depends(require_write)], responses=_CHANGE
)
def pause_queue(runner: RunnerDep) -> dict:
    """Stop after the current job: the job on the rig goes on, no further queued job (nor
    one started now) runs until the queue is resumed."""
    return runner.stop_after_current()


@router.post(
    "/resume", response_model=QueueOut, dependencies=[Depends(require_write)], responses=_CHANGE
)
def resume_queue(runner: RunnerDep) -> dict:
    """Let queued jobs start again (the first one now if the rig is free)."""
    return runner.resume_queue()


class StopMarkerRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    position: int | None = Field(
        None, description="Place in the queue, 1 = next; omitted: after the last job."
    )


@router.post(
    "/stop-marker",
    status_code=201,
    response_model=QueueOut,
    dependencies=[Depends(require_write)],
    responses=error_responses(401, 403, 422, 503),
)
def add_stop_marker(
    runner: RunnerDep, user: OperatorDep, body: StopMarkerRequest | None = None
) -> dict:
    """Put a stop marker in the queue (bluesky-queueserver's ``queue_stop``): when the queue
    reaches it, the marker goes and the queue pauses until resumed. Move or remove it like a
    job (``DELETE /api/queue/{id}``)."""
    runner.add_stop_marker(body.position if body else None, user.name)
    return runner.queue_json()
