"""Editing the rig's queue beyond move/remove, like bluesky-queueserver's: replace a queued
job's request, run one now (to the front, queue resumed), stop after the job on the rig,
and re-queue a past job (the same request submitted again).

A mixin of :class:`api.core.jobs.JobRunner`: it works on the runner's
:class:`~api.core.job_queue.RigQueue` under its lock, so a change is seen by every reader of
``queue_json`` at once.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from api.core.job_model import Job, JobConflict
from api.core.job_requests import procedure_from_request

if TYPE_CHECKING:
    from api.core.job_queue import RigQueue
    from api.core.job_registry import JobRegistry
    from api.core.rig_worker import RigWorker
    from api.core.service import RigService


#: Why the queue waits after "Stop after the current job" (the words the pages show).
STOP_AFTER_CURRENT = (
    "stopped by the operator: the job on the rig finishes, no further job starts until "
    "the queue is resumed"
)


class QueueEdits:
    """Replace, run now, stop after current, re-queue (see the module docstring)."""

    # provided by JobRunner
    service: RigService
    registry: JobRegistry
    queue: RigQueue
    rig: RigWorker

    if TYPE_CHECKING:

        def get(self, job_id: str) -> Job: ...
        def move(self, job_id: str, position: int) -> dict[str, Any]: ...
        def pause_queue(self, reason: str = ...) -> dict[str, Any]: ...
        def resume_queue(self) -> dict[str, Any]: ...

    def replace(self, job_id: str, request: dict[str, Any]) -> Job:
        """Give a queued job a new request (its kind's body, validated exactly like a new
        submission: ``ParameterError``/``NotCapable`` name the field); it keeps its place."""
        from daq.store.run_metadata import check_run_metadata

        job = self.queue.queued(job_id)
        check_run_metadata(request.get("metadata"))
        params, label = procedure_from_request(
            job.kind, request, self.service.source.rig, self.service.store
        )
        note = getattr(params, "adjustment", lambda: None)()
        with self.queue.lock:
            if job not in self.queue:
                raise JobConflict(f"job {job.id} left the queue (state {job.state})")
            with job.lock:
                job.request = request
                job.params = params
                job.parameters = params.to_json()
                job.label = label
                job.notes = [note] if note else []
        self.registry.update(job, message=f"queued (position {job.position}): parameters replaced")
        return job

    def run_now(self, job_id: str) -> dict[str, Any]:
        """Put a queued job first and resume the queue: it starts now if the rig is free,
        else as soon as the job on the rig ends."""
        job = self.queue.queued(job_id)
        self.move(job.id, 1)
        return self.resume_queue()

    def stop_after_current(self) -> dict[str, Any]:
        """Let the job on the rig finish and start no further one (a queue pause in plain
        words); ``resume_queue`` undoes it."""
        return self.pause_queue(STOP_AFTER_CURRENT)

    def requeue(self, job_id: str, user: str | None = None) -> Job:
        """Submit a past procedure job's request again as a new job for ``user`` (queued
        while the rig is busy or the queue paused); validated like any submission."""
        old = self.get(job_id)
        if old.request is None:
            raise JobConflict(f"job {old.id} ({old.kind}) has no stored request to submit again")
        if old.position is not None:
            raise JobConflict(f"job {old.id} is still in the queue (position {old.position})")
        request = dict(old.request)
        params, label = procedure_from_request(
            old.kind, request, self.service.source.rig, self.service.store
        )
        return self.rig.start_procedure(old.kind, params, label, request=request, user=user)

    def add_stop_marker(self, position: int | None = None, user: str | None = None) -> Job:
        """Put a stop marker in the queue at ``position`` (1 = next; None: at the end): when
        the queue reaches it the marker goes and the queue pauses
        (:func:`api.core.job_queue.marker_reason`)."""
        from api.core.job_queue import STOP_MARKER

        if position is not None and not 1 <= position <= len(self.queue) + 1:
            raise ValueError(
                f"position: {position} is outside the queue; allowed 1 ≤ position ≤ "
                f"{len(self.queue) + 1}"
            )
        label = "stop marker: the queue pauses here"
        marker = self.registry.new(STOP_MARKER, label, {}, user_name=user)
        self.queue.insert(marker, position)
        self.registry.save(marker, event=True).result(10)
        self.queue.start_next()  # a marker at the front of an idle queue takes effect now
        return marker
