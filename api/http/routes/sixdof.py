"""6-DOF routes: the vehicle files, one vehicle with its allocation matrix, and a
simulation with per-thruster commands or a generalized force (optionally with stored
surge/yaw estimation results plugged in)."""

from __future__ import annotations

from collections.abc import Sequence
from functools import partial
from typing import Annotated

from fastapi import APIRouter, Depends, HTTPException
from pydantic import BaseModel, ConfigDict, Field

from api.core import sixdof as sixdof_common
from api.http.deps import RunnerDep, StoreDep, require_read, require_write
from api.http.schemas import error_responses
from daq.store import ResultNotFound, Store
from estimation.vehicle.description import Vehicle6

router = APIRouter(prefix="/api", tags=["sixdof"])
#: Longest simulation the API runs, s.
MAX_DURATION_S = 600.0
#: Most samples one simulation may produce (duration_s / dt).
MAX_SAMPLES = 200_000
#: Right-hand-side evaluations one request may cost (≈ 5 s): a violent input is refused.
MAX_EVALUATIONS = 1_000_000
_Force = Annotated[float, Field(ge=-1e5, le=1e5)]
_Pose = Annotated[float, Field(ge=-1e4, le=1e4)]
_Speed = Annotated[float, Field(ge=-100, le=100)]


class SimulateRequest(BaseModel):
    """A 6-DOF simulation from rest (or from ``eta0``/``nu0``) with constant inputs."""

    model_config = ConfigDict(strict=True, extra="forbid")

    vehicle: str = Field(description="Vehicle name (GET /api/vehicles), e.g. 'seed002-rov'.")
    commands: list[Annotated[float, Field(ge=-1e6, le=1e6)]] | None = Field(
        None, description="One command per thruster (|u| ≤ its max_command), held constant."
    )
    force: Annotated[list[_Force], Field(min_length=6, max_length=6)] | None = Field(
        None, description="Generalized body force X, Y, Z (N), K, M, N (N·m); adds to commands."
    )
    duration_s: float = Field(gt=0, le=MAX_DURATION_S, description="Simulated time, s.")
    dt: float = Field(0.01, ge=0.001, le=1.0, description="Output sample step, s.")
    eta0: Annotated[list[_Pose], Field(min_length=6, max_length=6)] | None = Field(
        None, description="Initial x, y, z (m), φ, θ, ψ (rad), earth frame (NED)."
    )
    nu0: Annotated[list[_Speed], Field(min_length=6, max_length=6)] | None = Field(
        None, description="Initial u, v, w (m/s), p, q, r (rad/s), body frame."
    )
    estimates: list[Annotated[int, Field(ge=1, le=2**62)]] = Field(
        default_factory=list,
        max_length=12,
        description="Stored estimation result ids to plug in (surge/yaw …), in order.",
    )


def vehicle_with_estimates(
    store: Store, name: str, estimates: Sequence[int]
) -> tuple[Vehicle6, list]:
    """The vehicle file ``name`` with the coefficients of the stored estimation results
    ``estimates`` applied, and which were (404 for an unknown vehicle or result, 422 for a
    result that is not an estimation)."""
    try:
        vehicle = sixdof_common.find_vehicle(name)
    except sixdof_common.VehicleNotFound as err:
        raise HTTPException(404, str(err)) from None
    results = []
    for result_id in estimates:
        try:
            found = store.result(result_id)
        except ResultNotFound as err:
            raise HTTPException(404, str(err)) from None
        if found.kind != "estimation":
            raise ValueError(
                f"estimates: result {result_id} is a {found.kind!r} result, "
                "allowed: estimation results"
            )
        results.append((result_id, found.data))
    return sixdof_common.apply_results(vehicle, results)


@router.get("/vehicles", dependencies=[Depends(require_read)], responses=error_responses(401))
def list_vehicles() -> list[dict]:
    """Vehicle files: fixtures/vehicles, then $RIG_VEHICLES_DIR (a broken file shows its error)."""
    return [sixdof_common.vehicle_summary(n, p) for n, p in sixdof_common.vehicle_files().items()]


@router.get(
    "/vehicles/{name}",
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 404, 422),
)
def get_vehicle(name: str) -> dict:
    """One vehicle: parameters, the 18 coefficients, σ, thrusters, allocation matrix B
    (6 × n, rows X Y Z K M N, N or N·m per unit command), internal frame x fwd, y stbd,
    z down."""
    try:
        return sixdof_common.vehicle_detail(name)
    except sixdof_common.VehicleNotFound as err:
        raise HTTPException(404, str(err)) from None


@router.post(
    "/sixdof/simulate",
    dependencies=[Depends(require_write)],
    responses=error_responses(401, 404, 422),
)
def simulate_sixdof(body: SimulateRequest, store: StoreDep, runner: RunnerDep) -> dict:
    """Simulate the vehicle; the trajectory (≤ 2000 samples), steady values, final pose
    (integrated in the analysis worker process, not the rig's)."""
    if body.duration_s / body.dt > MAX_SAMPLES:
        raise ValueError(
            f"dt: got {body.dt!r}, allowed: ≥ duration_s / {MAX_SAMPLES} "
            f"({body.duration_s / MAX_SAMPLES:g} s for {body.duration_s:g} s)"
        )
    vehicle, applied = vehicle_with_estimates(store, body.vehicle, body.estimates)
    simulation = partial(
        sixdof_common.simulated_summary,
        vehicle,
        body.duration_s,
        commands=body.commands,
        force=body.force,
        dt=body.dt,
        eta0=body.eta0,
        nu0=body.nu0,
        max_evaluations=MAX_EVALUATIONS,
    )
    summary = runner.analysis.executor_for(store).call(None, simulation)
    summary["applied_estimates"] = applied
    summary["coefficients"] = vehicle.coefficients()
    return summary
