"""Rig routes: status, arm/disarm thrusters, emergency stop, health."""

from __future__ import annotations

from collections.abc import Callable, Coroutine
from typing import Annotated, Any

from fastapi import Depends, Request

from api.core.jobs import JobConflict, JobRunner
from api.core.rig_guard import RigGuard
from api.core.service import RigService
from api.http.app_codes import app_router
from api.http.deps import OperatorDep, RunnerDep, ServiceDep, require_read, require_write
from api.http.identity import anyone
from api.http.schemas import EmergencyStopOut, Health, RigStatus, error_responses
from daq.procedures.kind_spec import NotCapable
from daq.procedures.run_kinds import RIG_KINDS, capabilities
from daq.rig_capabilities import safety
from daq.session import RigSession
from daq.store.database import software_version
from daq.store.people_and_safety_log import User

router = app_router("/api", "rig")


def rig_status(service: RigService, runner: JobRunner) -> dict:
    """The rig's status with the current job and the rig's limits."""
    data = service.snapshot()
    job = runner.rig_job
    data["current_job"] = job.to_json() if job is not None else None
    rig = service.source.rig
    lim = rig.limits
    data["capabilities"] = capabilities(rig)
    data["safety"] = {name: c.to_json() for name, c in safety(rig).items()}
    limits = {
        "max_force_n": lim.max_force_n,
        "max_torque_nm": lim.max_torque_nm,
        "max_thruster_command": lim.max_thruster_command,
        "max_run_s": lim.max_run_s,
        "end_of_travel_m": service.source.rig.geometry.end_of_travel_m,
        "spin_max_angle_rad": service.source.rig.geometry.spin_max_angle_rad,
        "g": service.source.rig.rig.g,
    }
    data["limits"] = {k: v for k, v in limits.items() if v is not None}  # unset: not offered
    data["field_limits"] = {
        str(kind): spec.request.field_limits(rig)
        for kind, spec in RIG_KINDS.items()
        if spec.request is not None
    }
    data["stream_clients"] = service.broadcaster.client_count
    data["guard"] = RigGuard.of(service).state() if service.store is not None else {}
    return data


@router.get("/health", response_model=Health)
def health(request: Request, service: ServiceDep) -> dict:
    """Liveness (no token needed): is the rig service running."""
    return {
        "ok": service.running,
        "version": software_version(),
        "read_requires_token": not request.app.state.open_read,
    }


@router.get(
    "/rig",
    response_model=RigStatus,
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 503),  # 503: the safety log's database unreachable
)
def get_rig(service: ServiceDep, runner: RunnerDep) -> dict:
    """Connected, armed, stale channels, current values, lock holder, device loss, clock;
    what the rig can do (``capabilities``, with the reason for what it cannot) and which
    safety channels it has (``safety``)."""
    return rig_status(service, runner)


def _idle_session(service: RigService, runner: JobRunner, *, thrusters: bool = False):
    session = service.require_session()
    if thrusters and session.rig.thrusters is None:
        reason = "arming: needs a [thrusters] section"
        raise NotCapable("thrusters", None, reason, session.rig.rig.name)
    job = runner.rig_job
    if job is not None or session.lock_holder is not None:
        holder = f"{job.label} (job {job.id})" if job is not None else session.lock_holder
        raise JobConflict(f"rig is busy: {holder} holds the rig lock", holder=holder)
    return session


def _thrusters_route(
    verb: str, switch: Callable[[RigSession], Coroutine[Any, Any, None]], doc: str
) -> None:
    """``POST /api/rig/<verb>``: ``switch`` the thrusters of an idle rig (409 while a job or
    another client holds the rig), the rig's status as answer."""

    def switch_thrusters(service: ServiceDep, runner: RunnerDep, user: OperatorDep) -> dict:
        session = _idle_session(service, runner, thrusters=True)
        if verb == "arm":  # no motion after an unacknowledged e-stop or in another's hold
            RigGuard.of(service).check_start(user.name)
        service.run(switch(session))
        return rig_status(service, runner)

    switch_thrusters.__name__ = verb  # the OpenAPI operation id: arm_api_rig_arm_post
    switch_thrusters.__doc__ = doc
    router.post(
        f"/rig/{verb}",
        response_model=RigStatus,
        dependencies=[Depends(require_write)],
        responses=error_responses(401, 403, 409, 423, 503),
    )(switch_thrusters)


_thrusters_route(
    "arm",
    RigSession.arm_thrusters,
    "Arm the thrusters (outputs stay at zero until a procedure commands them).",
)
_thrusters_route("disarm", RigSession.disarm_thrusters, "Command zero and disarm the thrusters.")


@router.post(
    "/rig/emergency-stop",
    response_model=EmergencyStopOut,
    responses=error_responses(503),
)
def emergency_stop(runner: RunnerDep, user: Annotated[User | None, Depends(anyone)]) -> dict:
    """Abort whatever runs and put the rig in its safe state (thrusters zero, brakes on);
    the rig then refuses motion until an operator acknowledges the stop
    (``POST /api/estop/ack``). **No token needed**: anyone who can reach the service may
    stop the rig (a cross-site request could too: it can only make the rig safer); a
    valid token names who pressed it in the safety log."""
    aborted = runner.emergency_stop(user.name if user is not None else None)
    return {"aborted_jobs": aborted, "safe_state": True}
