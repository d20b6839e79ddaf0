"""Job routes: start tow / spin / pendulum / calibration / sequence / estimation, watch,
control."""

from __future__ import annotations

import inspect

from fastapi import APIRouter, Depends

from api.deps import RunnerDep, ServiceDep, StoreDep, require_read, require_write
from api.jobs import JobRunner
from api.schemas import EstimationRequest, JobOut, SequenceRequest, error_responses
from api.service import RigService
from daq.procedures.kinds import KINDS, KindSpec
from daq.procedures.sequence import parse_sequence

router = APIRouter(prefix="/api/jobs", tags=["jobs"])
_START = error_responses(401, 409, 422, 503)
_CONTROL = error_responses(401, 404, 409, 503)


def _start_route(spec: KindSpec) -> None:
    """``POST /api/jobs/<route>``: the kind's request model as body, validated against the
    rig (422 naming the field), then started as a job (409 when the rig is held)."""

    def start(body, service: RigService, runner: JobRunner) -> dict:
        params = spec.validate(body.model_dump(exclude_none=True), service.source.rig)
        return runner.start_procedure(spec.kind, params, spec.describe(params)).to_json()

    start.__name__ = f"start_{spec.route}"  # the OpenAPI operation id: start_tow_api_jobs_…
    start.__doc__ = f"Start a {spec.label} (the same parameters as ``rig {spec.command}``)."
    start.__signature__ = inspect.Signature(  # type: ignore[attr-defined]
        [
            inspect.Parameter("body", inspect.Parameter.KEYWORD_ONLY, annotation=spec.request),
            inspect.Parameter("service", inspect.Parameter.KEYWORD_ONLY, annotation=ServiceDep),
            inspect.Parameter("runner", inspect.Parameter.KEYWORD_ONLY, annotation=RunnerDep),
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


for _spec in KINDS.values():
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
) -> dict:
    """Start a sequence (the content of a sequence TOML file, as JSON)."""
    seq = parse_sequence(body.model_dump(exclude_none=True), service.source.rig, source="api")
    label = f"sequence {seq.name} ({len(seq.steps) * seq.repeats} runs)"
    return runner.start_procedure("sequence", seq, label).to_json()


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
) -> dict:
    """Estimate coefficients from stored runs in a worker thread; poll the job for the result."""
    from api.estimation_job import check_estimation_request

    run_ids = [store.get_run(r).id for r in body.run_ids]  # 404 for an unknown id, now
    check_estimation_request(store, run_ids, body.method)  # 422: mixed kinds, method per kind
    return runner.start_estimation(run_ids, body.method, body.search_effects).to_json()


@router.get(
    "",
    response_model=list[JobOut],
    dependencies=[Depends(require_read)],
    responses=error_responses(401),
)
def list_jobs(runner: RunnerDep) -> list[dict]:
    """Jobs of this service, newest first."""
    return [j.to_json() for j in runner.list()]


@router.get(
    "/{job_id}",
    response_model=JobOut,
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 404),
)
def get_job(job_id: str, runner: RunnerDep) -> dict:
    """State, progress, run ids and outcome of one job."""
    return runner.get(job_id).to_json()


@router.post(
    "/{job_id}/abort",
    response_model=JobOut,
    dependencies=[Depends(require_write)],
    responses=_CONTROL,
)
def abort_job(job_id: str, runner: RunnerDep) -> dict:
    """Abort a procedure: its run ends ``aborted``, thrusters zero, brakes on."""
    return runner.abort(job_id).to_json()


@router.post(
    "/{job_id}/pause",
    response_model=JobOut,
    dependencies=[Depends(require_write)],
    responses=_CONTROL,
)
def pause_job(job_id: str, runner: RunnerDep) -> dict:
    """Pause a sequence after the step in progress."""
    return runner.pause(job_id).to_json()


@router.post(
    "/{job_id}/resume",
    response_model=JobOut,
    dependencies=[Depends(require_write)],
    responses=_CONTROL,
)
def resume_job(job_id: str, runner: RunnerDep) -> dict:
    """Resume a paused sequence."""
    return runner.resume(job_id).to_json()


@router.post(
    "/{job_id}/confirm",
    response_model=JobOut,
    dependencies=[Depends(require_write)],
    responses=_CONTROL,
)
def confirm_job(job_id: str, runner: RunnerDep) -> dict:
    """Confirm the operator act a job is waiting for (state ``waiting_for_operator``)."""
    return runner.confirm(job_id).to_json()
