"""Job routes: start tow / spin / pendulum / calibration / sequence / estimation, watch,
control."""

from __future__ import annotations

from fastapi import APIRouter, Depends

from api.deps import RunnerDep, ServiceDep, StoreDep, require_read, require_write
from api.schemas import (
    CalibrationRequest,
    EstimationRequest,
    JobOut,
    PendulumRequest,
    SequenceRequest,
    SpinRequest,
    TowRequest,
    error_responses,
)
from daq.procedures.params import (
    calibration_parameters,
    pendulum_parameters,
    spin_parameters,
    tow_parameters,
)
from daq.procedures.sequence import parse_sequence

router = APIRouter(prefix="/api/jobs", tags=["jobs"])
_START = error_responses(401, 409, 422, 503)
_CONTROL = error_responses(401, 404, 409, 503)


@router.post(
    "/tow",
    status_code=202,
    response_model=JobOut,
    dependencies=[Depends(require_write)],
    responses=_START,
)
def start_tow(
    body: TowRequest,
    service: ServiceDep,
    runner: RunnerDep,
) -> dict:
    """Start a tow test (the same parameters as ``rig tow``)."""
    params = tow_parameters(body.parameters(), service.source.rig)
    label = f"tow {params.force_n:.4g} N" + (" (thrusters)" if params.drive == "thrusters" else "")
    return runner.start_procedure("tow", params, label, body.run_metadata()).to_json()


@router.post(
    "/spin",
    status_code=202,
    response_model=JobOut,
    dependencies=[Depends(require_write)],
    responses=_START,
)
def start_spin(
    body: SpinRequest,
    service: ServiceDep,
    runner: RunnerDep,
) -> dict:
    """Start a spin test (the same parameters as ``rig spin``)."""
    params = spin_parameters(body.parameters(), service.source.rig)
    label = f"spin {params.torque_nm:.4g} N·m" + (
        " (thrusters)" if params.drive == "thrusters" else ""
    )
    return runner.start_procedure("spin", params, label, body.run_metadata()).to_json()


@router.post(
    "/pendulum",
    status_code=202,
    response_model=JobOut,
    dependencies=[Depends(require_write)],
    responses=_START,
)
def start_pendulum(
    body: PendulumRequest,
    service: ServiceDep,
    runner: RunnerDep,
) -> dict:
    """Start a pendulum free-decay test (the same parameters as ``rig pendulum``)."""
    params = pendulum_parameters(body.parameters(), service.source.rig)
    label = f"pendulum {params.start_angle_rad:.3g} rad"
    return runner.start_procedure("pendulum", params, label, body.run_metadata()).to_json()


@router.post(
    "/calibration",
    status_code=202,
    response_model=JobOut,
    dependencies=[Depends(require_write)],
    responses=_START,
)
def start_calibration(
    body: CalibrationRequest,
    service: ServiceDep,
    runner: RunnerDep,
) -> dict:
    """Start a thrust calibration sweep (``rig calibrate-thrusters``)."""
    params = calibration_parameters(body.parameters(), service.source.rig)
    job = runner.start_procedure(
        "thrust_calibration", params, "thrust calibration", body.run_metadata()
    )
    return job.to_json()


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
    seq = parse_sequence(body.parameters(), service.source.rig, source="api")
    label = f"sequence {seq.name} ({len(seq.steps) * seq.repeats} runs)"
    return runner.start_procedure("sequence", seq, label, body.run_metadata()).to_json()


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
