"""6-DOF routes: the vehicle files, one vehicle with its allocation matrix, and a
simulation with per-thruster commands or a generalized force (optionally with stored
surge/yaw estimation results plugged in)."""

from __future__ import annotations

from collections.abc import Sequence
from functools import partial

from fastapi import Depends, HTTPException

from api.core import sixdof as sixdof_common
from api.core import vehicle_files
from api.http.app_codes import app_router
from api.http.deps import RunnerDep, StoreDep, require_read, require_write
from api.http.schemas import error_responses
from daq.store import ResultNotFound, Store
from estimation.vehicle.description import Vehicle6

router = app_router("/api", "sixdof")


def vehicle_with_estimates(
    store: Store, name: str, estimates: Sequence[int]
) -> tuple[Vehicle6, list]:
    """The vehicle file ``name`` with the coefficients of the stored estimation results
    ``estimates`` applied, and which were (404 for an unknown vehicle or result, 422 for a
    result that is not an estimation)."""
    try:
        vehicle = vehicle_files.find_vehicle(name)
    except vehicle_files.VehicleNotFound as err:
        raise HTTPException(404, str(err)) from None
    try:
        results = sixdof_common.stored_estimates(store, estimates)
    except ResultNotFound as err:
        raise HTTPException(404, str(err)) from None
    return sixdof_common.apply_results(vehicle, results)


@router.get("/vehicles", dependencies=[Depends(require_read)], responses=error_responses(401))
def list_vehicles() -> list[dict]:
    """Vehicle files: fixtures/vehicles, then $RIG_VEHICLES_DIR (a broken file shows its error)."""
    return [vehicle_files.vehicle_summary(n, p) for n, p in vehicle_files.vehicle_files().items()]


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
    except vehicle_files.VehicleNotFound as err:
        raise HTTPException(404, str(err)) from None


@router.post(
    "/sixdof/simulate",
    dependencies=[Depends(require_write)],
    responses=error_responses(401, 404, 422),
)
def simulate_sixdof(
    body: sixdof_common.SimulateRequest, store: StoreDep, runner: RunnerDep
) -> dict:
    """Simulate the vehicle; the trajectory (≤ 2000 samples), steady values, final pose
    (integrated in the analysis worker process, not the rig's). The body is
    ``api.core.sixdof.SimulateRequest`` (``rig sixdof``'s options too)."""
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
        max_evaluations=sixdof_common.MAX_EVALUATIONS,
    )
    summary = runner.analysis.executor_for(store).call(None, simulation)
    summary["applied_estimates"] = applied
    summary["coefficients"] = vehicle.coefficients()
    return summary
