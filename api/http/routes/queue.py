"""Queue routes: the rig's queue of procedure jobs — view, reorder, remove, pause, resume
(like bluesky-queueserver's queue)."""

from __future__ import annotations

from fastapi import APIRouter, Depends

from api.http.deps import RunnerDep, require_read, require_write
from api.http.schemas import QueueMoveRequest, QueueOut, error_responses

router = APIRouter(prefix="/api/queue", tags=["queue"])
_CHANGE = error_responses(401, 404, 409, 503)


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
    """Start no further queued job; the job on the rig goes on."""
    return runner.pause_queue()


@router.post(
    "/resume", response_model=QueueOut, dependencies=[Depends(require_write)], responses=_CHANGE
)
def resume_queue(runner: RunnerDep) -> dict:
    """Let queued jobs start again (the first one now if the rig is free)."""
    return runner.resume_queue()
