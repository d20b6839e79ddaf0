"""Job routes: start tow / spin / pendulum / calibration / sequence / estimation, watch,
control."""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Annotated

from fastapi import Depends, Query

from api.core.estimation_request import EstimationRequest
from api.core.job_filter import JobFilter
from api.core.job_model import Job
from api.core.job_requests import procedure_from_request
from api.core.jobs import JobRunner
from api.core.paging import JobsPage
from api.core.sequence_request import SequenceRequest
from api.core.service import RigService
from api.http.app_codes import app_router
from api.http.deps import (
    OperatorDep,
    RunnerDep,
    ServiceDep,
    StoreDep,
    require_read,
    require_write,
)
from api.http.schemas import (
    JobEventOut,
    JobOut,
    error_responses,
)
from daq.procedures.kind_spec import KindSpec
from daq.procedures.run_kinds import RIG_KINDS
from daq.store.people_and_safety_log import User

router = app_router("/api/jobs", "jobs")
_START = error_responses(401, 403, 409, 422, 423, 503)
_CONTROL = error_responses(401, 404, 409, 503)
#: ``?queue=false``: refuse (409) instead of queueing when the rig is busy.
QueueFlag = Annotated[
    bool,
    Query(
        description="When the rig is busy: true (default) queues the job behind the jobs "
        "already waiting; false refuses it at once with 409 naming the holder."
    ),
]


def _start(kind: str, body, service, runner, queue: bool, user: User) -> dict:
    request = body.model_dump(mode="json", exclude_none=True)
    params, label = procedure_from_request(kind, request, service.source.rig, service.store)
    started = runner.start_procedure(
        kind, params, label, request=request, queue=queue, user=user.name
    )
    return started.to_json()


def _start_route(spec: KindSpec) -> None:
    """``POST /api/jobs/<route>``: the kind's request model as body, validated against the
    rig (422 naming the field), then started as a job, or queued while the rig is busy
    (``?queue=false``: 409 instead)."""

    def start(body, service: RigService, runner: JobRunner, user: User, queue: bool = True) -> dict:
        return _start(spec.kind, body, service, runner, queue, user)

    start.__name__ = f"start_{spec.route}"  # the OpenAPI operation id: start_tow_api_jobs_…
    start.__doc__ = (
        f"Start a {spec.label} (the same parameters as ``rig {spec.command}``); queued while"
        " the rig is busy."
    )
    start.__signature__ = inspect.Signature(  # type: ignore[attr-defined]
        [
            inspect.Parameter("body", inspect.Parameter.KEYWORD_ONLY, annotation=spec.request),
            inspect.Parameter("service", inspect.Parameter.KEYWORD_ONLY, annotation=ServiceDep),
            inspect.Parameter("runner", inspect.Parameter.KEYWORD_ONLY, annotation=RunnerDep),
            inspect.Parameter("user", inspect.Parameter.KEYWORD_ONLY, annotation=OperatorDep),
            inspect.Parameter(
                "queue", inspect.Parameter.KEYWORD_ONLY, annotation=QueueFlag, default=True
            ),
        ],
        return_annotation=dict,
    )
    router.post(
        f"/{spec.route}",
        status_code=202,
        response_model=JobOut,
        dependencies=[Depends(require_write)],
        responses=_START,
    )(start)


for _spec in RIG_KINDS.values():
    _start_route(_spec)


@router.post(
    "/sequence",
    status_code=202,
    response_model=JobOut,
    dependencies=[Depends(require_write)],
    responses=_START,
)
def start_sequence(
    body: SequenceRequest,
    service: ServiceDep,
    runner: RunnerDep,
    user: OperatorDep,
    queue: QueueFlag = True,
) -> dict:
    """Start a sequence (the content of a sequence TOML file, as JSON); queued while the rig
    is busy. Every step is checked against the rig and the stored thrust calibration first
    (422 naming ``steps[i].field``)."""
    return _start("sequence", body, service, runner, queue, user)


@router.post(
    "/estimation",
    status_code=202,
    response_model=JobOut,
    dependencies=[Depends(require_write)],
    responses=error_responses(401, 404, 422),
)
def start_estimation(
    body: EstimationRequest,
    store: StoreDep,
    runner: RunnerDep,
    user: OperatorDep,
) -> dict:
    """Estimate coefficients from stored runs in a worker thread; poll the job for the result."""
    from api.core.estimation_job import load_estimation_runs, stored_runs

    records = stored_runs(store, body.run_ids)  # 404 for an unknown id, now
    # 422 for bad input (mixed kinds, a method the kind lacks, a run without its drive or
    # too short), so a failed job always means the fit itself failed
    load_estimation_runs(store, records, body.method)
    started = runner.start_estimation(
        [r.id for r in records], body.method, body.search_effects, user.name, body.exclude_outliers
    )
    return started.to_json()


@router.get(
    "",
    response_model=list[JobOut],
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 503),  # 503: the jobs' database unreachable
)
def list_jobs(
    runner: RunnerDep,
    job_filter: Annotated[JobFilter, Query()],
    page: Annotated[JobsPage, Query()],
) -> list[dict]:
    """This rig's jobs, newest first, from the database (so they outlive a restart). The
    filters and the page are ``api.core.job_filter.JobFilter``'s and
    ``api.core.paging.JobsPage``'s (``rig jobs`` too)."""
    found = runner.list(limit=page.limit, offset=page.offset, state=job_filter.state)
    return [j.to_json() for j in found]


@router.get(
    "/{job_id}",
    response_model=JobOut,
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 404, 503),
)
def get_job(job_id: str, runner: RunnerDep) -> dict:
    """State, progress, run ids and outcome of one job."""
    return runner.get(job_id).to_json()


@router.get(
    "/{job_id}/events",
    response_model=list[JobEventOut],
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 404, 503),
)
def job_events(job_id: str, runner: RunnerDep) -> list[dict]:
    """The job's stored progress: each change of state or message, oldest first."""
    from api.core.job_model import iso_time

    return [e | {"t_wall": iso_time(e["t_wall"])} for e in runner.events(job_id)]


def _control_route(verb: str, control: Callable[[JobRunner, str], Job], doc: str) -> None:
    """``POST /api/jobs/{job_id}/<verb>``: ``control(runner, job_id)``, the job as answer."""

    def control_job(job_id: str, runner: RunnerDep) -> dict:
        return control(runner, job_id).to_json()

    control_job.__name__ = f"{verb}_job"  # the OpenAPI operation id: abort_job_api_jobs_…
    control_job.__doc__ = doc
    router.post(
        f"/{{job_id}}/{verb}",
        response_model=JobOut,
        dependencies=[Depends(require_write)],
        responses=_CONTROL,
    )(control_job)


_control_route(
    "abort",
    JobRunner.abort,
    """Abort a job. A procedure: its run ends ``aborted``, thrusters zero, brakes on. An
    estimation or cross-check: its fit's worker process is killed and nothing of it is
    stored (409 where the analysis executor cannot stop a running fit, saying why). A queued
    job never runs and is kept as ``aborted``.""",
)
_control_route("pause", JobRunner.pause, "Pause a sequence after the step in progress.")
_control_route("resume", JobRunner.resume, "Resume a paused sequence.")
_control_route(
    "confirm",
    JobRunner.confirm,
    "Confirm the operator act a job is waiting for (state ``waiting_for_operator``).",
)


@router.post(
    "/{job_id}/alive",
    response_model=JobOut,
    dependencies=[Depends(require_write)],
    responses=_CONTROL,
)
def keep_job_alive(job_id: str, runner: RunnerDep) -> dict:
    """The dead-man of a procedure job: once called, call again within 3 s
    (``api.core.deadman.DEADMAN_S``) or the job is aborted (the page that started a manual
    thrust run says so every second; a closed tab or a lost network stops the thrust). 409
    for a job that ended or is not a procedure."""
    from api.core.deadman import keep_alive

    return keep_alive(runner, job_id).to_json()


@router.post(
    "/{job_id}/requeue",
    status_code=202,
    response_model=JobOut,
    dependencies=[Depends(require_write)],
    responses=error_responses(401, 404, 409, 422, 503),
)
def requeue_job(job_id: str, runner: RunnerDep, user: OperatorDep) -> dict:
    """Submit a past procedure job's request again: a new job, validated like any
    submission and queued while the rig is busy or the queue paused (409 for an analysis or
    a job still queued), asked for by this request's user."""
    return runner.requeue(job_id, user.name).to_json()
